"""Scene files: YAML loading, ``--set`` overrides, schema check and defaults.

A scene has three sections, ``model``, ``analysis`` and ``output`` (SPEC 4.2).
Loading uses PyYAML's safe loader, with YAML 1.2's float syntax (PyYAML
follows YAML 1.1, where ``1e-6`` without a dot is a string; :mod:`contin.scene.yaml_text`), on a file
read once under a size cap (:mod:`contin.scene.files`); the schema check then reports every problem
as a :class:`SceneError` naming the dotted key, the expected form, what was
found and, where the YAML parser knows it, the line.

Beyond the schema a scene is refused for names that are not in Unicode
normal form NFKC (:func:`check_names`: Python reads identifiers in that form,
so look-alikes would merge), for parameter values that make no physical
sense in a built-in model (:attr:`contin.model.catalog.ModelSpec.constraints`), and
for values an analysis gives a parameter against the same rules, a negative
excitation frequency included (:func:`check_parameter_values`). The checks
that need the built model are each analysis's ``check``
(:func:`contin.scene.registry.check_scene`). docs/reference/scene-checks.md lists them all.
"""

from __future__ import annotations

import unicodedata
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from contin.model.catalog import get_spec, rule_violation
from contin.util.naming import suggest
from contin.output.formats import EXPORT_FORMATS, FIGURE_FORMATS, is_style
from contin.output.panel_options import PANELS_EXPECTED, ZOOM_EXPECTED, PanelError, ZoomWindow, is_panel_list
from contin.scene.schema import (Key, SceneError, anything, check_section, integer, is_int, listing,
                           mapping, string)
from contin.scene import registry
from contin.scene.fe_model import FE_RULES, check_fe_section
from contin.scene.files import SCENE_FILE_CAP, input_key, read_input, size_text
from contin.scene.yaml_text import MAX_DEPTH, MAX_VALUES, SceneLoader, line_map, load_nodes, load_text  # noqa: F401

__all__ = ["SceneError", "Scene", "load_scene", "parse_scene", "read_scene_text", "scene_from_data", "apply_override", "cite_override", "analysis_schemas",
           "SceneLoader", "check_names", "check_parameter_values", "model_frequency",
           "parameter_rule", "check_model_section"]


# ---------------------------------------------------------------- schema
OUTPUT = {
    "measure": string(),
    "plots": Key("true or false", lambda v: isinstance(v, bool), True),
    "harmonic_columns": integer(5, 0),
    "units": mapping(),
    "labels": mapping(),
    "title": string(),
    # several measures in stacked panels, a window beside them (contin.output.panel_options)
    "panels": Key(PANELS_EXPECTED, is_panel_list, None),
    "zoom": Key(ZOOM_EXPECTED, lambda v: isinstance(v, dict), None),
    # figures: file formats, resolution of raster files, style (contin.output.figures)
    "formats": listing(["png"], lambda x: x in FIGURE_FORMATS,
                       "a list of figure formats among " + ", ".join(repr(f) for f in FIGURE_FORMATS)),
    "dpi": Key("an integer from 50 to 1200 (dots per inch of PNG figures)", lambda v: is_int(v) and 50 <= v <= 1200,
               200),
    "style": Key("'contin', 'paper', 'presentation' or the name of a style shipped with matplotlib",
                 is_style, "contin"),
    # data files beside the CSV tables (contin.output.exports)
    "exports": listing(["npz"], lambda x: x in EXPORT_FORMATS,
                       "a list of export formats among " + ", ".join(repr(f) for f in EXPORT_FORMATS)),
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
    "symbols": mapping(),  # how figures write names: name -> mathtext (contin.output.labels)
}


# ---------------------------------------------------------------- names
#: keys whose values are free text (titles, axis labels, units, a model's name), not names
FREE_TEXT_KEYS = ("title", "name")
#: mappings whose keys are names but whose values are free text
FREE_TEXT_MAPPINGS = ("labels", "units")


def _look_alike(text: str) -> str:
    """The characters of ``text`` that NFKC changes, each with the text it becomes."""
    parts = [f"{c!r} (U+{ord(c):04X}) reads as {unicodedata.normalize('NFKC', c)!r}"
             for c in dict.fromkeys(text) if unicodedata.normalize("NFKC", c) != c]
    return ", ".join(parts) if parts else "its characters combine into others"


def check_names(data, lines: dict | None = None, prefix: str = "") -> None:
    """Refuse a key or name that is not in Unicode normal form NFKC.

    Python's parser reads identifiers in NFKC, so an expression would read
    ``ﬁ`` (U+FB01) as ``fi`` and a fullwidth ``ｘ`` as ``x``: names that look
    distinct in a scene would silently be one. Every mapping key and every
    string value must equal its NFKC form, except free text (``title``,
    ``name``, and the values under ``labels`` and ``units``).

    Raises
    ------
    SceneError
        Naming the key, the offending characters and the NFKC spelling.
    """
    lines = lines or {}
    stack = [(data, prefix, False)]
    while stack:
        node, path, free = stack.pop()
        if isinstance(node, dict):
            for k, v in node.items():
                key = f"{path}.{k}" if path else str(k)
                if isinstance(k, str):
                    _normal(k, key, lines)
                text_only = k in FREE_TEXT_KEYS or path.rsplit(".", 1)[-1] in FREE_TEXT_MAPPINGS
                stack.append((v, key, text_only))
        elif isinstance(node, list):
            stack.extend((v, f"{path}[{i}]", free) for i, v in enumerate(node))
        elif isinstance(node, str) and not free:
            _normal(node, path, lines)


def _normal(text: str, key: str, lines: dict) -> None:
    norm = unicodedata.normalize("NFKC", text)
    if norm != text:
        raise SceneError(key, "a name in Unicode normal form NFKC (expressions read every name in that form: "
                         "a look-alike would merge with another name)", text, lines.get(key),
                         hint=f"; {_look_alike(text)}: write {norm!r}")


# ---------------------------------------------------------------- physical values
def parameter_rule(model: dict, name: str, analysis: dict | None = None):
    """``(rule, meaning)`` that the values of parameter ``name`` must obey, or None.

    Built-in models give theirs (:attr:`contin.model.catalog.ModelSpec.constraints`);
    the excitation frequency (:func:`model_frequency`) is never negative.

    Parameters
    ----------
    model : dict
        The checked ``model`` section.
    name : str
    analysis : dict, optional
        The checked ``analysis`` section (for ``frequency``).
    """
    rules = {}
    if "builtin" in model:
        try:
            spec = get_spec(model["builtin"])
        except (TypeError, ValueError):
            return None  # the model's build names it
        options = model.get("options") if isinstance(model.get("options"), dict) else {}
        rules = spec.parameter_constraints(options)
    elif "from" in model:
        rules = FE_RULES
    freq = model_frequency(model, analysis)
    if name in rules:
        return rules[name]
    if name == freq:
        return ("nonnegative", "the excitation frequency")
    return None


def check_parameter_values(model: dict, analysis: dict, name, items, lines: dict | None = None) -> None:
    """Refuse values of parameter ``name`` that its rule (:func:`parameter_rule`) forbids.

    Parameters
    ----------
    model, analysis : dict
        The checked sections.
    name : str or None
        The parameter (None: nothing to check).
    items : iterable of (str, value)
        Scene key and its value: a number or a list of numbers (a range).
    """
    if not isinstance(name, str):
        return
    rule = parameter_rule(model, name, analysis)
    if rule is None:
        return
    for key, value in items:
        for v in value if isinstance(value, list) else [value]:
            bad = rule_violation(rule, v)
            if bad:
                raise SceneError(key, f"values of {name}, each {bad}", value, (lines or {}).get(key))


def _check_builtin_parameters(model: dict, lines: dict) -> None:
    """A built-in model's parameter values against its constraints (before the model is built)."""
    try:
        spec = get_spec(model["builtin"])
    except (TypeError, ValueError):
        return  # the model's build names it
    rules = spec.parameter_constraints(model["options"] if isinstance(model["options"], dict) else {})
    for k, v in model["parameters"].items():
        bad = rule_violation(rules[k], v) if k in rules else None
        if bad:
            key = f"model.parameters.{k}"
            raise SceneError(key, bad, v, lines.get(key))


def model_frequency(model: dict, analysis: dict | None = None) -> str | None:
    """The excitation-frequency parameter ``w`` of a scene (``tau = w t``).

    The one place a scene's frequency is named: ``analysis.frequency`` where
    the analysis gives one, else the model's own (``model.frequency`` of a
    custom model, the built-in model's declared frequency). The analyses pass
    it to the problems they make (the ``frequency`` argument of
    :class:`contin.hb.problem.HarmonicBalance`); no model is changed.

    Parameters
    ----------
    model : dict
        The checked ``model`` section.
    analysis : dict, optional
        The checked ``analysis`` section.

    Returns
    -------
    str or None
        None for an unknown built-in model (its build names it).
    """
    if analysis is not None and isinstance(analysis.get("frequency"), str):
        return analysis["frequency"]
    if "from" in model:  # a finite-element rotor (contin.scene.fe_model): its speed
        from contin.model.fem.builder import SPEED  # deferred: the builder loads scipy.interpolate (0.13 s)

        return SPEED
    if "builtin" not in model:
        return model.get("frequency")
    try:
        return get_spec(model["builtin"]).frequency
    except (TypeError, ValueError):
        return None


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
    inputs : dict
        The files read for this scene: absolute, resolved path -> sha256 (hex)
        of the bytes read: the scene file (:func:`load_scene`) and a model
        file (a rotor's ``.npz`` or ROSS file, recorded when the model is built).
    """

    data: dict
    source: str = "<string>"
    lines: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)

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


def apply_override(data: dict, assignment: str) -> tuple[str, Any]:
    """Apply ``dotted.key=value`` (value parsed as YAML) to ``data`` in place; returns the key and the value."""
    if "=" not in assignment:
        raise SceneError("--set", "dotted.key=value", assignment)
    key, _, text = assignment.partition("=")
    key = key.strip()
    if not key or any(not part for part in key.split(".")):
        raise SceneError("--set", "a dotted key such as model.parameters.f0", key)
    try:
        value = load_text(text, f"--set {key}") if text.strip() else None
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
    return key, value


def cite_override(lines: dict, assignment: str, key: str, value: Any) -> None:
    """Make errors in an overridden value cite the ``--set`` that gave it, not the file's line it replaced.

    The file's lines of ``key`` and of everything below it are dropped, and
    ``key`` and each key inside ``value`` map to ``"--set key=value"`` (as the
    user typed it), which :class:`SceneError` prints in place of a line.
    """
    citation = f"--set {key}={assignment.partition('=')[2].strip()}"
    for k in [k for k in lines if k == key or k.startswith((f"{key}.", f"{key}["))]:
        del lines[k]

    def walk(v, path):
        lines[path] = citation
        if isinstance(v, dict):
            for k, item in v.items():
                walk(item, f"{path}.{k}")
        elif isinstance(v, list):
            for i, item in enumerate(v):
                walk(item, f"{path}[{i}]")

    walk(value, key)


def parse_scene(text: str, source: str = "<string>", overrides=()) -> Scene:
    """Parse, override and validate a scene given as YAML text.

    Raises
    ------
    SceneError
        On malformed YAML or any schema violation.
    """
    try:
        data, root = load_nodes(text, source)  # once: a large scene is not parsed again for its lines
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise SceneError(source, "valid YAML", None, line, hint=f"; the YAML parser says: {problem}") from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise SceneError("(top level)", "a mapping with the sections model, analysis, output", type(data).__name__)
    applied = [(ov, *apply_override(data, ov)) for ov in overrides]
    lines = line_map(root)
    for ov, key, value in applied:  # in order: a later --set of the same key is the one cited
        cite_override(lines, ov, key, value)
    return scene_from_data(data, source, lines)


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
    check_names(data, lines)
    for k in data:
        if k not in ("model", "analysis", "output"):
            raise SceneError(k, "one of the sections model, analysis, output", None, lines.get(k),
                             hint=f"; unknown key '{k}'{suggest(k, ('model', 'analysis', 'output'))}")
    for sec in ("model", "analysis"):
        if not isinstance(data.get(sec), dict):
            raise SceneError(sec, "a mapping (required section)", data.get(sec), lines.get(sec))
    model = check_model_section(data["model"], lines)
    analysis = data["analysis"]
    atype = analysis.get("type")
    names = registry.analysis_names()
    if not isinstance(atype, str) or atype not in names:
        raise SceneError("analysis.type", "one of " + ", ".join(repr(a) for a in names), atype,
                         lines.get("analysis.type"), hint=suggest(atype, names) if isinstance(atype, str) else "")
    made = registry.analysis(atype)  # only the scene's own analysis is imported
    analysis = check_section(analysis, made.schema, "analysis", lines)
    made.validate(data, model, analysis, lines)
    output = data.get("output") or {}
    if not isinstance(output, dict):
        raise SceneError("output", "a mapping", output, lines.get("output"))
    output = check_section(output, OUTPUT, "output", lines)
    _check_zoom(output.get("zoom"), lines)
    return Scene({"model": model, "analysis": analysis, "output": output}, source, lines)


def _check_zoom(zoom, lines: dict) -> None:
    """``output.zoom`` as :class:`contin.output.panel_options.ZoomWindow` takes it (the measures' names are the
    analysis's to check: :func:`contin.scene.registry.check_output`)."""
    if zoom is None:
        return
    try:
        ZoomWindow.from_dict(zoom)
    except PanelError as exc:
        key = f"output.zoom.{exc.field}"
        raise SceneError(key, exc.expected, exc.found, lines.get(key) or lines.get("output.zoom")) from None


def check_model_section(model: dict, lines: dict | None = None) -> dict:
    """The ``model`` section checked against its schema (built-in or custom), defaults filled in.

    Raises
    ------
    SceneError
        On any schema violation, naming the key.
    """
    lines = lines or {}
    if not isinstance(model, dict):
        raise SceneError("model", "a mapping (required section)", model, lines.get("model"))
    check_names({"model": model}, lines)
    if "from" in model:
        return check_fe_section(model, lines)
    model = check_section(model, BUILTIN_MODEL if "builtin" in model else CUSTOM_MODEL, "model", lines)
    if "builtin" in model:
        _check_builtin_parameters(model, lines)
    return model


def read_scene_text(path: str | Path) -> tuple[str, str]:
    """The text of a scene file and the sha256 of its bytes.

    The file is read once, only if it is a regular file (a link to one is
    followed) of at most :data:`contin.scene.files.SCENE_FILE_CAP` bytes: a
    device, a named pipe or a directory is refused before anything is read
    (:func:`contin.scene.files.read_input`); so is text that is not UTF-8.
    """
    path = Path(path)
    try:
        raw, digest = read_input(path, SCENE_FILE_CAP)
    except OSError as exc:
        raise SceneError(str(path), f"a readable scene file (a regular file of at most {size_text(SCENE_FILE_CAP)})",
                         None, hint=f" ({exc.strerror})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError(str(path), "a scene file in UTF-8", f"byte 0x{exc.object[exc.start]:02x} at offset {exc.start}",
                         hint=" (save the file as UTF-8)") from None
    # universal newlines, as text-mode reading gave (YAML's line numbers count them alike)
    return text.replace("\r\n", "\n").replace("\r", "\n"), digest


def load_scene(path: str | Path, overrides=()) -> Scene:
    """Read (:func:`read_scene_text`) and validate a scene file; see :func:`parse_scene`.

    The file's sha256 goes to :attr:`Scene.inputs`.
    """
    text, digest = read_scene_text(path)
    scene = parse_scene(text, str(path), overrides)
    scene.inputs[input_key(Path(path))] = digest
    return scene


def analysis_schemas() -> dict:
    """``analysis.type`` name -> schema of its section, for every analysis of :data:`contin.scene.registry.ANALYSES`."""
    return {name: registry.analysis(name).schema for name in registry.ANALYSES}
