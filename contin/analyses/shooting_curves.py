"""``bifurcation_curve`` with ``method: shooting``: curves of the integrated flow's folds, period doublings and
Neimark-Sacker points.

1. A one-parameter run in ``parameter`` at the scene's value of
   ``second_parameter``: the ``frequency_response`` of ``method: shooting``
   (the equations of motion integrated, contact switches located; Floquet
   multipliers by periodic Schur), with the branches ``switch`` asks for
   (``[pd]``: the ``2 nu`` branch at each period doubling).
2. Each located fold, period doubling and Neimark-Sacker point of those
   branches, of the kinds in ``curves``, is continued in ``(p1, p2)`` by
   :mod:`contin.bifurcation.shooting_curve_system` (single shooting of the
   branch's own order ``nu``), unless it lies on a curve already traced.
3. One-parameter runs at the ``overlay`` values of ``p2``, started and
   followed on their own, locate their points independently; their distance
   to the curves is written and drawn.

The files are those of the harmonic-balance form (:mod:`contin.analyses.bifurcation_curve`);
``curves.csv`` adds ``angle`` (the Neimark-Sacker multiplier's angle
``theta``, radians) and its rows' measures come from the integrated orbit.
"""

from __future__ import annotations

import math
import time

import numpy as np

from contin.analyses.base import RunError
from contin.analyses.branch_recorder import BranchRecorder
from contin.analyses.curve_files import curve_progress, not_started, on_curve, point_checks
from contin.analyses.frequency_response import FrequencyResponse, start_guess
from contin.analyses.shooting_rows import order_of, shooting_start
from contin.bifurcation.shooting_curve_system import ShootingCurveProblem
from contin.bifurcation.two_parameter import special_point_kind, trace_curve
from contin.scene.parse import scene_from_data
from contin.timedomain.multiple_shooting import ShootingProblem
from contin.timedomain.shooting_options import ShootingOptions
from contin.timedomain.simulation import SimulationError

__all__ = ["response_plan", "run_shooting_curves", "curve_start"]

#: how near (relative to the range) a located point must be to a value of ``curve_starts``
NEAR = 1e-2
#: the one-parameter run's keys taken from the bifurcation_curve scene as they are
_SHARED = ("parameter", "range", "start", "frequency", "subharmonic", "start_from", "start_simulation", "switch",
           "continuation", "stability_options", "max_branches", "starts")


def response_plan(scene, model, value: float | None = None):
    """The plan of the one-parameter ``frequency_response`` run by shooting, at ``p2 = value`` (None: the
    scene's own value)."""
    a = scene.analysis
    sweep = {k: a[k] for k in _SHARED if a.get(k) is not None}
    opts = dict(a["shooting_options"])
    lo, hi = sorted(a["range"])
    inside = a["start"] is not None and lo < a["start"] < hi
    sweep.update(type="frequency_response", method="shooting", stability="floquet", both_ways=bool(inside),
                 shooting={"steps_per_period": int(opts.get("steps_per_period", 4096))})
    data = {**scene.data, "analysis": sweep, "output": {"plots": False}}
    if value is not None:
        data["model"] = {**scene.data["model"], "parameters": {**(scene.data["model"].get("parameters") or {}),
                                                               a["second_parameter"]: float(value)}}
        model = None
    sc = scene_from_data(data, scene.source, scene.lines)
    if model is None:
        from contin.scene.build import build_model  # deferred: only for the overlaid runs

        model = build_model(sc)
    return FrequencyResponse().plan(sc, model)


def _follow(plan, ctx, rec, first_id: int) -> list:
    """The branches of the one-parameter run (the frequency_response's starts, in order)."""
    results = []
    for setup in plan.starts:
        sc, hb_i, problem, lam0 = setup.scene, setup.hb, setup.problem, setup.sweep.start
        a = sc.analysis
        u_hb = None if a["start_from"] == "simulation" else start_guess(sc, ctx.model, hb_i, lam0)
        try:
            u0 = shooting_start(problem, hb_i, a, lam0, u_hb)
        except (SimulationError, ArithmeticError) as exc:
            raise RunError(f"no starting orbit at {hb_i.parameter}={lam0:g}: {exc}") from None
        results += setup.follow(problem, u0, lam0, (setup.sweep.lo, setup.sweep.hi), setup.options, rec, ctx,
                                first_id=first_id + len(results))
    return results


def _angle(problem, u, lam: float) -> float:
    """The angle in (0, pi) of the multiplier nearest the unit circle with a positive imaginary part."""
    mu = problem.multipliers(u, lam)
    upper = mu[np.imag(mu) > 1e-12]
    if not upper.size:
        raise ArithmeticError(f"no complex multiplier at {problem.parameter}={lam:.10g}")
    return float(np.angle(upper[np.argmin(np.abs(np.abs(upper) - 1.0))]))


def curve_start(problem, point, kind: str, p2: str, steps_per_period: int, detect, p1_scale: float):
    """``(curve problem, z0)`` of a located point of a shooting branch (single shooting of the branch's order)."""
    nu = order_of(problem)
    single = ShootingProblem(problem.model, problem.parameter, problem.base,
                             ShootingOptions(steps_per_period=steps_per_period, subharmonic=nu))
    u, lam = np.asarray(point.unknowns, float), float(point.parameter)
    x = u[: 2 * problem.model.n_dof]
    extra = [_angle(problem, u, lam)] if kind == "ns" else []
    cp = ShootingCurveProblem(single, kind, p2, detect=detect, u_scale=max(float(np.max(np.abs(x))), 1e-3),
                              p1_scale=p1_scale)
    return cp, np.concatenate([x, extra, [lam]])


def _located(results, problems: dict, kinds, near=None, scale: float = 1.0, missing: list | None = None) -> list:
    """``(branch id, problem, point, kind)`` of each located point of the kinds, one per bifurcation
    (``problems``: branch id to its problem); with ``near`` (values of the parameter), only the point nearest to
    each value, within ``NEAR scale`` (the values with none go to ``missing``)."""
    out = []
    for j, (br, _) in enumerate(results):
        problem = problems.get(j)
        for sp in br.special_points:
            kind = special_point_kind(sp).value
            if kind not in kinds or not sp.located or problem is None:
                continue
            if any(q[3] == kind and q[0] == j and abs(q[2].parameter - sp.parameter) <= 1e-7 * max(1.0, abs(
                    sp.parameter)) for q in out):
                continue
            out.append((j, problem, sp, kind))
    if near is None:
        return out
    chosen = []
    for value in near:
        best = min(out, key=lambda q: abs(float(q[2].parameter) - value), default=None)
        if best is None or abs(float(best[2].parameter) - value) > NEAR * scale:
            missing.append(value)
        elif best not in chosen:
            chosen.append(best)
    return chosen


def run_shooting_curves(plan, ctx):
    """The stages of the module docstring; returns ``(curves, runs, runs_info, skipped, rec, unmatched)``
    (``unmatched``: the values of ``curve_starts`` with no located point near them, as shortfall entries)."""
    scene, model = ctx.scene, ctx.model
    a = scene.analysis
    p1, p2 = plan.sweep.parameter, plan.second
    lo, hi = plan.sweep.lo, plan.sweep.hi
    (lo2, hi2), p2_value = plan.second_range, plan.second_value
    kinds = tuple(a["curves"])
    steps = int(dict(a["shooting_options"]).get("steps_per_period", 4096))
    rec = BranchRecorder(ctx.sink, model.dof_names, p1, scene.output["harmonic_columns"], a["harmonics"], model=model)
    rec.expansion.full = plan.hb
    ctx.recorder = rec
    runs_info, runs, curves, skipped, unmatched = [], [], [], [], []

    def one_parameter(index: int, value: float, response):
        first = sum(len(r[2]) for r in runs)
        ctx.progress.update(f"one-parameter run {index} ({p2}={value:.6g})", task=f"run {index}")
        try:
            if response is None:
                response = response_plan(scene, model, value)
            results = _follow(response, ctx, rec, first)
        except RunError as exc:
            runs_info.append({"branch": index, p2: value, "points": 0, "status": "start_failed", "message": str(exc)})
            return
        for j, (br, meta) in enumerate(results, start=first):
            runs_info.append({"branch": j, "run": index, p2: value, "nu": meta["nu"], "points": len(br),
                              "status": br.status.value, "message": br.message,
                              "special_points": {k: sum(1 for s in br.special_points
                                                        if special_point_kind(s).value == k)
                                                 for k in ("fold", "pd", "bp", "ns")}})
        runs.append((index, value, results, first))

    # a tongue's tip turns within 1e-4 in the plane, near a grazing orbit: the steps shrink until the turn is
    # resolved rather than step across it as a corner (the multipliers jump at a grazing, so a curve cannot
    # continue across one anyway)
    curve_opts = plan.curve_options.replace(corners=False)

    def start_curves(run):
        _, value, results, first = run
        if not lo2 <= value <= hi2:
            return
        near = None if a["curve_starts"] == "all" else [float(v) for v in a["curve_starts"]]
        missing = []
        located = _located(results, {j - first: p for j, p in rec.problems.items() if j >= first}, kinds, near,
                           hi - lo, missing)
        for v in missing:
            unmatched.append({"status": "start_failed", "branch": f"start at {p1}={v:g}",
                              "message": f"no located {'/'.join(kinds)} point within {NEAR * (hi - lo):.3g} of "
                                         f"{p1}={v:g} (analysis.curve_starts) to start a curve"})
        for j, problem, sp, kind in located:
            if ctx.stop_requested:
                break
            nu = order_of(problem)
            why = not_started(on_curve(curves, kind, float(sp.parameter), value, nu), len(curves), a["max_curves"],
                              1e-6 * (hi - lo))
            if why is not None:
                skipped.append({"kind": kind, "nu": nu, p1: float(sp.parameter), p2: value, **why})
                continue
            ccb = curve_progress(ctx, kind, len(curves), p1, p2, (lo2, hi2))
            try:
                cp, z0 = curve_start(problem, sp, kind, p2, steps, plan.curve.detect,
                                     hi - lo if math.isfinite(hi - lo) else 1.0)
            except ArithmeticError as exc:
                skipped.append({"kind": kind, "nu": nu, p1: float(sp.parameter), p2: value, "reason": str(exc)})
                continue
            curves.append(trace_curve(cp, z0, value, (lo2, hi2), (lo, hi), curve_opts, plan.curve,
                                      callback=ccb, nu=nu, harmonics=0))

    t0 = time.perf_counter()
    try:
        one_parameter(0, p2_value, plan.response)
        ctx.timings["one_parameter"] = time.perf_counter() - t0
        t1 = time.perf_counter()
        if runs:
            start_curves(runs[0])
        ctx.timings["curves"] = time.perf_counter() - t1
        t2 = time.perf_counter()
        for k, value in enumerate(a["overlay"], start=1):
            if ctx.stop_requested:
                break
            n_runs = len(runs)
            one_parameter(k, float(value), None)
            if len(runs) > n_runs and a["curve_starts"] == "all":  # its points on no curve start curves too
                start_curves(runs[-1])
        ctx.timings["overlay"] = time.perf_counter() - t2
    finally:
        rec.close()
    return curves, runs, runs_info, skipped, rec, unmatched


def curve_rows(rec, cur, cid: int, p1: str, p2: str):
    """The rows of ``curves.csv`` of a shooting curve: both parameters, the angle and the orbit's measures."""
    cp = cur.problem
    for i in range(len(cur)):
        z = np.concatenate([cur.unknowns[i], [cur.p1[i]]])
        x, theta, q1 = cp.split(z)
        row = {"curve": cid, "kind": cur.kind.value, "nu": cur.nu, p1: float(q1), p2: float(cur.p2[i]),
               "angle": theta}
        row.update(rec.solution_measures(cp.problem_at(cur.p2[i]), x, float(q1)))
        yield row


def one_parameter_points(runs, curves, kinds, p1: str, p2: str) -> list:
    """Every fold, period doubling and Neimark-Sacker point of the one-parameter runs with its curve's distance."""
    entries = [(j, value, br, meta["nu"]) for _, value, results, first in runs
               for j, (br, meta) in enumerate(results, start=first)]
    return point_checks(entries, curves, kinds, p1, p2, ("fold", "pd", "ns"), with_nu=True)
