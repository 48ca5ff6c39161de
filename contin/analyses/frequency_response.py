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

import numpy as np

from contin.scene.registry import register_analysis, shortfalls
from contin.engine.branch import BranchStatus
from contin.engine.continuation import ContinuationOptions
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.condensation import condensation_dofs, condense
# the recorder's names are part of this analysis' interface (bifurcation_curve, convergence_plan use them)
from contin.analyses.branch_recorder import SPECIAL_EXTRA, BranchRecorder, row_measures  # noqa: F401
from contin.hb.torus import torus_measure_names
from contin.output.checkpoint import keep_records, read_records, rebuild_branches, resumable_prefix
from contin.output.dense import as_number
from contin.output.results import truncate_to_valid_rows
from contin.output.model_figures import model_figures
from contin.scene.parse import SceneError, model_frequency

__all__ = ["run", "BranchRecorder", "build_problem", "engine_problem"]




def build_problem(scene, model) -> HarmonicBalance:
    """The harmonic-balance problem of a ``frequency_response`` scene.

    Its frequency is the scene's (:func:`contin.scene.parse.model_frequency`),
    handed to the problem; the model is not changed.
    """
    a = scene.analysis
    freq = model_frequency(scene.model, a)
    if freq not in model.parameters:
        raise scene.error("analysis.frequency", f"a parameter of the model {list(model.parameters)}", freq)
    param = a["parameter"] or freq
    if param not in model.parameters:
        raise scene.error("analysis.parameter", f"a parameter of the model {list(model.parameters)}", param)
    try:
        opts = HBOptions(harmonics=a["harmonics"], subharmonic=a["subharmonic"], samples=a["samples"],
                         crossings=a["crossings"])
        return HarmonicBalance(model, param, opts, frequency=freq)
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


def _start(scene, model, hb, lam0: float, problem=None, options=None):
    """The start guess: ``analysis.start_from`` = model (its own start, else linear), linear or simulation.

    From the linear solution, Newton is tried at once on ``problem`` (the
    engine's, ``hb`` by default); where it fails with many harmonics, the start
    is solved with few and raised to ``hb.H``
    (:func:`contin.bifurcation.start.harmonic_start`). If that fails too, the
    linear solution is returned: the engine's start then fails with its own
    message, and :func:`start_advice` says what to try.
    """
    from contin.scene.registry import RunError
    from contin.timedomain.simulation import SimulationError
    from contin.bifurcation.start import HomotopyFailed, harmonic_start, simulation_start
    from contin.engine.newton import NUMERICAL_ERRORS

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
    from contin.bifurcation.start import START_LOW_HARMONICS

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


def _starts(scene):
    """The scene itself, then one scene per entry of ``analysis.starts`` (its keys override)."""
    from contin.scene.parse import Scene

    yield "analysis", scene
    for i, extra in enumerate(scene.analysis["starts"]):
        key = f"analysis.starts[{i}]"
        merged = dict(scene.analysis)  # the entry was checked with the scene (START_KEYS)
        merged.update(extra)
        merged["starts"] = []
        yield key, Scene({**scene.data, "analysis": merged}, scene.source, scene.lines)


def check(scene, model) -> list:
    """Every check of a ``frequency_response`` scene with its model; returns the setup of each start.

    Returns
    -------
    list of tuple
        ``(scene, hb, problem, lam0, options, follow)`` per start (the
        scene, then each entry of ``analysis.starts``).
    """
    from contin.scene.registry import check_output
    from contin.analyses.stability_hooks import stability_setup

    lam_a, lam_b = float(scene.analysis["range"][0]), float(scene.analysis["range"][1])
    lo, hi = min(lam_a, lam_b), max(lam_a, lam_b)
    setups = []
    for key, sc in _starts(scene):
        a = sc.analysis
        hb = build_problem(sc, model)
        lam0 = float(a["start"]) if a["start"] is not None else lam_a
        if not lo <= lam0 <= hi:
            raise scene.error(f"{key}.start", f"a value inside range [{lo:g}, {hi:g}]", lam0)
        opts = continuation_options(sc, lam0, lam_b if lam0 != lam_b else lam_a)
        if a["guess"] is not None and len(a["guess"]) != hb.size:
            raise scene.error(f"{key}.guess", f"{hb.size} numbers (n*(2H+1) coefficients)", f"{len(a['guess'])} numbers")
        problem = engine_problem(sc, hb)
        if a["start_from"] == "simulation" and a["guess"] is None:
            from contin.analyses.simulate import check_time_step
            from contin.bifurcation.start import simulation_start

            default = inspect.signature(simulation_start).parameters["steps_per_period"].default
            check_time_step(model, {hb.parameter: lam0}, a["start_simulation"].get("steps_per_period", default),
                            f"{key}.start_simulation.steps_per_period", scene.lines, f"{key}.start", hb.frequency)
        setups.append((sc, hb, problem, lam0, opts, stability_setup(a, problem)))
    hb = setups[0][1]
    check_output(scene, plot_measures(scene, model, hb), list(model.parameters))
    return setups


def _wants_tori(scene) -> bool:
    """Whether any start of the scene switches at Neimark-Sacker points (then the torus columns are written)."""
    return any("ns" in (s.get("switch") or ()) for s in [scene.analysis, *(scene.analysis.get("starts") or ())])


def plot_measures(scene, model, hb) -> list[str]:
    """The columns ``output.measure`` can name: the row measures and stability's."""
    torus = torus_measure_names(model.dof_names) if _wants_tori(scene) else []
    return row_measures(model.dof_names, scene.output["harmonic_columns"], hb.H, model) + torus + [
        "max_multiplier", "n_unstable"]


@register_analysis("frequency_response", check=check)
def run(ctx) -> dict:
    """Run a ``frequency_response`` scene; returns its part of ``summary.json``.

    The branches of the main start come first, then those of each entry of
    ``analysis.starts`` (further starts, e.g. a subharmonic branch found by
    a time simulation beside the harmonic one), all in one diagram.
    """
    scene, model = ctx.scene, ctx.model
    lam_a, lam_b = float(scene.analysis["range"][0]), float(scene.analysis["range"][1])
    lo, hi = min(lam_a, lam_b), max(lam_a, lam_b)
    setups = ctx.plan  # check(), made before anything was written
    hb = setups[0][1]
    previous = _restore(ctx.outdir, hb.parameter) if ctx.resume else {}
    try:
        rec = BranchRecorder(ctx.outdir, model.dof_names, hb.parameter, scene.output["harmonic_columns"], hb.H,
                             append=bool(previous), model=model, torus=_wants_tori(scene))
    except ValueError as exc:  # the files to continue have other columns
        raise SceneError("--resume", "result files of this scene", str(exc),
                         hint="; run again without --resume, or use another -o") from None
    rec.expansion.full = hb
    if previous:
        rec.restore(previous)
    ctx.recorder = rec
    results = []
    t0 = time.perf_counter()
    try:
        for sc, hb_i, problem, lam0, opts, follow in setups:
            a = sc.analysis
            if len(results) in previous:  # taken up from the checkpoint: no start to compute
                u0 = np.asarray(previous[len(results)].unknowns[0])
            else:
                u0 = np.array(a["guess"], dtype=float) if a["guess"] is not None else _start(sc, model, hb_i, lam0,
                                                                                               problem, opts)
                if problem is not hb_i:  # the starts are full coefficients
                    u0 = problem.restrict(u0)
            first = len(results)
            results += follow(problem, u0, lam0, (lo, hi), opts, rec, ctx, previous, first_id=first)
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
            "uncovered": _interval_or_none(branch.info.get("uncovered")),
            "torus": meta.get("torus"),
        })
    ctx.timings["continuation"] = time.perf_counter() - t0
    interrupted = any(b.status == BranchStatus.INTERRUPTED for b, _ in results)
    ctx.interrupted = ctx.interrupted or interrupted
    # a grazing end is an end as asked only where the orbit itself grazes and goes no further
    from contin.bifurcation.end_check import branch_end_checks

    t_ends = time.perf_counter()
    end_shortfalls = [] if ctx.interrupted or ctx.stop_requested else branch_end_checks(
        results, rec.problems, branches_info, (lo, hi), max(s[4].newton_tol for s in setups), hb.parameter)
    ctx.timings["end_checks"] = time.perf_counter() - t_ends
    ctx.plot = lambda: _plot(ctx, rec, hb) + model_figures(ctx.model, "frequency_response", hb.parameter, rec.curves,
                                                           rec.special_list, ctx.outdir, ctx.scene.output)
    return {
        "parameter": hb.parameter,
        "unknowns": hb.size,
        "condensation": condensation_summary(hb, setups[0][2]),
        "harmonics": hb.H,
        "subharmonic": hb.nu,
        "samples": hb.N,
        "starts": len(setups),
        "branches": branches_info,
        "rows": rec.n_rows,
        "special_points": len(rec.special_list),
        "failed_switches": rec.failed_switches,
        "shortfalls": shortfalls(branches_info, hb.parameter, rec.failed_switches) + end_shortfalls,
    }


def _interval_or_none(gap):
    return None if gap is None else [float(gap[0]), float(gap[1])]


def _finite_or_none(v):
    return float(v) if v is not None and np.isfinite(v) else None


def _condition_summary(branch) -> dict:
    """Largest and last condition estimates of the scaled bordered Newton Jacobian (None if singular/absent)."""
    info = branch.info
    return {"max": _finite_or_none(info.get("max_condition")),
            "max_at": _finite_or_none(info.get("max_condition_parameter")),
            "last": _finite_or_none(info.get("last_condition"))}


def _stability_summary(branch) -> dict | None:
    """Where Hill's multipliers were replaced by the monodromy's, and why."""
    from contin.stability.monitor import describe_ranges, replaced_ranges

    st = branch.info.get("stability")
    if not st:
        return None
    out = {"method": st.get("method"),
           "hill_monodromy_gap": st.get("largest_hill_monodromy_gap"),
           # points of the branch (the statistics count every evaluation: rejected steps and locations too)
           "fallbacks": replaced_ranges(branch, "hill_fallback")[0],
           "disagreements": replaced_ranges(branch, "disagreement")[0],
           "unevaluated": len(st.get("unevaluated", []))}
    if st.get("unevaluated"):
        lam, why = st["unevaluated"][0]
        out["unevaluated_message"] = (f"no stability verdict at {len(st['unevaluated'])} points (first at "
                                      f"{lam:.10g}: {why}); their rows have empty stability cells")
    count, ranges = replaced_ranges(branch, ("disagreement", "hill_fallback"))
    if count:
        out["first_fallback_at"] = ranges[0][0]
        out["replaced_points"] = count
        out["replaced_ranges"] = [list(r) for r in ranges]
        out["message"] = (f"Hill and the monodromy disagreed at {count} of the branch's {len(branch)} points "
                          f"({describe_ranges(branch.parameter_name, ranges)}): the monodromy's multipliers were "
                          "used there")
    return out


def _plot(ctx, rec, hb):
    from contin.output.labels import model_symbols
    from contin.output.plotting import bifurcation_diagram

    out = ctx.scene.output
    measure = out["measure"] or f"amp_{hb.model.dof_names[0]}"  # checked by check()
    curves, special = diagram_branches(rec, measure)
    return bifurcation_diagram(curves, special, hb.parameter, measure, ctx.outdir / "bifurcation_diagram",
                               units=out["units"], labels=out["labels"], symbols=model_symbols(hb.model),
                               title=out["title"], formats=out["formats"], dpi=out["dpi"], style=out["style"])


def diagram_branches(rec: BranchRecorder, measure: str) -> tuple[list, list]:
    """The branches and special points of the diagram of ``measure`` (for
    :func:`contin.output.plotting.draw_bifurcation_diagram`).

    Each branch is drawn densely: between its stored points the solutions are
    interpolated (:func:`contin.output.dense.dense_branch`) and ``measure`` is
    evaluated on them as for the CSV columns; a column that is no function of
    the solution (a multiplier) is drawn through the stored points. Each
    special point is put on its branch, and a change of stability is drawn
    at its located parameter. The two halves of a branch followed both ways
    from one start form one group (one colour, one legend entry).

    Returns
    -------
    branches : list of dict
        ``x``, ``y``, ``stable``, ``nu``, ``id``, ``group``.
    special : list of dict
        ``x``, ``y``, ``kind``, ``branch``.
    """
    from contin.output.dense import dense_branch, kept_indices, value_between
    from contin.output.plotting import CHANGES, SPECIAL

    n = len(rec.dof_names)
    branches, special = [], []
    for bid, c in rec.curves.items():
        x = np.asarray(c["x"], dtype=float)
        y = np.array([as_number(r.get(measure)) for r in c["rows"]])
        stable = None if all(v is None for v in c["stable"]) else list(c["stable"])
        off = rec.offsets.get(bid, 0)
        points = []
        for s in rec.special_list:
            if s["branch"] != bid or s["kind"] not in SPECIAL:
                continue
            j = int(s["_before"]) - off
            sy = as_number(s.get(measure))
            if not np.isfinite(sy):  # a multiplier: 1 where the stability changes, else read off the branch
                sy = 1.0 if measure == "max_multiplier" and s["kind"] in CHANGES else \
                    value_between(x, y, j, s[rec.parameter])
            points.append({"x": float(s[rec.parameter]), "y": sy, "index": j, "changes": s["kind"] in CHANGES})
            special.append({"x": float(s[rec.parameter]), "y": sy, "kind": s["kind"], "branch": bid,
                            "located": bool(s.get("located", True))})
        evaluate, U, directions = None, np.zeros((x.size, 0)), None
        if measure in rec.measures and len(c.get("u", ())) == x.size and x.size > 1:  # a function of u
            evaluate, U = _evaluator(rec, measure, c["nu"], rec.problems.get(bid)), np.array(c["u"])
            if all(d is not None for d in c["direction"]):
                directions = np.array(c["direction"])
        kept = kept_indices(c.get("kept"), n, c.get("H") or 0) if c.get("kept") is not None else None
        d = dense_branch(x, U, evaluate, directions=directions, kept=kept, scale=c.get("scale"), stable=stable,
                         special=points, node_xy=(x, y))
        # both halves of a branch followed both ways start at one point
        group = ("start", c["nu"], float(f"{x[0]:.10g}"), float(f"{y[0]:.8g}")) if x.size else ("branch", bid)
        branches.append({"x": d["x"], "y": d["y"], "stable": d["stable"], "nu": c["nu"], "id": bid, "group": group,
                         "torus": bool(c.get("torus"))})
    return branches, special


def _evaluator(rec: BranchRecorder, measure: str, nu: int, problem=None):
    """``evaluate(lam (K,), U (K, M)) -> (lam, measure (K,))`` with the function of the CSV columns."""
    n = len(rec.dof_names)

    def evaluate(lam, U):
        return lam, np.array([as_number(rec._measures(u, n, nu, problem, lv).get(measure)) for u, lv in zip(U, lam)])

    return evaluate
