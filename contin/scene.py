"""Scene files: YAML loading, ``--set`` overrides, schema check and defaults.

A scene has three sections, ``model``, ``analysis`` and ``output`` (SPEC 4.2).
Loading uses PyYAML's safe loader, with YAML 1.2's float syntax (PyYAML
follows YAML 1.1, where ``1e-6`` without a dot is a string); the schema check then reports every problem
as a :class:`SceneError` naming the dotted key, the expected form, what was
found and, where the YAML parser knows it, the line.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from contin.model import suggest
from contin.schema import (Key, SceneError, anything, check_section, integer, is_int, is_number, listing,
                           mapping, number, string)

__all__ = ["SceneError", "Scene", "load_scene", "parse_scene", "scene_from_data", "apply_override", "analysis_schemas", "SceneLoader"]


class SceneLoader(yaml.SafeLoader):
    """Safe YAML loader that reads ``1e-6`` as a number, as YAML 1.2 does, and refuses a key given twice
    in one mapping (PyYAML keeps the last silently; a merge ``<<`` may still be overridden)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen: dict = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=deep)
                try:
                    if key in seen:
                        raise yaml.constructor.ConstructorError(
                            "while constructing a mapping", node.start_mark,
                            f"the key {key!r} is given twice (first on line {seen[key]})", key_node.start_mark)
                except TypeError:  # an unhashable key: the base class reports it
                    continue
                seen[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep)


SceneLoader.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
SceneLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
    |\.[0-9_]+(?:[eE][-+][0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""", re.X),
    list("-+0123456789."),
)


#: values a scene may hold once its YAML aliases are expanded (a scene has a few hundred)
MAX_VALUES = 100_000
#: nesting depth a scene may have (a scene has about five levels)
MAX_DEPTH = 64


def _load(text: str, source: str = "<string>"):
    data = yaml.load(text, Loader=SceneLoader)  # noqa: S506  (a SafeLoader subclass)
    _check_expansion(data, source)
    return data


def _check_expansion(data, source: str) -> None:
    """Refuse what YAML aliases can build: a structure that contains itself, or one that expands
    to more values than any scene holds (the "billion laughs" of nested aliases)."""
    count = 0
    stack = [(data, 0, ())]
    while stack:
        node, depth, path = stack.pop()
        count += 1
        if count > MAX_VALUES:
            raise SceneError(source, f"a scene of at most {MAX_VALUES} values with its YAML aliases expanded",
                             "more (aliases nested within aliases)")
        if isinstance(node, (dict, list)):
            if id(node) in path:
                raise SceneError(source, "YAML whose aliases do not refer to themselves", "a recursive alias")
            if depth >= MAX_DEPTH:
                raise SceneError(source, f"YAML nested at most {MAX_DEPTH} levels deep", "deeper nesting")
            inner = (*path, id(node))
            items = list(node.keys()) + list(node.values()) if isinstance(node, dict) else node
            stack.extend((v, depth + 1, inner) for v in items)


# ---------------------------------------------------------------- schema
CONTINUATION_KEYS = mapping()  # validated by ContinuationOptions.from_dict

#: keys a further start (``analysis.starts``) may change; the others are shared
START_KEYS = ("start", "start_from", "start_simulation", "subharmonic", "harmonics", "samples", "crossings", "both_ways",
              "guess", "stability_options", "switch", "continuation")

FREQUENCY_RESPONSE = {
    "type": string(required=True),
    "parameter": string(),
    "range": Key("a list of two different numbers [start, end]",
                 lambda v: isinstance(v, list) and len(v) == 2 and all(is_number(x) for x in v) and v[0] != v[1],
                 required=True),
    "start": number(),
    "frequency": string(),
    "harmonics": Key("an integer from 1 to 2000", lambda v: is_int(v) and 1 <= v <= 2000, 5),
    "subharmonic": Key("an integer from 1 to 64", lambda v: is_int(v) and 1 <= v <= 64, 1),
    "samples": Key("an integer from 2*harmonics+1 to 2**20, or null",
                   lambda v: v is None or (is_int(v) and 3 <= v <= 2**20), None),
    "crossings": string("exact", ("exact", "interval", "none")),
    # eliminate the dofs free of nonlinear forces exactly (contin.condensation)
    "condense": Key("'auto', true or false", lambda v: v == "auto" or isinstance(v, bool), "auto"),
    "stability": string("both", ("hill", "floquet", "both", "none")),
    "stability_options": mapping(),
    "switch": listing([], lambda x: x in ("pd", "bp"), "a list of bifurcation kinds among 'pd', 'bp'"),
    "max_branches": integer(8, 1),
    "continuation": CONTINUATION_KEYS,
    "start_from": string("model", ("model", "linear", "simulation")),
    "start_simulation": mapping(),
    "both_ways": Key("true or false", lambda v: isinstance(v, bool), False),
    "guess": Key("a list of numbers (the harmonic coefficients) or null",
                 lambda v: v is None or (isinstance(v, list) and all(is_number(x) for x in v)), None),
    "starts": listing([], lambda x: isinstance(x, dict),
                      "a list of mappings, each a further start with keys among " + ", ".join(START_KEYS)),
}


OUTPUT = {
    "measure": string(),
    "plots": Key("true or false", lambda v: isinstance(v, bool), True),
    "harmonic_columns": integer(5, 0),
    "units": mapping(),
    "labels": mapping(),
    "title": string(),
}

BUILTIN_MODEL = {
    "builtin": string(required=True),
    "parameters": mapping(),
    "effects": Key("a list of effect names", lambda v: v is None or (isinstance(v, list) and all(isinstance(x, str) for x in v)), None),
    "options": mapping(),
}

CUSTOM_MODEL = {
    "name": string("custom"),
    "dofs": Key("a non-empty list of distinct names", lambda v: isinstance(v, list) and len(v) > 0
                and all(isinstance(x, str) and x.isidentifier() for x in v) and len(set(v)) == len(v), required=True),
    "parameters": mapping(),
    "mass": anything(),
    "damping": anything(),
    "stiffness": anything(),
    "gyroscopic": mapping(None),
    "forces": listing([]),
    "excitation": listing([]),
    "frequency": string("w"),
}


@dataclass
class Scene:
    """A validated scene with defaults filled in.

    Attributes
    ----------
    data : dict
        The scene (``model``, ``analysis``, ``output``), defaults included.
    source : str
        File name or ``"<string>"``.
    lines : dict
        Dotted key to YAML line number (1-based), where known.
    """

    data: dict
    source: str = "<string>"
    lines: dict = field(default_factory=dict)

    @property
    def model(self) -> dict:
        return self.data["model"]

    @property
    def analysis(self) -> dict:
        return self.data["analysis"]

    @property
    def output(self) -> dict:
        return self.data["output"]

    def error(self, key: str, expected: str, found: Any = None, hint: str = "") -> SceneError:
        return SceneError(key, expected, found, self.lines.get(key), hint)


def _line_map(text: str) -> dict:
    """Dotted key -> line number, from the YAML node tree."""
    lines: dict = {}
    try:
        root = yaml.compose(text, Loader=SceneLoader)
    except yaml.YAMLError:
        return lines

    def walk(node, prefix):
        if isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                key = f"{prefix}.{k.value}" if prefix else str(k.value)
                lines[key] = k.start_mark.line + 1
                walk(v, key)
        elif isinstance(node, yaml.SequenceNode):
            for i, v in enumerate(node.value):
                key = f"{prefix}[{i}]"
                lines[key] = v.start_mark.line + 1
                walk(v, key)

    if root is not None:
        walk(root, "")
    return lines


def apply_override(data: dict, assignment: str) -> None:
    """Apply ``dotted.key=value`` (value parsed as YAML) to ``data`` in place."""
    if "=" not in assignment:
        raise SceneError("--set", "dotted.key=value", assignment)
    key, _, text = assignment.partition("=")
    key = key.strip()
    if not key or any(not part for part in key.split(".")):
        raise SceneError("--set", "a dotted key such as model.parameters.f0", key)
    try:
        value = _load(text, f"--set {key}") if text.strip() else None
    except yaml.YAMLError as exc:
        raise SceneError(f"--set {key}", "a YAML value", text, hint=f" ({str(exc).splitlines()[0]})") from None
    node = data
    parts = key.split(".")
    for i, part in enumerate(parts[:-1]):
        nxt = node.get(part)
        if nxt is None:
            nxt = node[part] = {}
        if not isinstance(nxt, dict):
            raise SceneError(f"--set {key}", f"'{'.'.join(parts[: i + 1])}' to be a mapping", nxt)
        node = nxt
    node[parts[-1]] = value


def parse_scene(text: str, source: str = "<string>", overrides=()) -> Scene:
    """Parse, override and validate a scene given as YAML text.

    Raises
    ------
    SceneError
        On malformed YAML or any schema violation.
    """
    try:
        data = _load(text, source)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise SceneError(source, "valid YAML", None, line, hint=f"; the YAML parser says: {problem}") from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise SceneError("(top level)", "a mapping with the sections model, analysis, output", type(data).__name__)
    for ov in overrides:
        apply_override(data, ov)
    return scene_from_data(data, source, _line_map(text))


def scene_from_data(data: dict, source: str = "<string>", lines: dict | None = None) -> Scene:
    """Validate scene data already loaded (a mapping with ``model``, ``analysis``, ``output``).

    Parameters
    ----------
    data : dict
        The scene as loaded from YAML; not modified.
    source : str
        File name for messages.
    lines : dict, optional
        Dotted key to YAML line number.

    Raises
    ------
    SceneError
        On any schema violation.
    """
    lines = lines or {}
    for k in data:
        if k not in ("model", "analysis", "output"):
            raise SceneError(k, "one of the sections model, analysis, output", None, lines.get(k),
                             hint=f"; unknown key '{k}'{suggest(k, ('model', 'analysis', 'output'))}")
    for sec in ("model", "analysis"):
        if not isinstance(data.get(sec), dict):
            raise SceneError(sec, "a mapping (required section)", data.get(sec), lines.get(sec))
    model = data["model"]
    schema = BUILTIN_MODEL if "builtin" in model else CUSTOM_MODEL
    model = check_section(model, schema, "model", lines)
    analysis = data["analysis"]
    atype = analysis.get("type")
    schemas = analysis_schemas()
    if not isinstance(atype, str) or atype not in schemas:
        raise SceneError("analysis.type", "one of " + ", ".join(repr(a) for a in schemas), atype,
                         lines.get("analysis.type"), hint=suggest(atype, schemas) if isinstance(atype, str) else "")
    analysis = check_section(analysis, schemas[atype], "analysis", lines)
    if atype == "frequency_response":
        start_schema = {k: FREQUENCY_RESPONSE[k] for k in START_KEYS}
        for i, extra in enumerate(analysis["starts"]):
            check_section(extra, start_schema, f"analysis.starts[{i}]", lines)
    from contin.analyses import ANALYSIS_VALIDATORS

    if atype in ANALYSIS_VALIDATORS:
        ANALYSIS_VALIDATORS[atype](data, model, analysis, lines)
    output = data.get("output") or {}
    if not isinstance(output, dict):
        raise SceneError("output", "a mapping", output, lines.get("output"))
    output = check_section(output, OUTPUT, "output", lines)
    return Scene({"model": model, "analysis": analysis, "output": output}, source, lines)


def load_scene(path: str | Path, overrides=()) -> Scene:
    """Read and validate a scene file; see :func:`parse_scene`."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SceneError(str(path), "a readable scene file", None, hint=f" ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise SceneError(str(path), "a scene file in UTF-8", f"byte 0x{exc.object[exc.start]:02x} at offset {exc.start}",
                         hint=" (save the file as UTF-8)") from None
    return parse_scene(text, str(path), overrides)


def analysis_schemas() -> dict:
    """``analysis.type`` name -> schema of its section, for every registered analysis."""
    from contin.analyses import ANALYSIS_SCHEMAS, load_all

    load_all()
    return {"frequency_response": FREQUENCY_RESPONSE, **ANALYSIS_SCHEMAS}
