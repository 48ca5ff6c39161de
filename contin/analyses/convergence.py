"""``convergence``: what accuracy costs, error of quantities of interest against wall time.

A convergence scene embeds an ordinary analysis section (``base``: a
``frequency_response``, ``static``, ``backbone`` or ``simulate`` analysis) and
runs it once per *setting*: a combination of values of accuracy settings
given under ``vary`` by their dotted path in the scene, for example

.. code-block:: yaml

    analysis:
      type: convergence
      base: {type: frequency_response, parameter: w, range: [0.5, 3], harmonics: 9}
      vary:
        analysis.harmonics: [1, 3, 5, 7, 9, 11]     # keys of the base section
        model.parameters.terms: [3, 5]              # parameters (and options) of the model
      combine: product                              # or zip (lists of equal length, taken in step)
      reference: {analysis.harmonics: 25}           # optional: the finest setting
      quantities:
        - {type: fold, index: 0}
        - {type: peak, measure: amp_x}
      budget: 1.0e-6                                # optional: recommend the cheapest setting

Setting paths start with ``analysis.`` (a key of the base section, nested
mappings allowed, e.g. ``analysis.continuation.newton_tol``,
``analysis.stability_options.steps_per_period``; not ``analysis.starts``: the
start to study goes in the base section itself) or ``model.`` (built-in
models: ``model.parameters.NAME``, ``model.options.NAME``; custom models any
key, e.g. ``model.parameters.NAME``). With ``combine: product`` (the default)
every combination of the lists is run, the last key varying fastest; with
``zip`` the lists are taken in step. The reference is the last setting unless
``reference`` names one (values of the ``vary`` paths; paths it leaves out
take their last value); a reference outside the lists is run as well.

Each setting is an ordinary run of the base analysis into
``runs/NN_<label>/`` (plots off). Its wall time is measured around the whole
run (model build, start, continuation, stability, result files) with
``time.perf_counter``, after one untimed warm-up run of the first setting so
that numba compilation and cache loading are not counted (``warmup: false``
switches it off); with ``repeat: k`` the smallest of ``k`` timings is kept.
The CPU time of the same run (``time.process_time``) is recorded too; ``cost:
cpu_time`` makes it the cost axis of the plot and of the budget (on a machine
shared with other jobs it varies less than the wall time).

Quantities of interest (``quantities``, a list of mappings with a ``type``
or of type names):

``peak``
    The largest value of a column (``measure``, default ``output.measure``,
    else ``amp_`` of the first dof) over the rows of the selected branches
    (``branch``, ``nu``), refined by the vertex of the parabola through the
    largest stored row and its two neighbours along the branch (``refine``).
``fold`` and ``special``
    The parameter (or the column ``of``) of a located fold (for ``special``:
    of the ``kind`` fold, pd, ns or bp) in ``special_points.csv``: the
    ``index``-th in branch order (default 0), or the one nearest ``near``
    (within ``window`` if given).
``stable_interval``
    Hull ``[from, to]`` of the parameter intervals where a stable solution of
    order ``nu`` exists (:func:`contin.app.sweep.stable_intervals`: each end at
    the located change of stability), counting only rows whose ``measure``
    exceeds ``min`` if given (the rotor's harmonic solution seen as
    ``nu = 2`` has no ``+w/2`` whirl); ``ends`` chooses among ``from``,
    ``to``, ``length``.
``value`` and ``static_deflection``
    A column (``measure``; for a static base its ``measure``) at the
    parameter value ``at`` on a branch (default 0): the first crossing of
    ``at`` along the branch, linearly interpolated between stored rows
    (exact where ``at`` is the start of the branch or an end of ``range``,
    where a branch ends exactly). For a ``simulate`` base the table is
    ``simulation.csv`` and ``at`` one of its ``values``.

The error of each quantity is ``|q - q_ref|``, divided by ``|q_ref|`` for
``error: relative`` (the default; per quantity too). A quantity a run does not
produce (no fold, no stable interval, a failed run) is *missing*: its cells
are empty and the ``missing`` column says why.

Settings are labelled by the last part of their paths (``harmonics`` as
``H``, ``samples`` as ``N``, ``terms`` as ``n``, ``steps_per_period`` as
``steps``), or by the names given under ``labels`` (path -> name).

Result files: ``convergence.csv`` (one row per setting: ``setting`` (label),
the values of the ``vary`` paths, ``group`` (the values of all but the last
path: one line of the plot each), ``reference``, ``status``, ``wall_time``,
``cpu_time``, ``points`` (rows written), each quantity and
``<quantity>_error``, ``max_error`` (the largest error over the quantities;
empty when one is missing), ``missing``, ``run`` (the run's directory) and
``message`` (why a run failed, or why a branch ended before its range)), ``convergence.png`` (log-log error against
time, one line per quantity, points labelled by setting) and ``summary.json`` (``analysis.table``, the
printed table; ``analysis.recommendation`` for ``budget`` or ``contin run
--budget ERR``: the cheapest setting whose errors are all at most ``ERR``, the
reference excluded since its own error is not measured; ``contin budget OUTDIR
ERR`` gives the same from a finished run without running it again, and redraws
``convergence.png`` with that budget).
"""

from __future__ import annotations

import copy
import itertools
import math
import re
import time
from pathlib import Path

import numpy as np

from contin.scene.registry import register_analysis
from contin.scene.schema import Key, SceneError, check_section, flag, int_range, listing, mapping, number, string

__all__ = ["CONVERGENCE", "QUANTITIES", "base_columns", "check", "run", "settings_of", "recommend", "read_records",
           "quantity_items", "extract", "format_table", "plot_convergence", "replot"]

#: base analyses a convergence study can run, and the table their quantities read
BASE_TABLES = {"frequency_response": "branches.csv", "static": "branches.csv", "backbone": "branches.csv",
               "simulate": "simulation.csv"}

#: short names of settings in labels
SHORT = {"harmonics": "H", "samples": "N", "subharmonic": "nu", "terms": "n", "steps_per_period": "steps"}

ERROR_KINDS = ("relative", "absolute")

#: branch statuses that end a branch before its range (their messages explain a missing quantity)
EARLY_ENDS = ("step_too_small", "start_failed", "newton_failed", "ill_conditioned")

#: relative difference of two timings below which the budget counts them as equal
TIME_TIE = 0.05


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
    from contin.engine.continuation import ContinuationOptions
    from contin.util.naming import suggest

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
        from contin.model.catalog import get_spec

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
    from contin.util.naming import suggest
    from contin.scene.parse import FREQUENCY_RESPONSE, START_KEYS, analysis_schemas, scene_from_data

    base = analysis["base"]
    btype = base.get("type")
    if not isinstance(btype, str) or btype not in BASE_TABLES:
        raise SceneError("analysis.base.type", "one of " + ", ".join(repr(t) for t in BASE_TABLES), btype,
                         lines.get("analysis.base.type"),
                         hint=suggest(btype, BASE_TABLES) if isinstance(btype, str) else "")
    schema = analysis_schemas()[btype]
    checked = check_section(base, schema, "analysis.base", lines)
    if btype == "frequency_response":
        start_schema = {k: FREQUENCY_RESPONSE[k] for k in START_KEYS}
        for i, extra in enumerate(checked["starts"]):
            check_section(extra, start_schema, f"analysis.base.starts[{i}]", lines)
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


def normalize_quantity(q, i: int, base_type: str, lines: dict | None = None) -> dict:
    """A quantity as a checked mapping with defaults (a bare type name is a mapping with that type)."""
    from contin.util.naming import suggest

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
def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_")


def quantity_items(q: dict, ctx_defaults: dict) -> list[tuple[str, str]]:
    """``(column, description)`` of each scalar a quantity gives."""
    t = q["type"]
    if t == "peak":
        m = q["measure"] or ctx_defaults["measure"]
        base = q["name"] or f"peak_{m}"
        return [(_slug(base), f"peak of {m}")]
    if t in ("fold", "special"):
        what = q["of"] or ctx_defaults["parameter"]
        kind = q.get("kind", "fold")
        if q["near"] is not None:
            base, desc = q["name"] or f"{kind}_near_{q['near']:g}", f"{what} at the {kind} nearest {q['near']:g}"
        else:
            base, desc = q["name"] or f"{kind}_{q['index']}", f"{what} at {kind} {q['index']}"
        return [(_slug(base), desc)]
    if t == "stable_interval":
        base = q["name"] or f"stable_nu{q['nu']}"
        return [(_slug(f"{base}_{e}"), f"{e} of the stable nu={q['nu']} interval") for e in q["ends"]]
    m = q["measure"] or ctx_defaults["static_measure"]
    p = q["parameter"] or ctx_defaults["parameter"]
    base = q["name"] or f"{m}_at_{p}_{q['at']:g}"
    return [(_slug(base), f"{m} at {p} = {q['at']:g}")]


class Missing(Exception):
    """A quantity a run did not produce (its reason is the message)."""


def _branch_rows(rows: dict, q: dict) -> np.ndarray:
    n = len(next(iter(rows.values()))) if rows else 0
    sel = np.ones(n, bool)
    if q.get("branch") is not None and "branch" in rows:
        sel &= np.asarray(rows["branch"]) == q["branch"]
    if q.get("nu") is not None and "nu" in rows:
        sel &= np.asarray(rows["nu"]) == q["nu"]
    return np.flatnonzero(sel)


def _column(table: dict, name: str, what: str, file: str):
    if name not in table:
        raise KeyError(f"{what} '{name}' is not a column of {file} ({', '.join(list(table)[:40])})")
    col = table[name]
    if col.dtype.kind not in "fb":
        raise KeyError(f"{what} '{name}' is not a numeric column of {file}")
    return col.astype(float)


def _peak(rows, q, measure, param, file):
    m = _column(rows, measure, "measure", file)
    idx = _branch_rows(rows, q)
    idx = idx[np.isfinite(m[idx])] if len(idx) else idx
    if len(idx) == 0:
        raise Missing("no rows on the selected branches")
    i = int(idx[np.argmax(m[idx])])
    best = float(m[i])
    if not q["refine"]:
        return best
    b = rows["branch"] if "branch" in rows else np.zeros(len(m))
    if 0 < i < len(m) - 1 and b[i - 1] == b[i] == b[i + 1]:
        p = _column(rows, param, "parameter", file)
        pts = [(p[j], m[j]) for j in (i - 1, i, i + 1)]
        sp = max(np.ptp(p[b == b[i]]), 1e-300)
        sm = max(np.ptp(m[b == b[i]]), 1e-300)
        s = [0.0]
        for (pa, ma), (pb, mb) in zip(pts[:-1], pts[1:]):
            s.append(s[-1] + math.hypot((pb - pa) / sp, (mb - ma) / sm))
        if s[1] > 0 and s[2] > s[1]:
            c = np.polyfit(s, [v for _, v in pts], 2)
            if c[0] < 0:
                sv = -c[1] / (2 * c[0])
                if s[0] <= sv <= s[2]:
                    best = max(best, float(np.polyval(c, sv)))
    return best


def _fold(rows, special, q, param, file):
    kind = q.get("kind", "fold")
    kinds = list(special.get("kind", [])) if special else []
    what = q["of"] or param
    if not kinds:
        raise Missing("no special points")
    col = _column(special, what, "column", "special_points.csv")
    br = np.asarray(special["branch"])
    keep = [j for j, k in enumerate(kinds) if k == kind]
    if q["branch"] is not None:
        keep = [j for j in keep if br[j] == q["branch"]]
    if q["nu"] is not None:
        nu_of = {int(b): int(n) for b, n in zip(rows["branch"], rows["nu"])}
        keep = [j for j in keep if nu_of.get(int(br[j])) == q["nu"]]
    if not keep:
        raise Missing(f"no {kind} found")
    if q["near"] is not None:
        pv = _column(special, param, "parameter", "special_points.csv")
        j = min(keep, key=lambda j: abs(pv[j] - q["near"]))
        if q["window"] is not None and abs(pv[j] - q["near"]) > q["window"]:
            raise Missing(f"no {kind} within {q['window']:g} of {q['near']:g} (nearest at {pv[j]:.6g})")
        return float(col[j])
    if q["index"] >= len(keep):
        raise Missing(f"{kind} {q['index']} asked, {len(keep)} found")
    return float(col[keep[q["index"]]])


def _stable_interval(rows, special, q, param, file):
    from contin.analyses.intervals import stable_intervals

    if "stable" not in rows or rows["stable"].dtype != bool:
        raise Missing("no stability in the results")
    rows = dict(rows)
    if q["measure"] is not None and q["min"] is not None:
        m = _column(rows, q["measure"], "measure", file)
        rows["stable"] = rows["stable"] & (m > q["min"])
    iv = stable_intervals(rows, special, param).get(q["nu"], [])
    if not iv:
        raise Missing(f"no stable nu={q['nu']} solution")
    lo, hi = iv[0][0], iv[-1][1]
    return [{"from": lo, "to": hi, "length": sum(b - a for a, b in iv)}[e] for e in q["ends"]]


def _value(rows, q, measure, param, file):
    m = _column(rows, measure, "measure", file)
    p = _column(rows, param, "parameter", file)
    idx = np.flatnonzero(np.asarray(rows["branch"]) == q["branch"]) if "branch" in rows else np.arange(len(m))
    if len(idx) == 0:
        raise Missing(f"no branch {q['branch']}")
    at = q["at"]
    for a, b in zip(idx[:-1], idx[1:]):
        if p[a] == at:
            return float(m[a])
        if (p[a] - at) * (p[b] - at) < 0:
            t = (at - p[a]) / (p[b] - p[a])
            return float(m[a] + t * (m[b] - m[a]))
    if p[idx[-1]] == at:
        return float(m[idx[-1]])
    raise Missing(f"branch {q['branch']} does not reach {param} = {at:g}")


def extract(run_dir: Path, quantities: list[dict], defaults: dict, table_file: str,
            strict: bool = False) -> tuple[dict, dict]:
    """Values of the quantities in one run directory.

    Parameters
    ----------
    run_dir : Path
        A finished run of the base analysis.
    quantities : list of dict
        Checked quantities (:func:`normalize_quantity`).
    defaults : dict
        ``parameter``, ``measure`` and ``static_measure`` of the base run.
    table_file : str
        ``branches.csv`` or ``simulation.csv``.
    strict : bool
        Raise ``KeyError`` for a named column the results do not have;
        else such a quantity is missing at this run.

    Returns
    -------
    values : dict
        Column -> float for the quantities found.
    missing : dict
        Column -> reason for the others.

    Raises
    ------
    KeyError
        With ``strict``, a named column that the results do not have.
    """
    from contin.output.results import read_csv

    run_dir = Path(run_dir)
    rows = read_csv(run_dir / table_file) if (run_dir / table_file).exists() else {}
    sp_path = run_dir / "special_points.csv"
    special = read_csv(sp_path) if sp_path.exists() else {}
    values, missing = {}, {}
    for q in quantities:
        cols = [c for c, _ in quantity_items(q, defaults)]
        param = q.get("parameter") or defaults["parameter"]
        try:
            if not rows or len(next(iter(rows.values()))) == 0:
                raise Missing(f"no rows in {table_file}")
            t = q["type"]
            if t == "peak":
                got = [_peak(rows, q, q["measure"] or defaults["measure"], param, table_file)]
            elif t in ("fold", "special"):
                got = [_fold(rows, special, q, param, table_file)]
            elif t == "stable_interval":
                got = _stable_interval(rows, special, q, param, table_file)
            else:
                got = [_value(rows, q, q["measure"] or defaults["static_measure"], param, table_file)]
            values.update(zip(cols, got))
        except Missing as exc:
            missing.update({c: str(exc) for c in cols})
        except KeyError as exc:
            if strict:
                raise
            missing.update({c: exc.args[0] for c in cols})
    return values, missing


# ---------------------------------------------------------------- errors, budget, table
def _error(v, ref, kind):
    if v is None or ref is None:
        return None
    d = abs(v - ref)
    if kind == "relative":
        return d / abs(ref) if ref != 0 else (0.0 if d == 0 else math.inf)
    return d


def recommend(records: list[dict], columns: list[str], budget: float, cost: str = "wall_time") -> dict:
    """The cheapest setting whose errors of all quantities are at most ``budget``.

    Timings within :data:`TIME_TIE` (5 %) of the fastest passing one count as
    equal (timing noise); among those the first in ``records`` (the coarsest
    setting, as listed) is recommended.

    Parameters
    ----------
    records : list of dict
        Rows of ``convergence.csv`` as dicts (``setting``, ``reference``,
        ``wall_time``, ``<column>_error``).
    columns : list of str
        The quantity columns.
    budget : float
    cost : str
        ``wall_time`` or ``cpu_time``: the column that decides which setting is cheapest.

    Returns
    -------
    dict
        ``budget``, ``setting`` (label or None), the cost (``wall_time`` or
        ``cpu_time``) of that setting, ``max_error``,
        ``message`` (one sentence saying what was found, or that no setting
        reaches the budget and which came closest).
    """
    cands = [r for r in records if not r.get("reference") and r.get("status") == "complete"]
    passing, best = [], None
    for r in cands:
        errs = [r.get(f"{c}_error") for c in columns]
        if any(e is None or (isinstance(e, float) and math.isnan(e)) for e in errs):
            continue
        worst = max(errs)
        if best is None or worst < best[1]:
            best = (r, worst)
        if worst <= budget:
            passing.append((r[cost], r, worst))
    if passing:
        fastest = min(t for t, _, _ in passing)
        # timings within TIME_TIE of the fastest are equal within their noise: the first listed (coarsest) wins
        t, r, worst = next(p for p in passing if p[0] <= (1 + TIME_TIE) * fastest)
        tie = "" if t == fastest else f"; within {TIME_TIE:.0%} of the fastest, {fastest:.3g} s, so equal in cost"
        return {"budget": budget, "setting": r["setting"], cost: t, "max_error": worst,
                "message": f"cheapest setting with every error <= {budget:.3g}: {r['setting']} "
                           f"({t:.3g} s, largest error {worst:.2e}{tie})"}
    msg = f"no setting (the reference excluded: its own error is not measured) reaches every error <= {budget:.3g}"
    if best is not None:
        msg += f"; the smallest largest error is {best[1]:.2e}, at {best[0]['setting']} ({best[0][cost]:.3g} s)"
    else:
        msg += "; no setting has every quantity"
    return {"budget": budget, "setting": None, cost: None, "max_error": None if best is None else best[1],
            "message": msg}


def read_records(path: Path, columns: list[str]) -> list[dict]:
    """Rows of a ``convergence.csv`` as dicts for :func:`recommend` (empty cells as None)."""
    import csv

    out = []
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            rec = {"setting": row["setting"], "group": row.get("group", ""), "reference": row["reference"] == "true",
                   "status": row["status"]}
            for k in ["wall_time", "cpu_time"] + [f"{c}_error" for c in columns]:
                v = row.get(k, "")
                rec[k] = float(v) if v not in ("", None) else None
            out.append(rec)
    return out


def _fmt(v, err=False) -> str:
    if v is None:
        return "-"
    if err:
        return "0" if v == 0 else f"{v:.2e}"
    return f"{v:.10g}"


def format_table(records: list[dict], items: list[tuple[str, str]], error_kinds: dict) -> list[str]:
    """The printed table: one line per setting, value and error of each quantity."""
    head = ["setting", "wall [s]", "cpu [s]"]
    for c, _ in items:
        head += [c, f"{'rel.' if error_kinds[c] == 'relative' else 'abs.'} error"]
    body = []
    for r in records:
        label = r["setting"] + (" (ref.)" if r["reference"] else "")
        line = [label] + [f"{r[k]:.3f}" if r[k] is not None else "-" for k in ("wall_time", "cpu_time")]
        for c, _ in items:
            line += [_fmt(r.get(c)), "-" if r["reference"] else _fmt(r.get(f"{c}_error"), True)]
        body.append(line)
    widths = [max(len(x[j]) for x in [head] + body) for j in range(len(head))]
    fmt = lambda cells: "  ".join(c.ljust(w) if j == 0 else c.rjust(w) for j, (c, w) in enumerate(zip(cells, widths)))
    out = [fmt(head), fmt(["-" * w for w in widths])] + [fmt(b) for b in body]
    for r in records:
        if r["missing"]:
            out.append(f"missing at {r['setting']}: {r['missing']}")
    return out


# ---------------------------------------------------------------- the run
def base_columns(btype: str, scene, model, plan) -> tuple[str, dict]:
    """The parameter of a base run and the columns of its files (``file -> columns``), from its check's plan."""
    if btype == "frequency_response":
        from contin.analyses.frequency_response import SPECIAL_EXTRA, plot_measures

        hb = plan[0][1]
        measures = plot_measures(scene, model, hb)
        head = ["branch", "nu", hb.parameter, "stable"]
        return hb.parameter, {"branches.csv": head + measures + ["newton_iterations", "residual_norm"],
                              "special_points.csv": ["branch", "kind", hb.parameter, "index"]
                              + measures[:-2] + SPECIAL_EXTRA}
    if btype == "simulate":
        from contin.analyses.simulate import _columns

        return plan["param"], {"simulation.csv": _columns(plan["param"], model.dof_names)}
    if btype == "static":
        return plan["param"], plan["columns"]
    return "amplitude", plan["columns"]  # backbone


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


def check(scene, model) -> dict:
    """Every check of a ``convergence`` scene; returns its setup.

    Each setting's scene is built and checked as its run will check it
    (:func:`contin.analyses.check_scene`), so that a setting the base
    analysis refuses is found before anything is written, and every column
    a quantity reads must be one the runs write (``hK_`` columns: at some
    setting).

    Returns
    -------
    dict
        ``quantities`` (checked), ``settings``, ``iref``, ``labels``,
        ``scenes`` (one per setting), ``defaults``, ``items`` (quantity
        columns and descriptions) and ``kinds`` (column -> error kind).
    """
    from contin.scene.registry import check_scene
    from contin.util.naming import suggest
    from contin.scene.build import build_model
    from contin.scene.parse import scene_from_data

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
            plan = check_scene(sc, m)
        except SceneError as exc:
            if exc.key.startswith("output."):
                raise  # the scene's own output section, the same at every setting
            raise SceneError("analysis.vary", "settings the base analysis accepts", label,
                             scene.lines.get("analysis.vary"), hint=f"; with them: {exc}") from None
        param, files = base_columns(btype, sc, m, plan)
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
    return {"quantities": quantities, "settings": settings, "iref": iref, "labels": labels, "scenes": scenes,
            "defaults": defaults, "items": items, "kinds": kinds}


@register_analysis("convergence", CONVERGENCE, validate, check)
def run(ctx) -> dict:
    """Run a ``convergence`` scene; returns its part of ``summary.json``."""
    from contin.output.results import CsvStream
    from contin.scene.registry import RunError

    scene = ctx.scene
    a = scene.analysis
    btype = a["base"]["type"]
    table_file = BASE_TABLES[btype]
    plan = ctx.plan  # check(), made before anything was written
    quantities, settings, iref, labels = plan["quantities"], plan["settings"], plan["iref"], plan["labels"]
    scenes, defaults, items, kinds = plan["scenes"], plan["defaults"], plan["items"], plan["kinds"]
    columns = [c for c, _ in items]
    runs_dir = ctx.outdir / "runs"
    runs_dir.mkdir(exist_ok=True)
    t_all = time.perf_counter()
    if a["warmup"]:
        ctx.progress.update(f"warm-up run ({labels[0]}), not timed")
        try:
            ctx.run_scene(scenes[0], runs_dir / "warmup", progress=False)
        except RunError:
            pass  # the timed run reports it
        except SceneError as exc:  # check() ran every check of this setting: a guard, not a path
            raise SceneError("analysis.vary", "settings the base analysis accepts", labels[0],
                             hint=f"; with them: {exc}") from None
        ctx.timings["warmup"] = time.perf_counter() - t_all

    first_complete = [True]

    def check_columns(run_dir):
        """A column no run writes (check() refuses those before the run; a guard at the first complete run)."""
        if not first_complete[0]:
            return
        first_complete[0] = False
        try:
            extract(run_dir, quantities, defaults, table_file, strict=True)
        except KeyError as exc:
            if not re.search(r"'h\d+_", exc.args[0]):
                raise SceneError("analysis.quantities", "columns the base analysis writes", None,
                                 hint=f": {exc.args[0]}") from None

    records = []
    for i, (s, label, sc) in enumerate(zip(settings, labels, scenes)):
        run_dir = runs_dir / f"{i:02d}_{_slug(label)}"
        ctx.progress.update(f"setting {i + 1}/{len(settings)}: {label}")
        status, message, wall, cpu, points = "complete", "", None, None, None
        for _ in range(a["repeat"]):
            t0, c0 = time.perf_counter(), time.process_time()
            try:
                summary = ctx.run_scene(sc, run_dir, progress=False)
            except RunError as exc:
                status, message = "failed", " ".join(str(exc).split())
                wall, cpu = time.perf_counter() - t0, time.process_time() - c0  # the time spent until it failed
                break
            except SceneError as exc:  # a value the model refuses at run time (bad input, not a missing value)
                raise SceneError("analysis.vary", "settings the base analysis accepts", label,
                                 hint=f"; with them: {exc}") from None
            dt, dc = time.perf_counter() - t0, time.process_time() - c0
            if wall is None or dt < wall:
                wall, cpu = dt, dc
            status = summary["status"]
            points = (summary.get("analysis") or {}).get("rows")
            # branches that ended early say why (a start that did not converge, a step that collapsed, ...)
            message = "; ".join(f"branch {b.get('branch')}: {b.get('message')}"
                                for b in (summary.get("analysis") or {}).get("branches", [])
                                if b.get("status") in EARLY_ENDS and b.get("message"))
            if status == "interrupted":
                message = "interrupted"
                break
            if status == "incomplete":  # what it computed still counts; the branches that gave up say why
                message = message or summary.get("message", "")
        group = setting_label({k: s[k] for k in list(s)[:-1]}, a["labels"])  # the lines of the plot
        rec = {"setting": label, **s, "group": group, "reference": i == iref, "status": status, "wall_time": wall,
               "cpu_time": cpu,
               "points": points, "run": str(run_dir.relative_to(ctx.outdir)), "message": message}
        if status in ("complete", "incomplete"):
            check_columns(run_dir)
            vals, miss = extract(run_dir, quantities, defaults, table_file)
            if message:
                miss = {c: f"{why} ({message})" for c, why in miss.items()}
        else:
            vals, miss = {}, {c: f"run {status}" + (f" ({message})" if message and message != "interrupted" else "")
                              for c in columns}
        rec.update(vals)
        rec["_missing"] = miss
        records.append(rec)
        if status == "interrupted" or ctx.stop_requested:
            ctx.interrupted = True
            break
    ctx.timings["runs"] = time.perf_counter() - t_all
    ref = records[iref] if iref < len(records) else None
    for r in records:
        miss = dict(r.pop("_missing"))
        for c in columns:
            rv = None if ref is None else ref.get(c)
            e = _error(r.get(c), rv, kinds[c])
            r[f"{c}_error"] = e
            if r.get(c) is not None and rv is None and c not in miss:
                miss[c] = "reference has none" if ref is not None else "reference not run"
        errs = [r[f"{c}_error"] for c in columns]
        r["max_error"] = None if any(e is None for e in errs) else max(errs)
        if len(miss) == len(columns) and len(set(miss.values())) == 1:
            r["missing"] = "every quantity: " + next(iter(miss.values()))
        else:
            r["missing"] = "; ".join(f"{c}: {why}" for c, why in miss.items())
    vary_cols = list(a["vary"])
    header = ["setting"] + vary_cols + ["group", "reference", "status", "wall_time", "cpu_time", "points"]
    for c in columns:
        header += [c, f"{c}_error"]
    header += ["max_error", "missing", "run", "message"]
    csv = CsvStream(ctx.outdir / "convergence.csv", header)
    for r in records:
        csv.write({k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()})
    csv.close()
    budget = a["budget"]
    recommendation = recommend(records, columns, budget, a["cost"]) if budget is not None else None
    ref_label = labels[iref]
    table = [f"convergence of the {btype} analysis; reference {ref_label}; wall time of each run after one "
             f"untimed warm-up run (numba compilation excluded)" if a["warmup"] else
             f"convergence of the {btype} analysis; reference {ref_label}; wall time of each run (no warm-up)"]
    table += [f"  {c}: {d}" for c, d in items]
    table += format_table(records, items, kinds)
    if recommendation:
        table.append(recommendation["message"])
    ctx.plot = lambda: _plot(ctx, records, items, kinds, budget, btype, ref_label, a["cost"])
    return {
        "base": btype,
        "vary": vary_cols,
        "combine": a["combine"],
        "reference": ref_label,
        "quantities": [{"column": c, "description": d, "error": kinds[c]} for c, d in items],
        "timing": "wall time of each whole run (time.perf_counter), after one untimed warm-up run of the first "
                  "setting so that numba compilation is not counted" if a["warmup"] else
                  "wall time of each whole run (time.perf_counter), no warm-up",
        "settings": [{k: v for k, v in r.items()} for r in records],
        "table": table,
        "recommendation": recommendation,
        "columns": columns,
        "cost": a["cost"],
        # the errors are measured against the reference: a reference that fell short is a shortfall of the
        # study; a coarse setting that fell short is one of its findings (its row says why)
        "shortfalls": [f"the reference setting {ref_label} ended {ref['status']}: {ref.get('message') or ''}".rstrip(": ")]
        if ref is not None and ref["status"] not in ("complete", "interrupted") else [],
    }


def plot_convergence(path: Path, records: list[dict], items: list[tuple[str, str]], kinds: dict,
                     budget: float | None, cost: str, title: str) -> None:
    """Log-log error against time, one line per quantity (and per value of the other settings), points labelled.

    Parameters
    ----------
    path : Path
        The PNG to write.
    records : list of dict
        ``setting``, ``group`` (the values of the settings but the last: one
        line each), ``reference``, ``wall_time``, ``cpu_time`` and
        ``<column>_error`` per setting (reference and zero errors are left out).
    items : list of (str, str)
        Quantity columns and descriptions.
    kinds : dict
        Column -> ``relative`` or ``absolute``.
    budget : float or None
        Drawn as a horizontal line.
    cost : str
        ``wall_time`` or ``cpu_time``: the horizontal axis.
    title : str
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, ax = plt.subplots(figsize=(7.5, 5.2))
    markers = "osD^v<>ph*"
    drawn = 0
    labelled: set = set()
    groups = list(dict.fromkeys(r.get("group", "") for r in records))
    styles = ["-", "--", ":", "-."]
    for k, (c, d) in enumerate(items):
        for g, group in enumerate(groups):
            pts = [(r[cost], r[f"{c}_error"], r["setting"]) for r in records
                   if r.get("group", "") == group and not r["reference"] and r.get(cost) is not None
                   and r.get(f"{c}_error") not in (None, 0.0) and math.isfinite(r[f"{c}_error"])]
            if not pts:
                continue
            drawn += 1
            t, e, lab = zip(*pts)
            name = f"{c} ({kinds[c]})" + (f", {group}" if group else "")
            ax.loglog(t, e, marker=markers[(k + g) % len(markers)], ls=styles[g % len(styles)], label=name)
            for ti, ei, li in zip(t, e, lab):
                if li not in labelled:  # the quantities of a setting share its time: one label per setting
                    labelled.add(li)
                    short = li[len(group) + 2:] if group and li.startswith(group + ", ") else li
                    ax.annotate(short, (ti, ei), textcoords="offset points", xytext=(4, 3), fontsize=7)
    if budget is not None:
        ax.axhline(budget, color="0.5", ls=":", lw=1, label=f"budget {budget:g}")
    ax.set_xlabel(("wall" if cost == "wall_time" else "CPU") + " time per run [s]")
    lo, hi = ax.get_xlim()
    if hi < 10 * lo:  # less than a decade: plain numbers on the time axis
        ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.tick_params(axis="x", which="minor", labelsize=7)
    ax.set_ylabel("error against the reference")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    if drawn or budget is not None:
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def replot(outdir: Path, budget: float | None = None) -> Path:
    """Draw ``convergence.png`` of a finished convergence run again.

    Parameters
    ----------
    outdir : Path
        The run's result directory.
    budget : float, optional
        Drawn as a line; by default the run's own budget, if it had one.

    Returns
    -------
    Path
        The PNG.
    """
    import json

    outdir = Path(outdir)
    summary = json.loads((outdir / "summary.json").read_text())
    a = summary["analysis"]
    items = [(q["column"], q["description"]) for q in a["quantities"]]
    kinds = {q["column"]: q["error"] for q in a["quantities"]}
    records = read_records(outdir / "convergence.csv", a["columns"])
    if budget is None and a.get("recommendation"):
        budget = a["recommendation"]["budget"]
    title = (summary["scene"].get("output") or {}).get("title") or \
        f"{summary['model']['name']}: {a['base']} accuracy against cost (reference {a['reference']})"
    path = outdir / "convergence.png"
    plot_convergence(path, records, items, kinds, budget, a.get("cost", "wall_time"), title)
    return path


def _plot(ctx, records, items, kinds, budget, btype, ref_label, cost):
    title = ctx.scene.output["title"] or f"{ctx.model.name}: {btype} accuracy against cost (reference {ref_label})"
    path = ctx.outdir / "convergence.png"
    plot_convergence(path, records, items, kinds, budget, cost, title)
    return [path.name]
