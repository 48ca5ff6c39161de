"""Write docs/reference/scenes.md, the reference of every scene key, from the scene schemas.

The page is made from what the scene parser itself checks against: the
section schemas of :mod:`contin.scene.parse` (``model`` for built-in and
custom models, ``output``), the schema of each analysis of the table
:data:`contin.scene.registry.ANALYSES` (with the keys a further start of
``frequency_response`` may change), the quantity schemas of
the ``convergence`` analysis, and the fields of the option dataclasses that
the mappings ``continuation``, ``stability_options``, ``curve_options`` and
``shooting_options`` are read into, with the descriptions of their
docstrings. ``tests/docs/test_scene_reference.py`` fails when the committed
page differs from what this script writes.

    python scripts/docs/scene_reference.py           # writes docs/reference/scenes.md
    python scripts/docs/scene_reference.py --check   # exit status 1 when the committed page is not current
    python scripts/docs/scene_reference.py --quick   # the same as --check (the scripts' smoke test)
"""

from __future__ import annotations

import argparse
import dataclasses
import enum
import importlib
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "reference" / "scenes.md"
COMMAND = "python scripts/docs/scene_reference.py"

#: option mappings of the scenes -> (module, dataclass) they are read into
OPTION_CLASSES = (
    ("continuation, curve_continuation", "contin.engine.continuation", "ContinuationOptions"),
    ("stability_options", "contin.stability", "StabilityOptions"),
    ("curve_options", "contin.bifurcation.two_parameter", "CurveOptions"),
    ("shooting_options", "contin.timedomain.shooting", "ShootingOptions"),
)

#: where the ``convergence`` analysis keeps the schemas of its quantities: (module, name)
QUANTITY_SCHEMAS = ("contin.analyses.convergence_plan", "QUANTITIES")

_ROLE = re.compile(r":(?:func|class|meth|mod|data|attr|obj):`(~?)([^`]+)`")


def _markdown(text: str) -> str:
    """reStructuredText roles and literals of a docstring as Markdown code spans, on one line."""
    # ``:func:`~a.b.c` `` shows ``c``, as Sphinx does
    text = _ROLE.sub(lambda m: f"`{m.group(2).rsplit('.', 1)[-1] if m.group(1) else m.group(2)}`", text)
    text = text.replace("``", "`")
    return " ".join(text.split()).replace("|", "\\|")


def _value(v) -> str:
    """A default as it would be written in a scene."""
    if isinstance(v, enum.Enum):
        v = v.value
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return v if v else "''"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k}: {_value(x)}" for k, x in v.items()) + "}"
    return repr(v)


def _option_keys() -> dict:
    """Scene key -> name of the option class its mapping is read into."""
    return {k.strip(): cls for keys, _, cls in OPTION_CLASSES for k in keys.split(",")}


def schema_table(schema: dict) -> list[str]:
    """Markdown table of a section schema: key, the form expected, default."""
    options = _option_keys()
    rows = ["| key | expected | default |", "| --- | --- | --- |"]
    for key, spec in schema.items():
        default = "required" if spec.required else f"`{_value(spec.default)}`"
        expected = _markdown(spec.expected)
        if key in options:
            expected = f"a mapping of `{options[key]}` fields ([below](#option-mappings))"
        rows.append(f"| `{key}` | {expected} | {default} |")
    return rows


def attribute_docs(cls) -> dict:
    """Field name -> description, from the numpydoc ``Attributes`` section of ``cls``'s docstring."""
    doc = (cls.__doc__ or "").expandtabs()
    lines = doc.splitlines()
    out: dict = {}
    try:
        start = next(i for i, line in enumerate(lines) if line.strip() == "Attributes")
    except StopIteration:
        return out
    names: list = []
    body: list = []
    indent = None
    for line in lines[start + 2:]:
        if not line.strip():
            continue
        level = len(line) - len(line.lstrip())
        if indent is None:
            indent = level
        if level < indent:
            break
        if level == indent:
            if re.match(r"^\s*[A-Za-z_][\w, ]*\s*:", line) is None and ":" not in line:
                break  # the next section's title
            for n in names:
                out[n] = _markdown(" ".join(body))
            names = [n.strip() for n in line.split(":", 1)[0].split(",")]
            body = []
        else:
            body.append(line.strip())
    for n in names:
        out[n] = _markdown(" ".join(body))
    return out


def options_table(cls) -> list[str]:
    docs = attribute_docs(cls)
    rows = ["| key | default | meaning |", "| --- | --- | --- |"]
    for f in dataclasses.fields(cls):
        if f.metadata.get("scene") is False:  # an option no scene sets
            continue
        if f.default is not dataclasses.MISSING:
            default = f"`{_value(f.default)}`"
        elif f.default_factory is not dataclasses.MISSING:
            default = f"`{_value(f.default_factory())}`"
        else:
            default = "required"
        rows.append(f"| `{f.name}` | {default} | {docs.get(f.name, '')} |")
    return rows


def summary_line(module) -> str:
    """The first line of a module's docstring, less a leading ``name``: label."""
    first = (module.__doc__ or "").strip().splitlines()[0] if module.__doc__ else ""
    text = _markdown(re.sub(r"^``\w+``:\s*", "", first))
    return text[:1].upper() + text[1:]


def render() -> str:
    """The page's text."""
    from contin.scene import fe_model, parse
    from contin.scene.registry import analysis

    schemas = parse.analysis_schemas()  # in the table's order
    out = [
        "# Scene keys",
        "",
        f"<!-- generated by `{COMMAND}` from the scene schemas; do not edit by hand -->",
        "",
        "Every key a scene file may hold, with the form the scene parser expects and the value",
        "used when the key is left out. This page is generated from the schemas the parser checks",
        f"against (`{COMMAND}`), so it lists exactly what `contin check` accepts. Beyond these",
        "forms a scene is refused for the values listed in [Refused values](scene-checks.md).",
        "",
        "A scene has three sections: `model` (a built-in model or a custom one), `analysis`",
        "(its `type` selects the keys below) and `output`. `--set dotted.key=value` on the command",
        "line changes any of them (the value is read as YAML).",
        "",
        "## model: a built-in model",
        "",
        "`contin models` lists the models with their parameters, defaults and effects",
        "([Built-in models](models.md)).",
        "",
        *schema_table(parse.BUILTIN_MODEL),
        "",
        "## model: a custom model",
        "",
        "A section with `dofs` instead of `builtin` ([Custom models](../howto/custom-models.md)).",
        "",
        *schema_table(parse.CUSTOM_MODEL),
        "",
        "## model: a finite-element rotor",
        "",
        "A section with `from: ross` ([Finite-element rotors](../howto/fe-rotors.md)): a rotor file and the",
        "items placed at its nodes, in SI.",
        "",
        *schema_table(fe_model.FE_MODEL),
        *[line for key, schema in fe_model.ITEMS.items()
          for line in ("", f"`{key}`" + (" (each item)" if key == "unbalance" else "") + ":", "",
                       *schema_table(schema))],
        "",
        "## output",
        "",
        *schema_table(parse.OUTPUT),
        "",
        "## analysis",
        "",
        "`analysis.type` is one of " + ", ".join(f"`{t}`" for t in schemas) + ".",
    ]
    for atype, schema in schemas.items():
        module = importlib.import_module(type(analysis(atype)).__module__)
        out += ["", f"### type: {atype}", "", summary_line(module), "", *schema_table(schema)]
        if atype == "frequency_response":
            out += ["", "Each entry of `analysis.starts` is a further start, drawn in the same diagram; it may "
                    "change these keys (the others are shared): "
                    + ", ".join(f"`{k}`" for k in module.START_KEYS) + "."]
        if atype == "convergence":
            quantities = getattr(importlib.import_module(QUANTITY_SCHEMAS[0]), QUANTITY_SCHEMAS[1])
            out += ["", "Each entry of `quantities` is a type name or a mapping with a `type` and these keys:"]
            for qtype, qschema in quantities.items():
                out += ["", f"#### quantity: {qtype}", "", *schema_table(qschema)]
    out += ["", "## Option mappings", "",
            "These mappings of an `analysis` section are read into option objects; their keys are the",
            "objects' fields."]
    for keys, modname, clsname in OPTION_CLASSES:
        cls = getattr(importlib.import_module(modname), clsname)
        title = ", ".join(f"`{k.strip()}`" for k in keys.split(","))
        out += ["", f"### {title}", "", f"`{modname}.{clsname}`", "", *options_table(cls)]
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="compare with the committed page, write nothing")
    ap.add_argument("--quick", action="store_true", help="the same as --check")
    ap.add_argument("--out", type=Path, default=PAGE, help="the page to write or check")
    args = ap.parse_args(argv)
    text = render()
    name = args.out.relative_to(ROOT) if args.out.is_relative_to(ROOT) else args.out
    if args.check or args.quick:
        current = args.out.read_text(encoding="utf-8") if args.out.exists() else ""
        if current != text:
            print(f"{name} is not current: run `{COMMAND}`")
            return 1
        print(f"{name} is current ({text.count(chr(10))} lines)")
        return 0
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    print(f"wrote {name} ({text.count(chr(10))} lines)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
