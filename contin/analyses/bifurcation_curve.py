"""``bifurcation_curve``: fold, period-doubling and Neimark-Sacker curves in the plane of two parameters.

With ``method: shooting`` the stages below are those of
:mod:`contin.analyses.shooting_curves` (the integrated flow's curves, Neimark-Sacker
curves among them); the files are the same.

1. A one-parameter run in ``parameter`` (``p1``) over ``range`` at the scene's
   value of ``second_parameter`` (``p2``) locates folds (the engine's fold
   test) and period doublings (the flip test of
   :class:`contin.bifurcation.curve_system.FlipTestEvent`, or the multiplier
   events of ``stability`` with ``pd_test: stability``).
2. Each located point of the kinds in ``curves`` is continued in ``(p1, p2)``
   over ``second_range`` (and within ``range``) by
   :func:`contin.bifurcation.two_parameter.curve_from_point`; a point that already
   lies on a traced curve (the other fold of the same jump region, the other
   period doubling of the same tongue) starts no new curve.
3. One-parameter runs at the ``overlay`` values of ``p2`` (inside or outside
   ``second_range``) locate their folds and period doublings independently;
   their distance to the curves is written and they are drawn on the
   two-parameter diagram.

Result files: ``curves.csv`` (one row per curve point: ``curve``, ``kind``,
``nu``, both parameters, and the measures of the solution there),
``curve_points.csv`` (cusps, fold-flip points, turning points ``extremum``,
starts and ends, with both parameters, and why each end was reached),
``one_parameter_points.csv`` (every fold and period doubling of the
one-parameter runs, with both parameters, the curve it belongs to and its
distance to it), ``branches.csv`` and ``special_points.csv`` of the
one-parameter runs (branch ``i`` is the run at ``p2 = values[i]``, listed in
``summary.json``), and the figure ``bifurcation_curves.<format>`` (:mod:`contin.output.plane_plot`).

The files are written when each stage finishes; an interrupted run (Ctrl-C)
keeps the curves traced so far. ``--resume`` reruns the analysis. A run held
in memory (the Python API) holds the same tables in its outcome and the
one-parameter runs' solutions in its ``data``; it writes no file and draws no figure.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from contin.analyses.base import Analysis, RunContext, RunError, ScaleCheck
from contin.analyses.bifurcation_curve_shooting import shooting_options, shooting_reference
from contin.analyses.branch_recorder import BranchRecorder
from contin.analyses.curve_files import (curve_progress, curve_shortfalls, curve_summary, not_started, on_curve, plot_curves,
                                         point_checks, write_curve_points, write_one_parameter_points, write_table)
from contin.analyses.frequency_response import build_problem, continuation_options, start_guess
from contin.analyses.simulate import check_time_step
from contin.analyses.shooting_curves import curve_rows, one_parameter_points, response_plan, run_shooting_curves
from contin.analyses.stability_hooks import stability_options
from contin.bifurcation.curve_system import FlipTestEvent
from contin.bifurcation.two_parameter import CurveOptions, curve_from_point, special_point_kind
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.factory import harmonic_balance
from contin.hb.measures import measure_names, point_measures
from contin.hb.problem import HarmonicBalance
from contin.output.outcome import Outcome
from contin.scene.budget import bifurcation_curve_demands
from contin.scene.parse import check_parameter_values
from contin.scene.preflight import dofs_text
from contin.scene.registry import check_output, shortfalls
from contin.scene.schema import (START_SIMULATION, Key, SceneError, integer, is_int, is_number, listing, mapping,
                                 number, string)
from contin.scene.sweep_plan import SweepPlan, parameter_name, sweep_plan
from contin.stability import StabilityMethod, StabilityMonitor, stability_events
from contin.timedomain.shooting import ShootingOptions

__all__ = ["BIFURCATION_CURVE", "BifurcationCurve", "BifurcationCurvePlan"]


def _pair(v) -> bool:
    return isinstance(v, list) and len(v) == 2 and all(is_number(x) for x in v) and v[0] != v[1]


#: scene schema of ``analysis`` for ``type: bifurcation_curve``
BIFURCATION_CURVE = {
    "type": string(required=True),
    "parameter": string(),
    "range": Key("a list of two different numbers [start, end]", _pair, required=True),
    "start": number(),
    "frequency": string(),
    "second_parameter": string(required=True),
    "second_range": Key("a list of two different numbers [low, high]", _pair, required=True),
    "curves": listing(["fold", "pd"], lambda x: x in ("fold", "pd", "ns"),
                      "a list of curve kinds among 'fold', 'pd', 'ns' (ns with method: shooting)"),
    # harmonic balance, or shooting on the integrated flow (contin.analyses.shooting_curves)
    "method": string("hb", ("hb", "shooting")),
    "switch": listing([], lambda x: x == "pd", "a list of bifurcation kinds among 'pd' (with method: shooting: the "
                      "2nu branches, whose points start curves too)"),
    # which located points start curves (method: shooting): all, or those nearest to the listed values of p1
    "curve_starts": Key("'all' or a list of numbers (values of the first parameter: the located point nearest to "
                        "each starts a curve)", lambda v: v == "all" or (isinstance(v, list) and v and
                                                                          all(is_number(x) for x in v)), "all"),
    "starts": listing([], lambda x: isinstance(x, dict), "a list of mappings, each a further start of the "
                      "one-parameter run (method: shooting; the keys of frequency_response's starts)"),
    "harmonics": Key("an integer from 1 to 2000", lambda v: is_int(v) and 1 <= v <= 2000, 5),
    "subharmonic": Key("an integer from 1 to 64", lambda v: is_int(v) and 1 <= v <= 64, 1),
    "samples": Key("an integer from 2*harmonics+1 to 2**20, or null",
                   lambda v: v is None or (is_int(v) and 3 <= v <= 2**20), None),
    "crossings": string("exact", ("exact", "interval", "none")),
    "stability": string("none", ("hill", "floquet", "both", "none")),
    "stability_options": mapping(),
    "pd_test": string("flip", ("flip", "stability")),
    "continuation": mapping(),
    "curve_continuation": mapping(),
    "curve_options": mapping(),
    "overlay": listing([], is_number, "a list of values of the second parameter"),
    "max_curves": integer(8, 1),
    "start_from": string("model", ("model", "linear", "simulation")),
    "start_simulation": START_SIMULATION,
    "guess": Key("a list of numbers (the harmonic coefficients) or null",
                 lambda v: v is None or (isinstance(v, list) and all(is_number(x) for x in v)), None),
    "shooting": listing([], is_number, "a list of values of the second parameter"),
    "shooting_points": Key("an integer from 3 to 10000", lambda v: is_int(v) and 3 <= v <= 10000, 41),
    "shooting_refine": Key("an integer from 0 to 30", lambda v: is_int(v) and 0 <= v <= 30, 0),
    "shooting_options": mapping(),
}

def _options(scene, key: str, cls):
    try:
        return cls.from_dict(dict(scene.analysis[key]))
    except (ValueError, TypeError) as exc:
        raise SceneError(f"analysis.{key}", f"valid {cls.__name__} fields", None, hint=f": {exc}") from None


def _one_parameter_setup(scene, hb):
    """Events and monitors of the one-parameter runs."""
    a = scene.analysis
    stab = stability_options(a)
    if a["pd_test"] == "stability" and "pd" in a["curves"] and stab.method is StabilityMethod.NONE:
        raise scene.error("analysis.pd_test", "'flip', or a stability method (analysis.stability) to locate "
                          "period doublings by their multipliers", "pd_test: stability with stability: none")

    def setup(problem):
        events, monitors = [], []
        if stab.method is not StabilityMethod.NONE:
            mon = StabilityMonitor(problem, stab)
            events += stability_events(mon, period_doubling=a["pd_test"] == "stability")
            monitors.append(mon)
        if a["pd_test"] == "flip" and "pd" in a["curves"]:
            events.append(FlipTestEvent(problem))
        return events, monitors

    return setup


def _located_points(branch, kinds) -> list:
    """Located folds / period doublings of a one-parameter branch, one per bifurcation."""
    out = []
    for sp in branch.special_points:
        kind = special_point_kind(sp)
        if kind.value not in kinds or not sp.located:
            continue
        if any(special_point_kind(q) is kind and abs(q.parameter - sp.parameter) <= 1e-7 * max(1.0, abs(sp.parameter))
               for q in out):
            continue
        out.append(sp)
    return out


@dataclass(frozen=True)
class BifurcationCurvePlan:
    """Every checked choice of a ``bifurcation_curve`` scene.

    Attributes
    ----------
    sweep : SweepPlan
        The one-parameter runs' parameter ``p1``, range, start and direction.
    hb : HarmonicBalance
        The one-parameter problem at the model's value of ``second``.
    second : str
        The second parameter ``p2``.
    second_range : (float, float)
        ``analysis.second_range``, low to high.
    second_value : float
        The model's value of ``second`` (where the first one-parameter run is).
    options : ContinuationOptions
        Of the one-parameter runs.
    curve_options : ContinuationOptions
        Of the curves (``analysis.curve_continuation``).
    curve : CurveOptions
        ``analysis.curve_options``.
    setup : callable
        ``setup(problem) -> (events, monitors)`` of a one-parameter run.
    shooting : ShootingOptions or None
        Of the shooting reference, when ``analysis.shooting`` asks for one.
    response : FrequencyResponsePlan or None
        With ``method: shooting``, the one-parameter run's
        (:func:`contin.analyses.shooting_curves.response_plan`).
    """

    sweep: SweepPlan
    hb: HarmonicBalance
    second: str
    second_range: tuple
    second_value: float
    options: ContinuationOptions
    curve_options: ContinuationOptions
    curve: CurveOptions
    setup: Callable
    shooting: ShootingOptions | None
    response: object = None


class BifurcationCurve(Analysis):
    """Fold, period-doubling and Neimark-Sacker curves in the plane of two parameters (this module's docstring
    says how; ``method: shooting``: :mod:`contin.analyses.shooting_curves`)."""

    name = "bifurcation_curve"
    summary = "Fold, period-doubling and Neimark-Sacker curves in the plane of two parameters."
    required = "range, second_parameter, second_range"
    schema = BIFURCATION_CURVE

    def validate(self, data: dict, model: dict, analysis: dict, lines: dict) -> None:
        """Refuse parameter values that make no physical sense (a negative frequency, mass, ...)."""
        a = analysis
        p1 = parameter_name(model, a)
        check_parameter_values(model, a, p1, [(f"analysis.{k}", a[k]) for k in ("range", "start")
                                              if a[k] is not None], lines)
        check_parameter_values(model, a, a["second_parameter"],
                               [(f"analysis.{k}", a[k]) for k in ("second_range", "overlay", "shooting") if a[k]],
                               lines)

    def demands(self, scene, model) -> list:
        return bifurcation_curve_demands(scene, model)

    def plan(self, scene, model) -> BifurcationCurvePlan:
        """Every check of the scene with its model, before anything is written."""
        a = scene.analysis
        sweep = sweep_plan(scene, model)
        hb = build_problem(scene, model)
        p1, p2 = sweep.parameter, a["second_parameter"]
        if p2 not in model.parameters:
            raise scene.error("analysis.second_parameter", f"a parameter of the model {list(model.parameters)}", p2)
        if p2 == p1:
            raise scene.error("analysis.second_parameter", f"a parameter other than analysis.parameter ({p1})", p2)
        dependent = getattr(model, "dependent_parameters", None) or {}
        for key, name in (("analysis.parameter", p1), ("analysis.second_parameter", p2)):
            if name in dependent:
                raise scene.error(key, f"an independent parameter (one of {list(model.parameters)})", name)
        lo2, hi2 = sorted(float(v) for v in a["second_range"])
        p2_value = float(model.parameters[p2])
        if not lo2 <= p2_value <= hi2:
            raise scene.error("analysis.second_range", f"a range containing the model's {p2} = {p2_value:g}",
                              a["second_range"])
        if a["guess"] is not None and len(a["guess"]) != hb.size:
            raise scene.error("analysis.guess", f"{hb.size} numbers (n*(2H+1) coefficients)",
                              f"{len(a['guess'])} numbers")
        for key, cls in (("continuation", ContinuationOptions), ("curve_continuation", ContinuationOptions),
                         ("curve_options", CurveOptions)):
            _options(scene, key, cls)
        response = None
        if a["method"] == "shooting":
            if a["shooting"]:
                raise scene.error("analysis.shooting", "no reference values with method: shooting (the curves are "
                                  "the integrated flow's)", a["shooting"])
            shooting_options(scene)  # the discretisation's options, checked by name
            response = response_plan(scene, model)
        else:
            if a["starts"]:
                raise scene.error("analysis.starts", "method: shooting for further starts", a["starts"])
            for key, bad in (("curves", "ns"), ("switch", "pd")):
                if bad in a[key]:
                    raise scene.error(f"analysis.{key}", f"method: shooting for '{bad}' (harmonic balance follows "
                                      "fold and period-doubling curves of the one-parameter branch)", a[key])
        shooting = None
        if a["shooting"]:
            if "pd" not in a["curves"]:
                raise scene.error("analysis.shooting", "period-doubling curves to check ('pd' in analysis.curves)",
                                  a["shooting"])
            shooting = shooting_options(scene)
        setup = _one_parameter_setup(scene, hb)
        opts = continuation_options(scene, sweep.start, sweep.end)
        if a["start_from"] == "simulation":  # each one-parameter run may start from a simulation
            for value in [p2_value] + [float(v) for v in a["overlay"]]:
                check_time_step(model, {p1: sweep.start, p2: value},
                                a["start_simulation"].get("steps_per_period", 4096),
                                "analysis.start_simulation.steps_per_period", scene.lines, "analysis.start",
                                hb.frequency)
        obs = list(getattr(model, "observable_names", ()) if getattr(model, "observables", None) else ())
        measures = measure_names(model.dof_names, scene.output["harmonic_columns"], hb.H) + obs
        check_output(scene, measures + ["max_multiplier", "n_unstable"], [p1, p2])
        return BifurcationCurvePlan(sweep, hb, p2, (lo2, hi2), p2_value, opts,
                                    _options(scene, "curve_continuation", ContinuationOptions),
                                    _options(scene, "curve_options", CurveOptions), setup, shooting, response)

    def describe(self, plan: BifurcationCurvePlan, scene, model) -> list[str]:
        """The one-parameter run, the unknowns, the curves, the overlaid runs and the shooting reference."""
        hb, a = plan.hb, scene.analysis
        p1, p2 = plan.sweep.parameter, plan.second
        (lo, hi), (lo2, hi2) = (plan.sweep.lo, plan.sweep.hi), plan.second_range
        if plan.response is not None:
            steps = int(dict(a["shooting_options"]).get("steps_per_period", 4096))
            n = 2 * hb.n
            starts = "all located points" if a["curve_starts"] == "all" else \
                f"the located points nearest to {p1} = " + ", ".join(f"{v:g}" for v in a["curve_starts"])
            return [f"  one-parameter run in {p1} over [{lo:g}, {hi:g}] at {p2}={plan.second_value:g} by shooting "
                    f"({steps} RK4 steps a forcing period, contact switches located), "
                    f"{len(plan.response.starts)} start(s)",
                    f"  unknowns: {n} = {hb.n} dof x 2 (x, x'); curve systems: {n + 1} (state and {p1}), ns: {n + 2} "
                    f"(and the multiplier's angle)",
                    f"  curves: {', '.join(a['curves'])} in ({p1}, {p2}), {p2} over [{lo2:g}, {hi2:g}], from {starts}",
                    f"  overlaid one-parameter runs at {p2} = {', '.join(f'{v:g}' for v in a['overlay']) or 'none'}"]
        return [f"  one-parameter run in {p1} over [{lo:g}, {hi:g}] at {p2}={plan.second_value:g}, harmonics "
                f"H={hb.H}, subharmonic nu={hb.nu}, samples N={hb.N}",
                f"  unknowns: {hb.size} = {hb.n} dof x (2H+1); curve systems: {hb.size + 1} (coefficients and {p1})",
                f"  curves: {', '.join(a['curves'])} in ({p1}, {p2}), {p2} over [{lo2:g}, {hi2:g}]"
                + (f"; period doublings located by the {'flip test' if a['pd_test'] == 'flip' else 'multipliers'}"
                   if "pd" in a["curves"] else ""),
                f"  overlaid one-parameter runs at {p2} = {', '.join(f'{v:g}' for v in a['overlay']) or 'none'}",
                f"  period doublings of the integrated flow (shooting) at {p2} = "
                f"{', '.join(f'{v:g}' for v in a['shooting']) or 'none'}"]

    def scale_checks(self, plan: BifurcationCurvePlan) -> list[ScaleCheck]:
        """The one-parameter problem's unknowns, and the curve systems' (those and ``p1``)."""
        hb = plan.hb
        return [ScaleCheck("analysis.continuation.unknown_scale", plan.options, hb.size,
                           f"{dofs_text(hb.n)} x {2 * hb.H + 1} coefficients"),
                ScaleCheck("analysis.curve_continuation.unknown_scale", plan.curve_options, hb.size + 1,
                           f"{hb.size} coefficients and {hb.parameter}")]

    def run(self, plan: BifurcationCurvePlan, ctx: RunContext) -> Outcome:
        """The one-parameter run, the curves from its points, the overlaid runs and the shooting reference."""
        if plan.response is not None:
            return _run_shooting(self, plan, ctx)
        return _run(self, plan, ctx)


def _run(analysis: BifurcationCurve, plan: BifurcationCurvePlan, ctx: RunContext) -> Outcome:
    scene, model = ctx.scene, ctx.model
    a = scene.analysis
    hb, lam0 = plan.hb, plan.sweep.start
    lo, hi = plan.sweep.lo, plan.sweep.hi
    (lo2, hi2), p2_value = plan.second_range, plan.second_value
    p1, p2 = plan.sweep.parameter, plan.second
    opts, curve_opts, cur_opts, setup = plan.options, plan.curve_options, plan.curve, plan.setup

    rec = BranchRecorder(ctx.sink, model.dof_names, p1, scene.output["harmonic_columns"], hb.H, model=model)
    rec.expansion.full = hb
    ctx.recorder = rec
    runs_info: list[dict] = []
    kinds = tuple(a["curves"])

    first: dict = {}

    def start_at(problem, value: float):
        """A start at ``p2 = value``: the first run's start followed in ``p2``, else the model's own start."""
        if "u" in first:
            hb2 = harmonic_balance(model, p2, hb.options, {p1: lam0}, hb.frequency)
            step = opts.replace(direction=1 if value > p2_value else -1, detect_branch_points=False)
            br = continuation(hb2, first["u"], p2_value, sorted((p2_value, value)), step, parameter_name=p2,
                              solve_start=False)
            if len(br) and br.parameter[-1] == value:
                return br.unknowns[-1].copy()
        return start_guess(scene, model, problem, lam0)

    def one_parameter(index: int, value: float):
        problem = hb if value == p2_value else harmonic_balance(model, p1, hb.options, {p2: value}, hb.frequency)
        if index == 0 and a["guess"] is not None:
            u0 = np.array(a["guess"], dtype=float)
        elif index == 0:
            u0 = start_guess(scene, model, problem, lam0)
        else:
            try:
                u0 = start_at(problem, value)
            except RunError as exc:
                runs_info.append({"branch": index, p2: value, "points": 0, "status": "start_failed",
                                  "message": str(exc)})
                return problem, None
        events, monitors = setup(problem)

        def cb(branch, i):
            rec.point(index, problem.nu, branch, i, problem.H)
            ctx.progress.update(f"one-parameter run {index} ({p2}={value:.6g})  {p1}={branch.parameter[i]:.6g}"
                                f"  point {i}", parameter=branch.parameter, bounds=(lo, hi), task=f"run {index}")
            return not ctx.stop_requested

        br = continuation(problem, u0, lam0, (lo, hi), opts, parameter_name=p1, events=events, monitors=monitors,
                          callback=cb)
        if index == 0 and len(br):
            first["u"] = br.unknowns[0].copy()
        rec.special_points(index, br)
        runs_info.append({"branch": index, p2: value, "points": len(br), "status": br.status.value,
                          "message": br.message,
                          "special_points": {k: sum(1 for s in br.special_points if special_point_kind(s).value == k)
                                             for k in ("fold", "pd", "bp", "ns")}})
        return problem, br

    t0 = time.perf_counter()
    curves: list = []
    skipped: list = []
    try:
        problem0, branch0 = one_parameter(0, p2_value)
        ctx.timings["one_parameter"] = time.perf_counter() - t0
        t1 = time.perf_counter()
        scale1 = hi - lo
        for sp in _located_points(branch0, kinds):
            if ctx.stop_requested:
                break
            kind = special_point_kind(sp).value
            why = not_started(on_curve(curves, kind, float(sp.parameter), p2_value), len(curves), a["max_curves"],
                              1e-6 * scale1)
            if why is not None:
                skipped.append({"kind": kind, p1: float(sp.parameter), **why})
                continue
            curves.append(curve_from_point(problem0, sp, p2, (lo2, hi2), (lo, hi), curve_opts, cur_opts,
                                           callback=curve_progress(ctx, kind, len(curves), p1, p2, (lo2, hi2))))
        ctx.timings["curves"] = time.perf_counter() - t1
        _write_curves(ctx, curves, p1, p2, model)
        t2 = time.perf_counter()
        overlay = []
        for j, value in enumerate(a["overlay"], start=1):
            if ctx.stop_requested:
                break
            _, br = one_parameter(j, float(value))
            if br is not None:
                overlay.append((j, float(value), br))
        ctx.timings["overlay"] = time.perf_counter() - t2
        t3 = time.perf_counter()
        shooting = {}
        if a["shooting"] and len(branch0) and not ctx.stop_requested:
            shooting = shooting_reference(ctx, plan.shooting, problem0, branch0, curves, p1, p2, p2_value, (lo, hi))
        ctx.timings["shooting"] = time.perf_counter() - t3
    finally:
        rec.close()
    entries = [(j, value, br, hb.nu) for j, value, br in [(0, p2_value, branch0)] + overlay]
    checks = write_one_parameter_points(ctx, point_checks(entries, curves, kinds, p1, p2), p1, p2)
    ctx.interrupted = ctx.interrupted or ctx.stop_requested
    lines = [v for _, v, _ in overlay] + [p2_value]
    part = {
        "parameters": [p1, p2],
        "range": [lo, hi],
        "second_range": [lo2, hi2],
        "unknowns": hb.size,
        "harmonics": hb.H,
        "subharmonic": hb.nu,
        "samples": hb.N,
        "one_parameter_runs": runs_info,
        "curves": [curve_summary(cid, cur, p1, p2) for cid, cur in enumerate(curves)],
        "starts_on_earlier_curves": skipped,
        "one_parameter_points": len(checks),
        "max_distance_to_curves": max((c["distance"] for c in checks if c["distance"] is not None), default=None),
        "shooting": {k: v for k, v in shooting.items() if k != "points"},
        "shortfalls": shortfalls(runs_info, p1, what="one-parameter run") + curve_shortfalls(ctx, curves, skipped,
                                                                                             p1, p2),
    }
    return analysis.outcome(ctx, part, shortfalls=part["shortfalls"], data=rec.run_data(ctx.summary),
                            draw=lambda: plot_curves(ctx, curves, checks, p1, p2, (lo, hi), (lo2, hi2), lines,
                                                     shooting.get("points", [])))


def _write_curves(ctx, curves, p1, p2, model) -> None:
    names = list(model.dof_names)
    hc = ctx.scene.output["harmonic_columns"]
    H = max((c.harmonics for c in curves), default=1)
    obs = list(getattr(model, "observable_names", ()) if getattr(model, "observables", None) else ())

    def rows():
        for cid, cur in enumerate(curves):
            for i in range(len(cur)):
                u = cur.unknowns[i]
                row = {"curve": cid, "kind": cur.kind.value, "nu": cur.nu, p1: float(cur.p1[i]), p2: float(cur.p2[i])}
                row.update(point_measures(u, len(names), names, hc))
                if obs:
                    row.update(model.observables(u, len(names), cur.nu))
                yield row

    write_table(ctx, "curves.csv", ["curve", "kind", "nu", p1, p2] + measure_names(names, hc, H) + obs, rows())
    write_curve_points(ctx, curves, p1, p2)


def _run_shooting(analysis: BifurcationCurve, plan: BifurcationCurvePlan, ctx: RunContext) -> Outcome:
    """``method: shooting`` (:mod:`contin.analyses.shooting_curves`): its stages, files and figure."""
    a = ctx.scene.analysis
    p1, p2 = plan.sweep.parameter, plan.second
    (lo, hi), (lo2, hi2) = (plan.sweep.lo, plan.sweep.hi), plan.second_range
    curves, runs, runs_info, skipped, rec, unmatched = run_shooting_curves(plan, ctx)
    names = list(ctx.model.dof_names)
    head = ["curve", "kind", "nu", p1, p2, "angle"]
    write_table(ctx, "curves.csv", head + rec.measures,
                (row for cid, cur in enumerate(curves) for row in curve_rows(rec, cur, cid, p1, p2)))
    write_curve_points(ctx, curves, p1, p2)
    checks = write_one_parameter_points(ctx, one_parameter_points(runs, curves, tuple(a["curves"]), p1, p2),
                                        p1, p2, nu=True)
    ctx.interrupted = ctx.interrupted or ctx.stop_requested
    lines = sorted({float(v) for _, v, _, _ in runs})
    part = {
        "method": "shooting", "parameters": [p1, p2], "range": [lo, hi], "second_range": [lo2, hi2],
        "unknowns": 2 * len(names), "steps_per_period": int(dict(a["shooting_options"]).get("steps_per_period", 4096)),
        "one_parameter_runs": runs_info,
        "curves": [curve_summary(cid, cur, p1, p2) for cid, cur in enumerate(curves)],
        "starts_on_earlier_curves": skipped,
        "one_parameter_points": len(checks),
        "max_distance_to_curves": max((c["distance"] for c in checks if c["distance"] is not None), default=None),
        "shortfalls": shortfalls(runs_info, p1, rec.failed_switches, what="one-parameter branch")
        + curve_shortfalls(ctx, curves, skipped, p1, p2) + shortfalls(unmatched, p1, what="curve"),
    }
    return analysis.outcome(ctx, part, shortfalls=part["shortfalls"], data=rec.run_data(ctx.summary),
                            draw=lambda: plot_curves(ctx, curves, checks, p1, p2, (lo, hi), (lo2, hi2), lines,
                                                     on_curves_only=True))
