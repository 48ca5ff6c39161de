"""``convergence``: the plan of a convergence study: its section's schema, its settings, and every check before it runs.

:data:`CONVERGENCE` and :data:`QUANTITIES` are the schemas of the
``analysis`` section and of its quantities; :func:`settings_of` spells out
the settings (``vary``, ``combine``, ``reference``) and :func:`variant_data`
the scene of each; :func:`validate` and :func:`plan` make every check of
the scene, each setting's scene included, before anything is written, and
:func:`plan` returns the plan the run follows (:class:`ConvergencePlan`).
The section itself is described in :mod:`contin.analyses.convergence`.
"""

from __future__ import annotations

import copy
import itertools
import re
from dataclasses import dataclass

from contin.analyses.branch_recorder import SPECIAL_EXTRA
from contin.analyses.frequency_response import plot_measures
from contin.analyses.simulate import result_columns as simulation_columns
from contin.engine.continuation import ContinuationOptions
from contin.model.catalog import get_spec
from contin.scene.build import build_model
from contin.scene.parse import scene_from_data
from contin.scene.registry import analysis as registered_analysis, check_scene
from contin.scene.schema import Key, SceneError, check_section, flag, int_range, listing, mapping, number, string
from contin.util.naming import suggest

__all__ = ["BASE_TABLES", "CONVERGENCE", "QUANTITIES", "ConvergencePlan", "base_columns", "normalize_quantity",
           "plan", "quantity_items", "setting_label", "settings_of", "slug", "validate", "variant_data"]

#: base analyses a convergence study can run, and the table their quantities read
BASE_TABLES = {"frequency_response": "branches.csv", "static": "branches.csv", "backbone": "branches.csv",
               "simulate": "simulation.csv"}

#: short names of settings in labels
SHORT = {"harmonics": "H", "samples": "N", "subharmonic": "nu", "terms": "n", "steps_per_period": "steps"}

ERROR_KINDS = ("relative", "absolute")


def _vary_ok(v) -> bool:
    return isinstance(v, dict) and len(v) > 0 and all(
        isinstance(k, str) and isinstance(x, list) and len(x) > 0 for k, x in v.items())


def _quantities_ok(v) -> bool:
    return isinstance(v, list) and len(v) > 0 and all(isinstance(q, (str, dict)) for q in v)


CONVERGENCE = {
    "type": string(required=True),
    "base": Key("a mapping: the analysis section run at each setting, with its own type "
                "(" + ", ".join(BASE_TABLES) + ")", lambda v: isinstance(v, dict), required=True),
    "vary": Key("a non-empty mapping from a setting path (such as analysis.harmonics or model.parameters.terms) "
                "to a non-empty list of values", _vary_ok, required=True),
    "combine": string("product", ("product", "zip")),
    "reference": Key("a mapping from setting paths of vary to values, or null",
                     lambda v: v is None or isinstance(v, dict), None),
    "quantities": Key("a non-empty list of quantities (type names or mappings with a type among "
                      "peak, fold, special, stable_interval, value, static_deflection)", _quantities_ok, required=True),
    "error": string("relative", ERROR_KINDS),
    "budget": number(positive=True),
    "warmup": flag(True),
    "repeat": int_range(1, 1, 20, "an integer"),
    "labels": mapping(),
    "cost": string("wall_time", ("wall_time", "cpu_time")),
}

_COMMON = {"type": string(required=True), "name": string(), "error": string(None, ERROR_KINDS)}
_SELECT = {"branch": Key("an integer >= 0 or null", lambda v: v is None or (isinstance(v, int) and v >= 0)),
           "nu": Key("an integer >= 1 or null", lambda v: v is None or (isinstance(v, int) and v >= 1))}

#: quantity type -> schema of its mapping
QUANTITIES = {
    "peak": {**_COMMON, **_SELECT, "measure": string(), "refine": flag(True)},
    "fold": {**_COMMON, **_SELECT, "index": Key("an integer >= 0", lambda v: isinstance(v, int) and v >= 0, 0),
             "near": number(), "window": number(positive=True), "of": string()},
    "special": {**_COMMON, **_SELECT, "kind": string("fold", ("fold", "pd", "ns", "bp")),
                "index": Key("an integer >= 0", lambda v: isinstance(v, int) and v >= 0, 0),
                "near": number(), "window": number(positive=True), "of": string()},
    "stable_interval": {**_COMMON, "nu": Key("an integer >= 1", lambda v: isinstance(v, int) and v >= 1, 1),
                        "measure": string(), "min": number(),
                        "ends": listing(["from", "to"], lambda x: x in ("from", "to", "length"),
                                        "a non-empty list among 'from', 'to', 'length'")},
    "value": {**_COMMON, "measure": string(), "at": number(required=True), "parameter": string(),
              "branch": Key("an integer >= 0", lambda v: isinstance(v, int) and v >= 0, 0)},
    "static_deflection": {**_COMMON, "measure": string(), "at": number(required=True), "parameter": string(),
                          "branch": Key("an integer >= 0", lambda v: isinstance(v, int) and v >= 0, 0)},
}


# ---------------------------------------------------------------- settings
def settings_of(analysis: dict) -> tuple[list[dict], int]:
    """The settings of a convergence section and the index of the reference among them.

    Parameters
    ----------
    analysis : dict
        A checked ``convergence`` section.

    Returns
    -------
    settings : list of dict
        Setting path -> value, one per run, in run order (a reference outside
        the lists comes last).
    reference : int
        Index of the reference setting.
    """
    vary = analysis["vary"]
    keys = list(vary)
    if analysis["combine"] == "zip":
        combos = [dict(zip(keys, vals)) for vals in zip(*(vary[k] for k in keys))]
    else:
        combos = [dict(zip(keys, vals)) for vals in itertools.product(*(vary[k] for k in keys))]
    ref = {k: vary[k][-1] for k in keys}
    ref.update(analysis["reference"] or {})
    if analysis["combine"] == "zip" and not analysis["reference"]:
        ref = dict(combos[-1])
    for i, c in enumerate(combos):
        if c == ref:
            return combos, i
    return combos + [ref], len(combos)


def setting_label(setting: dict, labels: dict | None = None) -> str:
    """Short text of a setting, such as ``H=5, N=256``."""
    parts = []
    for path, v in setting.items():
        name = (labels or {}).get(path) or SHORT.get(path.split(".")[-1], path.split(".")[-1])
        parts.append(f"{name}={v:g}" if isinstance(v, float) else f"{name}={v}")
    return ", ".join(parts)


def _set_path(data: dict, path: str, value) -> None:
    node = data
    parts = path.split(".")
    for part in parts[:-1]:
        nxt = node.get(part)
        if nxt is None:
            nxt = node[part] = {}
        if not isinstance(nxt, dict):
            raise SceneError(f"analysis.vary.{path}", f"'{part}' to be a mapping in the scene", nxt)
        node = nxt
    node[parts[-1]] = copy.deepcopy(value)


def variant_data(data: dict, setting: dict) -> dict:
    """The scene data of one run: the base section as ``analysis``, the setting applied, plots off."""
    out = {"model": copy.deepcopy(data["model"]), "analysis": copy.deepcopy(data["analysis"]["base"]),
           "output": copy.deepcopy(data.get("output") or {})}
    out["output"]["plots"] = False
    for path, v in setting.items():
        _set_path(out, path, v)
    return out


# ---------------------------------------------------------------- validation
def _check_path(path: str, model: dict, base: dict, base_schema: dict, where: str) -> None:
    parts = path.split(".")
    if len(parts) < 2 or parts[0] not in ("analysis", "model") or any(not p for p in parts):
        raise SceneError(where, "a setting path starting with 'analysis.' (a key of the base analysis) or "
                         "'model.' (such as model.parameters.NAME)", path)
    if parts[0] == "analysis":
        key = parts[1]
        allowed = [k for k in base_schema if k not in ("type", "starts")]
        if key not in allowed:
            raise SceneError(where, f"a key of the {base['type']} analysis after 'analysis.' ({', '.join(allowed)})",
                             key, hint=suggest(key, allowed))
        if key == "continuation" and len(parts) > 2:
            names = ContinuationOptions.field_names()
            if len(parts) != 3 or parts[2] not in names:
                raise SceneError(where, "a continuation option after 'analysis.continuation.' (" +
                                 ", ".join(names) + ")", ".".join(parts[2:]), hint=suggest(parts[2], names))
        return
    if "builtin" in model:
        if parts[1] not in ("parameters", "options") or len(parts) != 3:
            raise SceneError(where, "model.parameters.NAME or model.options.NAME for a built-in model", path)
        try:
            spec = get_spec(model["builtin"])
        except ValueError:
            return  # the model section reports it
        known = spec.parameters if parts[1] == "parameters" else (spec.options or {})
        if parts[2] not in known:
            raise SceneError(where, f"a {parts[1][:-1]} of the built-in model '{model['builtin']}' "
                             f"({', '.join(known) or 'none'})", parts[2], hint=suggest(parts[2], known))
        return
    if parts[1] == "parameters" and (len(parts) != 3 or parts[2] not in (model.get("parameters") or {})):
        names = list(model.get("parameters") or {})
        raise SceneError(where, f"a parameter of the model ({', '.join(names)})", ".".join(parts[2:]),
                         hint=suggest(parts[2], names) if len(parts) > 2 else "")


def validate(data: dict, model: dict, analysis: dict, lines: dict) -> None:
    """Checks of a convergence scene beyond its schema (``analysis.base``, paths, quantities, every setting)."""
    base = analysis["base"]
    btype = base.get("type")
    if not isinstance(btype, str) or btype not in BASE_TABLES:
        raise SceneError("analysis.base.type", "one of " + ", ".join(repr(t) for t in BASE_TABLES), btype,
                         lines.get("analysis.base.type"),
                         hint=suggest(btype, BASE_TABLES) if isinstance(btype, str) else "")
    made = registered_analysis(btype)
    schema = made.schema
    checked = check_section(base, schema, "analysis.base", lines)
    # the base analysis' own checks of its section (a frequency response's further starts), its keys cited
    # under analysis.base
    base_lines = {"analysis" + k[len("analysis.base"):]: v for k, v in lines.items()
                  if k == "analysis.base" or k.startswith("analysis.base.")}
    try:
        made.validate({**data, "analysis": base}, model, checked, base_lines)
    except SceneError as exc:
        raise _under_base(exc) from None
    for path in analysis["vary"]:
        _check_path(path, model, base, schema, f"analysis.vary.{path}")
    if analysis["combine"] == "zip":
        lengths = {len(v) for v in analysis["vary"].values()}
        if len(lengths) > 1:
            raise SceneError("analysis.vary", "lists of equal length with combine: zip",
                             {k: len(v) for k, v in analysis["vary"].items()})
    for path in analysis["reference"] or {}:
        if path not in analysis["vary"]:
            raise SceneError(f"analysis.reference.{path}", "a setting path of analysis.vary (" +
                             ", ".join(analysis["vary"]) + ")", path, hint=suggest(path, analysis["vary"]))
    for path in analysis["labels"]:
        if path not in analysis["vary"]:
            raise SceneError(f"analysis.labels.{path}", "a setting path of analysis.vary", path)
    for i, q in enumerate(analysis["quantities"]):
        normalize_quantity(q, i, btype, lines)
    if not isinstance(data.get("output") or {}, dict):
        return  # the scene check reports the output section
    settings, _ = settings_of(analysis)
    seen = set()
    for s in settings:
        label = setting_label(s, analysis["labels"])
        if label in seen:
            raise SceneError("analysis.vary", "distinct settings", label, hint="; this setting appears twice")
        seen.add(label)
        try:
            scene_from_data(variant_data(data, s), "analysis.base")
        except SceneError as exc:
            raise SceneError("analysis.vary", "settings that each give a valid scene", label,
                             hint=f"; with them: {exc}") from None


def _under_base(exc: SceneError) -> SceneError:
    """``exc`` of a key of the base section (``analysis.X``) as the convergence scene names it (``analysis.base.X``)."""
    if exc.key != "analysis" and not exc.key.startswith("analysis."):
        return exc
    out = SceneError("analysis.base" + exc.key[len("analysis"):], exc.expected, exc.found, exc.line)
    out.args = ("analysis.base" + str(exc)[len("analysis"):],)  # the message as it was, the hint included
    return out


def normalize_quantity(q, i: int, base_type: str, lines: dict | None = None) -> dict:
    """A quantity as a checked mapping with defaults (a bare type name is a mapping with that type)."""
    where = f"analysis.quantities[{i}]"
    if isinstance(q, str):
        q = {"type": q}
    qtype = q.get("type")
    if not isinstance(qtype, str) or qtype not in QUANTITIES:
        raise SceneError(f"{where}.type", "one of " + ", ".join(QUANTITIES), qtype,
                         hint=suggest(qtype, QUANTITIES) if isinstance(qtype, str) else "")
    out = check_section(q, QUANTITIES[qtype], where, lines or {})
    if base_type == "simulate" and qtype not in ("peak", "value", "static_deflection"):
        raise SceneError(f"{where}.type", "peak or value for a simulate base (its table has no branches)", qtype)
    if base_type == "static" and qtype == "stable_interval":
        raise SceneError(f"{where}.type", "a quantity of a periodic-solution base (peak, fold, value, "
                         "static_deflection) for a static base", qtype)
    if qtype in ("fold", "special") and out["near"] is not None and "index" in q:
        raise SceneError(where, "either index or near, not both", sorted(q))
    return out


# ---------------------------------------------------------------- quantities
def slug(text: str) -> str:
    """``text`` with each run of characters other than letters and digits as one ``_`` (a column, a directory)."""
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_")


def quantity_items(q: dict, ctx_defaults: dict) -> list[tuple[str, str]]:
    """``(column, description)`` of each scalar a quantity gives."""
    t = q["type"]
    if t == "peak":
        m = q["measure"] or ctx_defaults["measure"]
        base = q["name"] or f"peak_{m}"
        return [(slug(base), f"peak of {m}")]
    if t in ("fold", "special"):
        what = q["of"] or ctx_defaults["parameter"]
        kind = q.get("kind", "fold")
        if q["near"] is not None:
            base, desc = q["name"] or f"{kind}_near_{q['near']:g}", f"{what} at the {kind} nearest {q['near']:g}"
        else:
            base, desc = q["name"] or f"{kind}_{q['index']}", f"{what} at {kind} {q['index']}"
        return [(slug(base), desc)]
    if t == "stable_interval":
        base = q["name"] or f"stable_nu{q['nu']}"
        return [(slug(f"{base}_{e}"), f"{e} of the stable nu={q['nu']} interval") for e in q["ends"]]
    m = q["measure"] or ctx_defaults["static_measure"]
    p = q["parameter"] or ctx_defaults["parameter"]
    base = q["name"] or f"{m}_at_{p}_{q['at']:g}"
    return [(slug(base), f"{m} at {p} = {q['at']:g}")]



def base_columns(btype: str, scene, model, plan) -> tuple[str, dict]:
    """The parameter of a base run and the columns of its files (``file -> columns``), from its plan."""
    if btype == "frequency_response":
        hb = plan.first.hb
        measures = plot_measures(scene, model, hb)
        head = ["branch", "nu", hb.parameter, "stable"]
        return hb.parameter, {"branches.csv": head + measures + ["newton_iterations", "residual_norm"],
                              "special_points.csv": ["branch", "kind", hb.parameter, "index"]
                              + measures[:-2] + SPECIAL_EXTRA}
    if btype == "simulate":
        return plan.parameter, {"simulation.csv": simulation_columns(plan.parameter, model.dof_names)}
    if btype == "static":
        return plan.sweep.parameter, plan.columns
    return "amplitude", plan.columns  # backbone


def _quantity_columns(q: dict, i: int, defaults: dict) -> list[tuple[str, str, str]]:
    """``(key, column, file)`` of every column the quantity ``q`` reads (``file``: ``table`` or ``special``)."""
    where = f"analysis.quantities[{i}]"
    t = q["type"]
    param = q.get("parameter") or defaults["parameter"]
    pkey = f"{where}.parameter" if q.get("parameter") else where
    out = []
    if t == "peak":
        out.append((f"{where}.measure" if q["measure"] else "output.measure", q["measure"] or defaults["measure"],
                    "table"))
        if q["refine"]:
            out.append((pkey, param, "table"))
    elif t in ("fold", "special"):
        out.append((f"{where}.of" if q["of"] else where, q["of"] or param, "special"))
        if q["near"] is not None:
            out.append((where, param, "special"))
    elif t == "stable_interval":
        out.append((where, param, "table"))
        if q["measure"] is not None and q["min"] is not None:
            out.append((f"{where}.measure", q["measure"], "table"))
    else:
        out.append((f"{where}.measure" if q["measure"] else where, q["measure"] or defaults["static_measure"], "table"))
        out.append((pkey, param, "table"))
    return out


@dataclass(frozen=True)
class ConvergencePlan:
    """Every checked choice of a ``convergence`` scene.

    Attributes
    ----------
    quantities : tuple of dict
        The checked quantities (:func:`normalize_quantity`).
    settings : tuple of dict
        Setting path -> value, one per run, in run order (:func:`settings_of`).
    iref : int
        The reference setting's index.
    labels : tuple of str
        Each setting's label (:func:`setting_label`).
    scenes : tuple of Scene
        Each setting's scene (the base section as ``analysis``, plots off).
    defaults : dict
        ``parameter``, ``measure`` and ``static_measure`` of the base runs.
    items : tuple of (str, str)
        Each quantity column and its description.
    kinds : dict
        Quantity column -> ``relative`` or ``absolute``.
    """

    quantities: tuple
    settings: tuple
    iref: int
    labels: tuple
    scenes: tuple
    defaults: dict
    items: tuple
    kinds: dict

    @property
    def columns(self) -> list[str]:
        """The quantity columns, in order."""
        return [c for c, _ in self.items]


def plan(scene, model) -> ConvergencePlan:
    """Every check of a ``convergence`` scene; returns its plan.

    Each setting's scene is built and checked as its run will check it
    (:func:`contin.scene.registry.check_scene`), so that a setting the base
    analysis refuses is found before anything is written, and every column
    a quantity reads must be one the runs write (``hK_`` columns: at some
    setting).
    """
    a = scene.analysis
    btype = a["base"]["type"]
    quantities = [normalize_quantity(q, i, btype) for i, q in enumerate(a["quantities"])]
    settings, iref = settings_of(a)
    labels = [setting_label(s, a["labels"]) for s in settings]
    scenes = [scene_from_data(variant_data(scene.data, s), scene.source) for s in settings]
    tables: dict = {}
    parameter = None
    for label, sc in zip(labels, scenes):
        try:
            m = build_model(sc)
            base_plan = check_scene(sc, m)
        except SceneError as exc:
            if exc.key.startswith("output."):
                raise  # the scene's own output section, the same at every setting
            raise SceneError("analysis.vary", "settings the base analysis accepts", label,
                             scene.lines.get("analysis.vary"), hint=f"; with them: {exc}") from None
        param, files = base_columns(btype, sc, m, base_plan)
        if parameter is None:
            parameter, first_model = param, m
        for f, cols in files.items():
            tables.setdefault(f, {}).update(dict.fromkeys(cols))
    out, base = scenes[0].data["output"], scenes[0].data["analysis"]
    measure = out.get("measure") or base.get("measure") or (
        first_model.dof_names[0] if btype == "static" else f"amp_{first_model.dof_names[0]}")
    defaults = {"parameter": parameter, "measure": measure,
                "static_measure": base.get("measure") or out.get("measure") or measure}
    table = list(tables.get(BASE_TABLES[btype], {}))
    special = list(tables.get("special_points.csv", {}))
    items, kinds = [], {}
    for i, q in enumerate(quantities):
        for key, col, which in _quantity_columns(q, i, defaults):
            known, file = (table, BASE_TABLES[btype]) if which == "table" else (special, "special_points.csv")
            if col not in known:
                what = "column" if key.endswith(".of") else "parameter" if col == defaults["parameter"] \
                    or key.endswith(".parameter") else "measure"
                raise SceneError(key, f"a column of {file} of the {btype} runs", None, scene.lines.get(key),
                                 hint=f": {what} '{col}' is not a column of {file}{suggest(str(col), known)} "
                                      f"({', '.join(known[:60])})")
        for c, d in quantity_items(q, defaults):
            if c in kinds:
                raise SceneError("analysis.quantities", "quantities with distinct names (set name:)", c,
                                 scene.lines.get("analysis.quantities"))
            items.append((c, d))
            kinds[c] = q["error"] or a["error"]
    return ConvergencePlan(tuple(quantities), tuple(settings), iref, tuple(labels), tuple(scenes), defaults,
                           tuple(items), kinds)
