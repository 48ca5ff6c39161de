"""``frequency_response``: periodic solutions of a forced model versus a parameter.

Traces the branch of order ``nu`` from the start of ``range`` with
pseudo-arclength continuation, with stability where requested, switches at
the requested bifurcations, and streams ``branches.csv`` and
``special_points.csv`` as points are found.

With ``analysis.condense`` (``auto``, ``true``, ``false``) the engine follows
the problem condensed onto the dofs that carry nonlinear forces
(:mod:`contin.hb.condensation`); everything written stays full: the measures,
the special points, and the coefficients ``u`` in ``state.jsonl`` (whose
tangents are the engine's, in the kept dofs' coefficients, listed as
``dofs`` in each branch record).
"""

from __future__ import annotations

import dataclasses
import inspect
import json
import time

import numpy as np

from contin.scene.registry import register_analysis, shortfalls
from contin.engine.branch import BranchStatus
from contin.engine.continuation import ContinuationOptions
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.output.checkpoint import encode, special_record
from contin.hb.condensation import condensation_dofs, condense
from contin.hb.measures import measure_names, point_measures
from contin.output.checkpoint import read_records, rebuild_branches, resumable_prefix
from contin.output.dense import as_number, checkpoint_solutions
from contin.output.results import CsvStream, read_csv, truncate_to_valid_rows
from contin.output.model_figures import model_figures
from contin.scene.parse import SceneError, model_frequency

__all__ = ["run", "BranchRecorder", "build_problem", "engine_problem"]

SPECIAL_EXTRA = ["interval_lo", "interval_hi", "located", "detail"]
#: what a finished branch's ``info`` keeps in its checkpoint (what the summary reports of it)
_END_INFO = ("unknown_scale", "parameter_scale", "lam_range", "min_rcond", "min_rcond_index", "max_condition",
             "max_condition_parameter", "last_condition", "n_rejected_steps", "n_newton_iterations", "n_backtracked",
             "rescalings", "n_linearizations", "last_failure", "uncovered")


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


class BranchRecorder:
    """Streams the rows of ``branches.csv`` and ``special_points.csv``.

    Parameters
    ----------
    outdir : Path
    dof_names : sequence of str
    parameter : str
    harmonic_columns, H : int
        Number of ``hK`` columns is ``min(H, harmonic_columns) + 1``.
    """

    def __init__(self, outdir, dof_names, parameter, harmonic_columns, H, append=False, model=None):
        self.failed_switches: list = []  # sides of a switch with no first point
        self.dof_names = list(dof_names)
        self.parameter = parameter
        self.harmonic_columns = harmonic_columns
        self.observables = getattr(model, "observables", None)
        self.measures = row_measures(self.dof_names, harmonic_columns, H, model)
        head = ["branch", "nu", parameter, "stable", "n_unstable", "max_multiplier"]
        self.branch_columns = head + self.measures + ["newton_iterations", "residual_norm"]
        self.special_columns = ["branch", "kind", parameter, "index"] + self.measures + SPECIAL_EXTRA
        self.rows = CsvStream(outdir / "branches.csv", self.branch_columns, append)
        self.special = CsvStream(outdir / "special_points.csv", self.special_columns, append)
        # full solutions (coefficients and tangent) for plots of any row and for --resume
        self.state = open(outdir / "state.jsonl", "a" if append else "w")
        self.n_rows = self.rows.rows
        self._written_special: dict[int, int] = {}
        self._headers: set = set()
        self.offsets: dict[int, int] = {}  # branch id -> its first row (of this run or a resumed one)
        self._engine_offsets: dict[int, int] = {}  # branch id -> row of the engine's index 0 in this run
        self.curves: dict[int, dict] = {}
        self.special_list: list[dict] = []
        self.problems: dict = {}  # branch id -> its problem, to expand condensed unknowns

    def _full(self, branch_id: int, u, lam: float, problem=None):
        """Full coefficients of the engine's ``u`` (expanded when the branch's problem is condensed)."""
        problem = self.problems.get(branch_id) if problem is None else problem
        if problem is None or not hasattr(problem, "expand"):
            return np.asarray(u)
        return problem.expand(u, lam)

    def _measures(self, u, n, nu):
        out = point_measures(u, n, self.dof_names, self.harmonic_columns)
        if self.observables is not None:
            out.update(self.observables(u, n, nu))
        return out

    def point(self, branch_id: int, nu: int, branch, i: int, H: int | None = None, problem=None) -> None:
        self.offsets.setdefault(branch_id, self.n_rows - i)
        self._engine_offsets.setdefault(branch_id, self.n_rows - i)
        if problem is not None:
            self.problems[branch_id] = problem
        lam = float(branch.parameter[i])
        u = self._full(branch_id, branch.unknowns[i], lam)
        row = {"branch": branch_id, "nu": nu, self.parameter: lam}
        pd = branch.point_data
        if "stable" in pd and bool(pd["evaluated"][i] if "evaluated" in pd else True):
            row["stable"] = bool(pd["stable"][i])
            row["n_unstable"] = int(pd["n_unstable"][i])
            row["max_multiplier"] = float(pd["max_multiplier"][i])
        elif "stable" in pd:  # no verdict at this point: empty cells, not the monitor's placeholders
            row.update(stable=None, n_unstable=None, max_multiplier=None)
        row.update(self._measures(u, len(self.dof_names), nu))
        row["newton_iterations"] = int(branch.newton_iterations[i])
        row["residual_norm"] = float(branch.residual_norms[i])
        self.rows.write(row)
        if branch_id not in self._headers:
            self._headers.add(branch_id)
            su = branch.info.get("unknown_scale")
            kept = getattr(self.problems.get(branch_id), "dofs", None)
            self.state.write(json.dumps(encode({"type": "branch", "branch": branch_id, "nu": nu, "H": H,
                                                "unknown_scale": None if su is None else np.asarray(su),
                                                "parameter_scale": branch.info.get("parameter_scale"),
                                                "dofs": None if kept is None else [int(d) for d in kept]})) + "\n")
        self.state.write(json.dumps({
            "type": "point", "row": self.n_rows, "branch": branch_id, "nu": nu, "H": H, "lam": lam, "u": u.tolist(),
            "tangent": branch.tangents[i].tolist(), "s": float(branch.arclength[i]),
            "step": float(branch.step_sizes[i]), "iterations": int(branch.newton_iterations[i]),
            "residual": float(branch.residual_norms[i]),
            "data": encode({k: v[i] for k, v in pd.items()})}) + "\n")
        self.state.flush()
        self.n_rows += 1
        self.special_points(branch_id, branch)
        c = self.curves.setdefault(branch_id, {"x": [], "rows": [], "stable": [], "nu": nu})
        c["x"].append(lam)
        c["rows"].append(row)
        c["stable"].append(row.get("stable"))
        kept = getattr(self.problems.get(branch_id), "dofs", None)
        self._keep_solution(c, u, branch.tangents[i], branch.info.get("unknown_scale"),
                            branch.info.get("parameter_scale"), kept, H)

    def _keep_solution(self, c: dict, u, tangent, su, sl, kept, H) -> None:
        """Keep a point's full coefficients ``u`` and its tangent in the unknowns' units (for the dense curves).

        ``tangent`` (m+1,) is the engine's, scaled by ``su`` (m,) and ``sl``, over the coefficients of
        the ``kept`` dofs (all when None); ``c`` gets ``u``, ``direction``, ``scale``, ``kept`` and ``H``.
        """
        c.setdefault("u", []).append(np.asarray(u, dtype=float))
        t = np.asarray(tangent, dtype=float)
        direction = None
        if su is not None and sl is not None and t.size >= 2:
            scale = np.append(np.broadcast_to(np.asarray(su, dtype=float), (t.size - 1,)), float(sl))
            direction = t * scale
            c["scale"] = scale
        c.setdefault("direction", []).append(direction)
        c["kept"] = None if kept is None else [int(d) for d in kept]
        c["H"] = H

    def special_points(self, branch_id: int, branch, problem=None) -> None:
        if problem is not None:
            self.problems[branch_id] = problem
        off = self._engine_offsets.get(branch_id, self.offsets.get(branch_id, self.n_rows - len(branch)))
        done = self._written_special.get(branch_id, 0)
        self._written_special[branch_id] = len(branch.special_points)
        for sp in branch.special_points[done:]:
            if sp.kind.value == "start" or self._duplicate(branch_id, sp):
                # kept in the checkpoint all the same: a resumed branch holds every special point
                self.state.write(json.dumps(special_record(branch_id, self._full_point(branch_id, sp), csv=False)) + "\n")
                continue
            i = min(max(sp.index, 0), len(branch) - 1)
            if i + 1 < len(branch) and abs(branch.parameter[i + 1] - sp.parameter) < abs(branch.parameter[i] - sp.parameter):
                i += 1
            row = {"branch": branch_id, "kind": sp.kind.value, self.parameter: float(sp.parameter), "index": off + i}
            sp = self._full_point(branch_id, sp)
            row.update(self._measures(sp.unknowns, len(self.dof_names), self.curves.get(branch_id, {}).get("nu", 1)))
            lo, hi = sp.bracket
            row.update({"interval_lo": float(lo), "interval_hi": float(hi), "located": bool(sp.located),
                        "detail": _detail(sp)})
            self.special.write(row)
            self.special_list.append(dict(row, _before=off + min(max(sp.index, 0), len(branch) - 1)))
            self.state.write(json.dumps(special_record(branch_id, sp)) + "\n")
            self.state.flush()

    def _full_point(self, branch_id: int, sp):
        """``sp`` with full coefficients (expanded when the branch's problem is condensed)."""
        u_full = self._full(branch_id, sp.unknowns, float(sp.parameter))
        return sp if u_full is sp.unknowns else dataclasses.replace(sp, unknowns=u_full)

    def checkpoint(self, branch_id: int, branch, state: dict) -> None:
        """The engine's state after a step (or its monitors' at the branch's end): see :mod:`contin.output.checkpoint`."""
        self.special_points(branch_id, branch)  # the state holds them: write them first
        if "points" in state:
            rec = {"type": "engine", "branch": branch_id, "state": encode(state)}
        else:
            info = {k: v for k, v in branch.info.items() if k in _END_INFO}
            rec = {"type": "end", "branch": branch_id, "status": branch.status.value, "message": branch.message,
                   "info": encode(info), "monitors": encode(state.get("monitors") or [])}
        self.state.write(json.dumps(rec) + "\n")
        self.state.flush()

    def restore(self, previous: dict) -> None:
        """Take up the rows and special points of an interrupted run (``--resume``)."""
        rows = read_csv(self.rows.path)
        self.n_rows = len(rows.get("branch", []))  # the rows of this run continue the numbering
        solutions = checkpoint_solutions(read_records(self.state.name))
        for r in range(len(rows.get("branch", []))):
            bid = int(rows["branch"][r])
            self.offsets.setdefault(bid, r)
            row = {c: rows[c][r] for c in self.branch_columns if c in rows}
            st = _flag(rows["stable"][r]) if "stable" in rows else None
            c = self.curves.setdefault(bid, {"x": [], "rows": [], "stable": [], "nu": int(rows["nu"][r])})
            c["x"].append(float(rows[self.parameter][r]))
            c["rows"].append(row)
            c["stable"].append(st)
            if r in solutions:
                self._keep_solution(c, *solutions[r])
        sp = read_csv(self.special.path)
        for r in range(len(sp.get("branch", []))):
            row = {c: sp[c][r] for c in self.special_columns if c in sp}
            row["branch"], row["index"] = int(row["branch"]), int(row["index"])
            self.special_list.append(dict(row, _before=row["index"]))
        self._headers = set(previous)
        self._engine_offsets = dict(self.offsets)  # a resumed branch holds its points from the first
        self._written_special = {j: len(b.special_points) for j, b in previous.items()}

    def _duplicate(self, branch_id, sp) -> bool:
        """The same bifurcation found by two tests (the bordered determinant and a multiplier at +1)."""
        tol = 1e-6 * max(1.0, abs(sp.parameter))
        return any(r["branch"] == branch_id and r["kind"] == sp.kind.value
                   and abs(r[self.parameter] - sp.parameter) <= tol for r in self.special_list)

    def close(self) -> None:
        self.rows.close()
        self.special.close()
        self.state.close()


def _start(scene, model, hb, lam0: float):
    """The start guess: ``analysis.start_from`` = model (its own start, else linear), linear or simulation."""
    from contin.scene.registry import RunError
    from contin.timedomain.simulation import SimulationError
    from contin.bifurcation.start import HomotopyFailed, simulation_start

    how = scene.analysis["start_from"]
    try:
        if how == "simulation":  # its keys are checked by the scene schema, its step by check()
            return simulation_start(hb, lam0, **scene.analysis["start_simulation"])
        if how == "model" and model.start is not None:
            return model.start(hb, lam0)
    except (HomotopyFailed, SimulationError) as exc:
        raise RunError(f"no starting solution at {hb.parameter}={lam0:g}: {exc}") from None
    return hb.linear_solution(lam0)


def _restore(outdir, parameter: str) -> dict:
    """Branches of an interrupted run in ``outdir``, its files cut back to the last point it can go on from."""
    n_rows = truncate_to_valid_rows(outdir / "branches.csv")
    records, rows, special_rows = resumable_prefix(read_records(outdir / "state.jsonl"), n_rows)
    truncate_to_valid_rows(outdir / "branches.csv", rows)
    truncate_to_valid_rows(outdir / "special_points.csv", special_rows)
    # rewrite the checkpoint without what the cut dropped
    with open(outdir / "state.jsonl", "w") as fh:
        for r in records:
            fh.write(json.dumps(r) + "\n")
    return rebuild_branches(records, parameter)


def _detail(sp) -> str:
    d = sp.data or {}
    parts = []
    if "multiplier" in d:
        z = complex(d["multiplier"])
        parts.append(f"multiplier {z.real:.6g}{z.imag:+.6g}j")
    if sp.message:
        parts.append(sp.message)
    return "; ".join(parts)


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


def row_measures(dof_names, harmonic_columns: int, H: int, model=None) -> list[str]:
    """The measure columns of a row of ``branches.csv``: those of every dof, then the model's own."""
    own = list(getattr(model, "observable_names", ()) if getattr(model, "observables", None) else ())
    return measure_names(list(dof_names), harmonic_columns, H) + own


def plot_measures(scene, model, hb) -> list[str]:
    """The columns ``output.measure`` can name: the row measures and stability's."""
    return row_measures(model.dof_names, scene.output["harmonic_columns"], hb.H, model) + ["max_multiplier",
                                                                                            "n_unstable"]


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
                             append=bool(previous), model=model)
    except ValueError as exc:  # the files to continue have other columns
        raise SceneError("--resume", "result files of this scene", str(exc),
                         hint="; run again without --resume, or use another -o") from None
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
                u0 = np.array(a["guess"], dtype=float) if a["guess"] is not None else _start(sc, model, hb_i, lam0)
                if problem is not hb_i:  # the starts are full coefficients
                    u0 = problem.restrict(u0)
            results += follow(problem, u0, lam0, (lo, hi), opts, rec, ctx, previous, first_id=len(results))
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
                               for k in ("fold", "bp", "pd", "ns", "kink", "stability")},
            "min_rcond": branch.info.get("min_rcond"),
            "condition": _condition_summary(branch),
            "rejected_steps": branch.info.get("n_rejected_steps"),
            "newton": {"iterations": branch.info.get("n_newton_iterations"),
                       "retried_with_step_halving": branch.info.get("n_backtracked", 0)},
            "rescalings": [list(r) for r in branch.info.get("rescalings", [])],
            "stability": _stability_summary(branch),
            "uncovered": _interval_or_none(branch.info.get("uncovered")),
        })
    ctx.timings["continuation"] = time.perf_counter() - t0
    interrupted = any(b.status == BranchStatus.INTERRUPTED for b, _ in results)
    ctx.interrupted = ctx.interrupted or interrupted
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
        "shortfalls": shortfalls(branches_info, hb.parameter, rec.failed_switches),
    }


def _flag(value) -> bool | None:
    """A ``stable`` cell read back: True, False, or None where it is empty (no verdict)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    return {"true": True, "false": False}.get(value)


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
    st = branch.info.get("stability")
    if not st:
        return None
    out = {"method": st.get("method"),
           "hill_monodromy_gap": st.get("largest_hill_monodromy_gap"),
           "fallbacks": len(st.get("fallbacks", [])),
           "disagreements": len(st.get("disagreements", [])),
           "unevaluated": len(st.get("unevaluated", []))}
    if st.get("unevaluated"):
        lam, why = st["unevaluated"][0]
        out["unevaluated_message"] = (f"no stability verdict at {len(st['unevaluated'])} points (first at "
                                      f"{lam:.10g}: {why}); their rows have empty stability cells")
    where = sorted(st.get("fallbacks", []) + st.get("disagreements", []))
    if where:
        out["first_fallback_at"] = where[0]
        out["message"] = (f"Hill and the monodromy disagreed at {len(where)} points (first at {where[0]:.10g}): "
                          "the monodromy's multipliers were used there")
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
            special.append({"x": float(s[rec.parameter]), "y": sy, "kind": s["kind"], "branch": bid})
        evaluate, U, directions = None, np.zeros((x.size, 0)), None
        if measure in rec.measures and len(c.get("u", ())) == x.size and x.size > 1:  # a function of u
            evaluate, U = _evaluator(rec, measure, c["nu"]), np.array(c["u"])
            if all(d is not None for d in c["direction"]):
                directions = np.array(c["direction"])
        kept = kept_indices(c.get("kept"), n, c.get("H") or 0) if c.get("kept") is not None else None
        d = dense_branch(x, U, evaluate, directions=directions, kept=kept, scale=c.get("scale"), stable=stable,
                         special=points, node_xy=(x, y))
        # both halves of a branch followed both ways start at one point
        group = ("start", c["nu"], float(f"{x[0]:.10g}"), float(f"{y[0]:.8g}")) if x.size else ("branch", bid)
        branches.append({"x": d["x"], "y": d["y"], "stable": d["stable"], "nu": c["nu"], "id": bid, "group": group})
    return branches, special


def _evaluator(rec: BranchRecorder, measure: str, nu: int):
    """``evaluate(lam (K,), U (K, M)) -> (lam, measure (K,))`` with the function of the CSV columns."""
    n = len(rec.dof_names)

    def evaluate(lam, U):
        return lam, np.array([as_number(rec._measures(u, n, nu).get(measure)) for u in U])

    return evaluate
