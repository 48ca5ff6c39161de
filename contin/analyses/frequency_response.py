"""``frequency_response``: periodic solutions of a forced model versus a parameter.

Traces the branch of order ``nu`` from the start of ``range`` with
pseudo-arclength continuation, with stability where requested, switches at
the requested bifurcations, and streams ``branches.csv`` and
``special_points.csv`` as points are found.

With ``analysis.condense`` (``auto``, ``true``, ``false``) the engine follows
the problem condensed onto the dofs that carry nonlinear forces
(:mod:`contin.hb.condensation`); everything written stays full: the measures,
the special points, and the coefficients ``u`` of ``state.jsonl`` (whose
tangents are the engine's, in the kept dofs' coefficients, listed as
``dofs`` in each branch record).
"""

from __future__ import annotations

import inspect
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from contin.analyses.base import Analysis, RunError, ScaleCheck
# the recorder's names are part of this analysis' interface (bifurcation_curve, convergence_plan use them)
from contin.analyses.response_figure import draw_response
from contin.analyses.branch_recorder import SPECIAL_EXTRA, BranchRecorder, row_measures  # noqa: F401
from contin.analyses.simulate import check_time_step
from contin.analyses.branch_summary import condition_summary as _condition_summary
from contin.analyses.branch_summary import interval_or_none as _interval_or_none
from contin.analyses.branch_summary import stability_summary as _stability_summary
from contin.analyses.handover import boundary_gap, follow_and_hand_over, hand_over
from contin.analyses.recut import recut
from contin.analyses.shooting_rows import (METHODS, ShootingSettings, analysis_method, is_shooting, shooting_problem,
                                           shooting_start, stored_shooting_problem)
from contin.analyses.stability_hooks import stability_setup
from contin.analyses.torus_start import check_torus_start, circle_from_simulation, torus_keys_ok
from contin.bifurcation.start import START_LOW_HARMONICS, HomotopyFailed, harmonic_start, simulation_start
from contin.engine.branch import BranchStatus
from contin.engine.continuation import ContinuationOptions
from contin.engine.newton import NUMERICAL_ERRORS
from contin.bifurcation.end_check import branch_end_checks
from contin.bifurcation.torus_branch import TorusSettings
from contin.hb.condensation import condensation_dofs, condense
from contin.hb.factory import harmonic_balance
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.torus import torus_measure_names
from contin.output.checkpoint import keep_records, read_records, rebuild_branches, resumable_prefix
from contin.output.outcome import Outcome
from contin.output.model_figures import model_figures
from contin.output.results import truncate_to_valid_rows
from contin.scene.budget import frequency_response_demands
from contin.scene.parse import Scene, SceneError, check_parameter_values
from contin.scene.preflight import dofs_text, scale_key
from contin.scene.registry import check_output, shortfalls
from contin.scene.schema import (START_SIMULATION, Key, check_section, integer, is_int, is_number, listing, mapping,
                                 number, string)
from contin.scene.sweep_plan import SweepPlan, parameter_name, sweep_names, sweep_plan
from contin.timedomain.simulation import SimulationError

__all__ = ["FrequencyResponse", "FrequencyResponsePlan", "StartSetup", "BranchRecorder", "START_KEYS", "SCHEMA",
           "build_problem", "engine_problem", "start_guess", "start_scenes"]

#: keys a further start (``analysis.starts``) may change; the others are shared
START_KEYS = ("start", "start_from", "start_simulation", "subharmonic", "harmonics", "samples", "crossings", "both_ways",
              "guess", "stability_options", "switch", "continuation", "method", "shooting", "solution", "torus")


#: the keys of a ``frequency_response`` analysis section
SCHEMA = {
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
    # eliminate the dofs free of nonlinear forces exactly (contin.hb.condensation)
    "condense": Key("'auto', true or false", lambda v: v == "auto" or isinstance(v, bool), "auto"),
    "stability": string("both", ("hill", "floquet", "both", "none")),
    "stability_options": mapping(),
    "switch": listing([], lambda x: x in ("pd", "bp", "ns"), "a list of bifurcation kinds among 'pd', 'bp', 'ns'"),
    # quasi-periodic branches started at 'ns' points (contin.hb.torus, contin.bifurcation.torus_branch)
    "torus": Key("a mapping with keys among harmonics, harmonics2, samples, samples2 (integers or null), stability "
                 "('simulation' or 'none'), periods (a number > 0), steps_per_period (an integer >= 4), "
                 "locking_tol (a number in (0, 0.25)), points (an odd integer from 3 to 999: the invariant "
                 "circle's points on a shooting branch), continuation ('arclength' or 'natural': a circle branch "
                 "in natural steps of the parameter, through its folds; a torus born at a Neimark-Sacker point "
                 "grows from it first)", torus_keys_ok, {}),
    # a start on a torus: the invariant circle a simulation settles on (contin.analyses.torus_start)
    "solution": string("periodic", ("periodic", "torus")),
    "max_branches": integer(8, 1),
    "continuation": mapping(),  # validated by ContinuationOptions.from_dict
    "start_from": string("model", ("model", "linear", "simulation")),
    "start_simulation": START_SIMULATION,
    "both_ways": Key("true or false", lambda v: isinstance(v, bool), False),
    "guess": Key("a list of numbers (the harmonic coefficients) or null",
                 lambda v: v is None or (isinstance(v, list) and all(is_number(x) for x in v)), None),
    # harmonic balance, shooting on the integrated flow, or harmonic balance handed to shooting at grazing
    "method": string("auto", METHODS),
    # validated by ShootingSettings.from_dict (each key named in its messages)
    "shooting": Key("a mapping with keys among segments (an integer >= 1 dividing steps_per_period: the shooting "
                    "segments of the period) and steps_per_period (RK4 steps per forcing period, an integer from 16 "
                    "to 2**20, default 1024)", lambda v: isinstance(v, dict), {}),
    "starts": listing([], lambda x: isinstance(x, dict),
                      "a list of mappings, each a further start with keys among " + ", ".join(START_KEYS)),
}



def build_problem(scene, model) -> HarmonicBalance:
    """The harmonic-balance problem of a ``frequency_response`` scene.

    Its continuation parameter and frequency are the sweep's
    (:func:`contin.scene.sweep_plan.sweep_names`), handed to the problem; the model is not changed.
    """
    a = scene.analysis
    param, freq = sweep_names(scene, model)
    try:
        opts = HBOptions(harmonics=a["harmonics"], subharmonic=a["subharmonic"], samples=a["samples"],
                         crossings=a["crossings"])
        return harmonic_balance(model, param, opts, frequency=freq)
    except ValueError as exc:
        raise SceneError("analysis", "a discretisation the model can use", None, hint=f": {exc}") from None


def engine_problem(scene, hb: HarmonicBalance):
    """The problem the continuation follows: ``hb`` condensed as ``analysis.condense`` says.

    ``auto`` condenses when dofs free of nonlinear forces can be eliminated
    safely (:func:`contin.hb.condensation.condense`), ``true`` whenever any can
    (an error naming the key when none can), ``false`` never.
    """
    how = scene.analysis.get("condense", "auto")
    if how is False:
        return hb
    try:
        return condense(hb, require=how is True)
    except ValueError as exc:
        raise scene.error("analysis.condense", "a model with dofs free of nonlinear forces (or auto/false)", True,
                          hint=f": {exc}") from None


def condensation_summary(hb: HarmonicBalance, problem) -> dict:
    """What ``summary.json`` says of the condensation: the kept dofs and unknowns, or why there was none."""
    if problem is hb:
        _, why = condensation_dofs(hb)
        return {"condensed": False, "reason": why or "analysis.condense is false"}
    return {"condensed": True, "dofs": problem.dof_names, "unknowns": problem.size, "full_unknowns": hb.size}


def continuation_options(scene, lam_start: float, lam_end: float) -> ContinuationOptions:
    d = dict(scene.analysis["continuation"])
    d.setdefault("direction", 1 if lam_end > lam_start else -1)
    try:
        return ContinuationOptions.from_dict(d)
    except ValueError as exc:
        raise SceneError("analysis.continuation", "valid continuation options", None, hint=f": {exc}") from None


def start_guess(scene, model, hb, lam0: float, problem=None, options=None):
    """The start guess: ``analysis.start_from`` = model (its own start, else linear), linear or simulation.

    From the linear solution, Newton is tried at once on ``problem`` (the
    engine's, ``hb`` by default); where it fails with many harmonics, the start
    is solved with few and raised to ``hb.H``
    (:func:`contin.bifurcation.start.harmonic_start`). If that fails too, the
    linear solution is returned: the engine's start then fails with its own
    message, and :func:`start_advice` says what to try.
    """

    how = scene.analysis["start_from"]
    try:
        if how == "simulation":  # its keys are checked by the scene schema, its step by check()
            return simulation_start(hb, lam0, **scene.analysis["start_simulation"])
        if how == "model" and model.start is not None:
            return model.start(hb, lam0)
    except (HomotopyFailed, SimulationError) as exc:
        raise RunError(f"no starting solution at {hb.parameter}={lam0:g}: {exc}{start_advice(scene, hb, lam0)}") \
            from None
    u = hb.linear_solution(lam0)
    problem = hb if problem is None else problem
    try:
        x = harmonic_start(problem, lam0, u if problem is hb else problem.restrict(u), options)
    except (HomotopyFailed, *NUMERICAL_ERRORS):  # the engine's start says why, in its words
        return u
    return x if problem is hb else problem.expand(x, lam0)




def start_advice(scene, hb, lam0: float) -> str:
    """What to try when no start was found at ``lam0``: the other end of the range, a simulation, fewer harmonics."""
    a = scene.analysis
    lo, hi = sorted(float(v) for v in a["range"])
    other = hi if abs(lam0 - lo) <= abs(lam0 - hi) else lo
    tips = [f"start at the other end of the range (--set analysis.start={other:g}; the direction follows)"]
    if a["start_from"] != "simulation":
        tips.append("start from a time simulation (--set analysis.start_from=simulation)")
    if hb.H > START_LOW_HARMONICS:
        tips.append(f"fewer harmonics first (--set analysis.harmonics={START_LOW_HARMONICS}), "
                    "then raise them")
    return "; to try: " + ", or ".join(tips)


def _restore(outdir, parameter: str) -> dict:
    """Branches of an interrupted run in ``outdir``, its files cut back to the last point it can go on from."""
    n_rows = truncate_to_valid_rows(outdir / "branches.csv")
    records, rows, special_rows = resumable_prefix(read_records(outdir / "state.jsonl"), n_rows)
    truncate_to_valid_rows(outdir / "branches.csv", rows)
    truncate_to_valid_rows(outdir / "special_points.csv", special_rows)
    # cut the checkpoint's lines to what was kept (atomically, never through a link; state.bin is appended to)
    keep_records(outdir / "state.jsonl", len(records))
    return rebuild_branches(records, parameter)


def start_scenes(scene):
    """The scene itself, then one scene per entry of ``analysis.starts`` (its keys override)."""
    yield "analysis", scene
    for i, extra in enumerate(scene.analysis["starts"]):
        key = f"analysis.starts[{i}]"
        merged = dict(scene.analysis)  # the entry was checked with the scene (START_KEYS)
        merged.update(extra)
        merged["starts"] = []
        yield key, Scene({**scene.data, "analysis": merged}, scene.source, scene.lines)


@dataclass(frozen=True)
class StartSetup:
    """One start of a ``frequency_response`` scene, checked (the scene's own, then each of ``analysis.starts``).

    Attributes
    ----------
    key : str
        Its scene key (``analysis``, ``analysis.starts[0]``, ...).
    scene : Scene
        The scene with the start's keys merged in.
    hb : HarmonicBalance
        Its full problem.
    problem : object
        The problem the engine follows (``hb`` or its condensation).
    sweep : SweepPlan
        Parameter, frequency, range, start and direction.
    options : ContinuationOptions
    follow : callable
        Follows the branch with its stability and switches
        (:func:`contin.analyses.stability_hooks.stability_setup`).
    scale_key : str
        The key that sets its ``continuation.unknown_scale``.
    method : str
        ``hb``, ``shooting`` or ``auto`` (:func:`contin.analyses.shooting_rows.analysis_method`).
    shooting : ShootingSettings
        ``analysis.shooting``.
    """

    key: str
    scene: Scene
    hb: HarmonicBalance
    problem: object
    sweep: SweepPlan
    options: ContinuationOptions
    follow: Callable
    scale_key: str
    method: str = "hb"
    shooting: ShootingSettings = ShootingSettings()


@dataclass(frozen=True)
class FrequencyResponsePlan:
    """Every checked choice of a ``frequency_response`` scene: its starts, in order (the scene's own first)."""

    starts: tuple

    @property
    def first(self) -> StartSetup:
        return self.starts[0]


def _plan(scene, model) -> FrequencyResponsePlan:
    setups = []
    for i, (key, sc) in enumerate(start_scenes(scene)):
        a = sc.analysis
        hb = build_problem(sc, model)
        sweep = sweep_plan(sc, model, a, key)
        opts = continuation_options(sc, sweep.start, sweep.end)
        if a["guess"] is not None and len(a["guess"]) != hb.size:
            raise scene.error(f"{key}.guess", f"{hb.size} numbers (n*(2H+1) coefficients)", f"{len(a['guess'])} numbers")
        problem = engine_problem(sc, hb)
        method = analysis_method(a, hb)
        shooting = ShootingSettings.from_dict(a.get("shooting"), f"{key}.shooting")
        check_torus_start(a, key, method)
        if a["solution"] == "torus":
            method = "shooting"
        if method == "shooting":
            problem = shooting_problem(hb, shooting)
            if a["guess"] is not None:
                raise scene.error(f"{key}.guess", "no guess with method: shooting (its start is a state)", True)
        if a["start_from"] == "simulation" and a["guess"] is None:
            default = inspect.signature(simulation_start).parameters["steps_per_period"].default
            check_time_step(model, {hb.parameter: sweep.start}, a["start_simulation"].get("steps_per_period", default),
                            f"{key}.start_simulation.steps_per_period", scene.lines, f"{key}.start", hb.frequency)
        setups.append(StartSetup(key, sc, hb, problem, sweep, opts, stability_setup(a, hb if method == "shooting" else
                                                                                    problem),
                                 scale_key(scene, i), method, shooting))
    check_output(scene, plot_measures(scene, model, setups[0].hb), list(model.parameters), panels=True)
    return FrequencyResponsePlan(tuple(setups))


def _shooting_factory(plan: FrequencyResponsePlan):
    """``make(header) -> ShootingProblem``: a resumed shooting branch's problem from its checkpoint record."""
    hb = plan.first.hb

    def make(header: dict):
        return stored_shooting_problem(hb, header)

    return make


def _wants_tori(scene) -> bool:
    """Whether any start of the scene switches at Neimark-Sacker points or starts on a torus (then the torus
    columns are written)."""
    return any("ns" in (s.get("switch") or ()) or s.get("solution") == "torus"
               for s in [scene.analysis, *(scene.analysis.get("starts") or ())])


def plot_measures(scene, model, hb) -> list[str]:
    """The columns ``output.measure`` can name: the row measures and stability's."""
    torus = torus_measure_names(model.dof_names, getattr(model, "whirl_parts", None) or {}) if _wants_tori(scene) \
        else []
    return row_measures(model.dof_names, scene.output["harmonic_columns"], hb.H, model) + torus + [
        "max_multiplier", "n_unstable"]


def _run(plan: FrequencyResponsePlan, ctx) -> Outcome:
    """Run a ``frequency_response`` scene from its plan; returns its outcome.

    The branches of the main start come first, then those of each entry of
    ``analysis.starts`` (further starts, e.g. a subharmonic branch found by
    a time simulation beside the harmonic one), all in one diagram.
    """
    scene, model = ctx.scene, ctx.model
    lo, hi = plan.first.sweep.lo, plan.first.sweep.hi
    hb = plan.first.hb
    previous = _restore(ctx.outdir, hb.parameter) if ctx.resume else {}
    try:
        rec = BranchRecorder(ctx.sink, model.dof_names, hb.parameter, scene.output["harmonic_columns"], hb.H,
                             append=bool(previous), model=model, torus=_wants_tori(scene))
    except ValueError as exc:  # the files to continue have other columns
        raise SceneError("--resume", "result files of this scene", str(exc),
                         hint="; run again without --resume, or use another -o") from None
    rec.expansion.full = hb
    rec.shooting_problem = _shooting_factory(plan)
    if previous:
        rec.restore(previous)
    ctx.recorder = rec
    results = []
    t0 = time.perf_counter()
    try:
        for setup in plan.starts:
            sc, hb_i, problem, lam0, opts = setup.scene, setup.hb, setup.problem, setup.sweep.start, setup.options
            a = sc.analysis
            if a["solution"] == "torus":  # the circle and its anchor from the simulation (again on resume)
                try:
                    problem, u0 = circle_from_simulation(problem, a, lam0, hb_i.H)
                except (SimulationError, ArithmeticError, ValueError) as exc:
                    raise RunError(f"no starting torus at {hb_i.parameter}={lam0:g}: {exc}") from None
            elif len(results) in previous:  # taken up from the checkpoint: no start to compute
                u0 = np.asarray(previous[len(results)].unknowns[0])
            elif is_shooting(problem):
                u_hb = None if a["start_from"] == "simulation" else start_guess(sc, model, hb_i, lam0)
                try:
                    u0 = shooting_start(problem, hb_i, a, lam0, u_hb)
                except (SimulationError, ArithmeticError) as exc:
                    raise RunError(f"no starting orbit at {hb_i.parameter}={lam0:g}: {exc}") from None
            else:
                u0 = np.array(a["guess"], dtype=float) if a["guess"] is not None else start_guess(sc, model, hb_i,
                                                                                                   lam0, problem, opts)
                if problem is not hb_i:  # the starts are full coefficients
                    u0 = problem.restrict(u0)
            first = len(results)
            # an auto start's two directions, each handed over at its grazing point, side by side; a start taken
            # up from a checkpoint runs one after the other
            both = None if setup.method != "auto" or a["solution"] == "torus" or any(j >= first for j in previous) \
                else follow_and_hand_over(setup, problem, u0, lam0, (lo, hi), rec, ctx, first)
            if both is not None:
                results += both
            else:
                results += setup.follow(problem, u0, lam0, (lo, hi), opts, rec, ctx, previous, first_id=first)
                if setup.method == "auto":  # branches that harmonic balance could not take past a grazing point
                    results = hand_over(results, first, setup, rec, ctx, previous, (lo, hi))
            # shooting branches that crawled, continued with their orbits cut at another section
            results = recut(results, first, setup, rec, ctx, previous, (lo, hi))
            if len(results) > first and results[first][0].status == BranchStatus.START_FAILED:
                results[first][0].message += start_advice(sc, hb_i, lam0)
            if ctx.stop_requested or any(b.status == BranchStatus.INTERRUPTED for b, _ in results):
                break
    finally:
        rec.close()
    branches_info = []
    for bid, (branch, meta) in enumerate(results):
        branches_info.append({
            "branch": bid, "nu": meta.get("nu", hb.nu), "points": len(branch), "status": branch.status.value,
            "message": branch.message, "parent": meta.get("parent"), "origin": meta.get("origin"),
            "special_points": {k: sum(1 for s in branch.special_points if s.kind.value == k)
                               for k in ("fold", "bp", "pd", "ns", "kink", "stability", "locking")},
            "min_rcond": branch.info.get("min_rcond"),
            "condition": _condition_summary(branch),
            "rejected_steps": branch.info.get("n_rejected_steps"),
            "newton": {"iterations": branch.info.get("n_newton_iterations"),
                       "retried_with_step_halving": branch.info.get("n_backtracked", 0)},
            "rescalings": [list(r) for r in branch.info.get("rescalings", [])],
            "stability": _stability_summary(branch),
            "uncovered": _interval_or_none(branch.info.get("uncovered")) or boundary_gap(branch, (lo, hi)),
            "torus": meta.get("torus"),
            "method": meta.get("method", "hb"),
            **({k: meta[k] for k in ("handed_over_to", "handed_over_from", "handover_failed", "recut_to", "recut_from",
                                     "end") if k in meta}),
            **({"returned": branch.info["returned"]} if "returned" in branch.info else {}),
        })
    ctx.timings["continuation"] = time.perf_counter() - t0
    interrupted = any(b.status == BranchStatus.INTERRUPTED for b, _ in results)
    ctx.interrupted = ctx.interrupted or interrupted
    # a grazing end is an end as asked only where the orbit itself grazes and goes no further
    t_ends = time.perf_counter()
    checked = {j: p for j, p in rec.problems.items()
               if j < len(results) and "handed_over_to" not in results[j][1] and "recut_to" not in results[j][1]}
    end_shortfalls = [] if ctx.interrupted or ctx.stop_requested else branch_end_checks(
        results, checked, branches_info, (lo, hi), max(s.options.newton_tol for s in plan.starts), hb.parameter)
    ctx.timings["end_checks"] = time.perf_counter() - t_ends
    part = {
        "parameter": hb.parameter,
        "unknowns": hb.size,
        "condensation": condensation_summary(hb, plan.first.problem),
        "harmonics": hb.H,
        "subharmonic": hb.nu,
        "samples": hb.N,
        "starts": len(plan.starts),
        "branches": branches_info,
        "rows": rec.n_rows,
        "special_points": len(rec.special_list),
        "failed_switches": rec.failed_switches,
        "shortfalls": shortfalls(branches_info, hb.parameter, rec.failed_switches) + end_shortfalls,
    }

    def draw() -> list[str]:
        return draw_response(ctx, rec, hb) + model_figures(ctx.model, "frequency_response", hb.parameter, rec.curves,
                                                   rec.special_list, ctx.outdir, ctx.scene.output)

    return Analysis.outcome(ctx, part, shortfalls=part["shortfalls"], data=rec.run_data(ctx.summary), draw=draw)


class FrequencyResponse(Analysis):
    """``frequency_response``: periodic solutions against a parameter (this module's docstring)."""

    name = "frequency_response"
    summary = ("Periodic solutions against a parameter, harmonic or subharmonic, with stability, special points "
               "and branch switching.")
    required = "range; often parameter, harmonics, stability, switch"
    schema = SCHEMA

    def validate(self, data: dict, model: dict, analysis: dict, lines: dict) -> None:
        """The further starts' keys (:data:`START_KEYS`) and the values of the continued parameter."""
        start_schema = {k: SCHEMA[k] for k in START_KEYS}
        for i, extra in enumerate(analysis["starts"]):
            check_section(extra, start_schema, f"analysis.starts[{i}]", lines)
        name = parameter_name(model, analysis)
        items = [("analysis.range", analysis["range"]), ("analysis.start", analysis["start"])]
        items += [(f"analysis.starts[{i}].start", extra.get("start")) for i, extra in enumerate(analysis["starts"])]
        check_parameter_values(model, analysis, name, [(k, v) for k, v in items if v is not None], lines)

    def demands(self, scene, model) -> list:
        return frequency_response_demands(scene, model)

    def plan(self, scene, model) -> FrequencyResponsePlan:
        return _plan(scene, model)

    def compile_ahead(self, plan) -> list:
        """The shooting problems of the starts that are not harmonic balance alone (``auto`` hands over late)."""
        return [(shooting_problem(s.hb, s.shooting), s.sweep.start) for s in plan.starts if s.method != "hb"]

    def run(self, plan: FrequencyResponsePlan, ctx) -> Outcome:
        return _run(plan, ctx)

    def describe(self, plan: FrequencyResponsePlan, scene, model) -> list[str]:
        a, hb, problem = scene.analysis, plan.first.hb, plan.first.problem
        lines = [f"  parameter {hb.parameter} over {a['range']}, harmonics H={hb.H}, subharmonic nu={hb.nu}, "
                 f"samples N={hb.N}", f"  unknowns: {hb.size} = {hb.n} dof x (2H+1)"]
        if is_shooting(problem):  # its unknowns are the states at the segment starts
            lines[1] = f"  unknowns: {problem.size} = {hb.n} dof x 2 (x, x') x {plan.first.shooting.segments} segment(s)"
        elif problem is not hb:
            lines.append(f"  {problem.describe()}")
        lines.append(f"  stability: {a['stability']}; switching at: {', '.join(a['switch']) or 'none'}")
        sh = plan.first.shooting
        if plan.first.method != "hb":  # harmonic balance alone: as before, nothing to add
            lines.append({"shooting": f"  method: shooting ({sh.segments} segment(s), {sh.steps_per_period} RK4 "
                                      "steps a forcing period)",
                          "auto": f"  method: harmonic balance, handed to shooting ({sh.segments} segment(s), "
                                  f"{sh.steps_per_period} steps a period) at a grazing point it cannot pass"}
                         [plan.first.method])
        t = TorusSettings.from_dict(a.get("torus") or {}, hb.H)
        circles = [s for s in plan.starts if s.method != "hb" and ("ns" in s.scene.analysis["switch"]
                                                                   or s.scene.analysis["solution"] == "torus")]
        if circles:  # the first start with tori says how they are made
            c = circles[0].scene.analysis
            t = TorusSettings.from_dict(c.get("torus") or {}, hb.H)
            fitted = sum(s.scene.analysis["solution"] == "torus" for s in plan.starts)
            lines.append(f"  tori: invariant circles of {t.points} points ({circles[0].shooting.steps_per_period} "
                         "steps a period); "
                         + ("stability by their Lyapunov exponents" if t.stability != "none" else "no stability")
                         + (f"; in natural steps of {hb.parameter}" if t.continuation.value == "natural" else "")
                         + ("; the first fitted to a simulation" if a["solution"] == "torus" else "")
                         + (f"; {fitted} fitted to simulations" if fitted and a["solution"] != "torus" else ""))
        elif "ns" in a["switch"]:
            o = t.options
            lines.append(f"  tori: H1={o.harmonics}, H2={o.harmonics2}, crossings {o.crossings}; stability "
                         + (f"by simulation ({t.periods:g} periods, {t.steps_per_period} steps each)"
                            if t.stability == "simulation" else "none"))
        return lines

    def scale_checks(self, plan: FrequencyResponsePlan) -> list[ScaleCheck]:
        out = []
        for s in plan.starts:
            switch = [k for k in s.scene.analysis.get("switch") or () if k in ("pd", "ns")]
            n = getattr(s.problem, "n", s.hb.n)
            what = f"{dofs_text(n)} x {2 * s.hb.H + 1} coefficients" + (" (condensed)" if s.problem is not s.hb else "")
            if is_shooting(s.problem):
                what = f"{dofs_text(n)} x 2 states x {s.shooting.segments} segment(s)"
            out.append(ScaleCheck(s.scale_key, s.options, s.problem.size, what,
                                  f"analysis.switch: [{', '.join(switch)}]" if switch else ""))
        return out
