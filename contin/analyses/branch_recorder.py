"""The rows of ``branches.csv`` and ``special_points.csv`` and the checkpoint, written as branches are traced."""

from __future__ import annotations


import numpy as np

from contin.analyses.shooting_rows import is_shooting, order_of, shooting_row
from contin.hb.measures import measure_names, point_measures
from contin.hb.torus import QuasiPeriodicBalance, torus_measure_names, torus_measures
from contin.model.periodic import is_circle
from contin.output.checkpoint import read_records, special_record
from contin.output.dense import checkpoint_solutions
from contin.output.expansion import ENGINE_UNKNOWNS, StoredExpansion
from contin.output.exports import run_data
from contin.output.outcome import Sink
from contin.output.results import read_csv
from contin.output.state_store import INLINE
from contin.output.state_writer import StateWriter

__all__ = ["BranchRecorder", "SPECIAL_EXTRA", "row_measures"]

SPECIAL_EXTRA = ["interval_lo", "interval_hi", "located", "detail"]
#: what a finished branch's ``info`` keeps in its checkpoint (what the summary reports of it)
_END_INFO = ("unknown_scale", "parameter_scale", "lam_range", "min_rcond", "min_rcond_index", "max_condition",
             "max_condition_parameter", "last_condition", "n_rejected_steps", "n_newton_iterations", "n_backtracked",
             "rescalings", "n_linearizations", "last_failure", "uncovered", "continuation")


def row_measures(dof_names, harmonic_columns: int, H: int, model=None) -> list[str]:
    """The measure columns of a row of ``branches.csv``: those of every dof, then the model's own."""
    own = list(getattr(model, "observable_names", ()) if getattr(model, "observables", None) else ())
    return measure_names(list(dof_names), harmonic_columns, H) + own


class BranchRecorder:
    """Streams the rows of ``branches.csv`` and ``special_points.csv``.

    Parameters
    ----------
    sink : Sink or Path
        Where the tables go (:class:`contin.output.outcome.Sink`; a path: that result directory); the
        checkpoint ``state.jsonl`` only when it writes files. The rows and every point's full coefficients
        are kept in memory too (:meth:`run_data`).
    dof_names : sequence of str
    parameter : str
    harmonic_columns, H : int
        Number of ``hK`` columns is ``min(H, harmonic_columns) + 1``.
    """

    def __init__(self, sink, dof_names, parameter, harmonic_columns, H, append=False, model=None, torus=False):
        sink = sink if isinstance(sink, Sink) else Sink(sink)
        self.failed_switches: list = []  # sides of a switch with no first point
        self.dof_names = list(dof_names)
        self.parameter = parameter
        self.harmonic_columns = harmonic_columns
        self.H = H  # the harmonics of a shooting row of order nu: nu * H of w / nu
        # header -> the shooting problem of a resumed shooting branch (set by the analysis; None: rows keep states)
        self.shooting_problem = None
        self.observables = getattr(model, "observables", None)
        self.whirl_parts = dict(getattr(model, "whirl_parts", None) or {})
        self.measures = row_measures(self.dof_names, harmonic_columns, H, model)
        if torus:  # quasi-periodic branches: their second frequency and main components
            self.measures += torus_measure_names(self.dof_names, self.whirl_parts)
        head = ["branch", "nu", parameter, "stable", "n_unstable", "max_multiplier"]
        self.branch_columns = head + self.measures + ["newton_iterations", "residual_norm"]
        self.special_columns = ["branch", "kind", parameter, "index"] + self.measures + SPECIAL_EXTRA
        self.rows = sink.table("branches.csv", self.branch_columns, append)
        self.special = sink.table("special_points.csv", self.special_columns, append)
        # the engine's solutions (unknowns and tangent) for plots of any row and for --resume: small records in
        # strict JSON, their arrays in binary beside them (never through a link: contin.output.state_store)
        self.state = StateWriter(sink.path("state.jsonl"), append) if sink.writes else _NoState()
        self.solutions: dict[int, dict] = {}  # row -> its full coefficients, with branch, lam, H, nu
        self.headers: dict[int, dict] = {}  # branch id -> its branch record
        self.n_rows = self.rows.rows
        self._written_special: dict[int, int] = {}
        self._headers: set = set()
        self.offsets: dict[int, int] = {}  # branch id -> its first row (of this run or a resumed one)
        self._engine_offsets: dict[int, int] = {}  # branch id -> row of the engine's index 0 in this run
        self.curves: dict[int, dict] = {}
        self.special_list: list[dict] = []
        self.problems: dict = {}  # branch id -> its problem, to expand condensed unknowns
        # the stored unknowns' full coefficients (its full problem set by the analysis: expansion.full = hb)
        self.expansion = StoredExpansion(None, self.problems)

    def _full(self, branch_id: int, u, lam: float, problem=None):
        """Full coefficients of the engine's ``u`` (expanded when the branch's problem is condensed)."""
        problem = self.problems.get(branch_id) if problem is None else problem
        if problem is None or not hasattr(problem, "expand"):
            return np.asarray(u)
        return problem.expand(u, lam)

    def _solution(self, branch_id: int, u, lam: float, nu: int, problem=None) -> tuple[np.ndarray, dict]:
        """A point's full coefficients and the measures that are not functions of them.

        A shooting branch's are the coefficients of its integrated orbit and the orbit's sampled extremes
        (:func:`contin.analyses.shooting_rows.shooting_row`); a harmonic-balance branch's, its (expanded) unknowns.
        """
        problem = self.problems.get(branch_id) if problem is None else problem
        if is_shooting(problem):  # of the problem's own order (a special point may come before the branch's rows)
            return shooting_row(problem, u, lam, order_of(problem) * self.H, self.dof_names)
        return self._full(branch_id, u, lam, problem), {}

    def _measures(self, u, n, nu, problem=None, lam=None):
        if isinstance(problem, QuasiPeriodicBalance):
            return torus_measures(problem, u, lam, self.dof_names, self.harmonic_columns, self.whirl_parts)
        if is_circle(problem):
            from contin.timedomain.circle_measures import circle_measures  # deferred: the time domain

            return circle_measures(problem, u, lam, self.dof_names, min(self.H, self.harmonic_columns),
                                   self.whirl_parts)
        out = point_measures(u, n, self.dof_names, self.harmonic_columns)
        if self.observables is not None:
            out.update(self.observables(u, n, nu))
        return out

    def solution_measures(self, problem, u, lam: float) -> dict:
        """The row measures of a solution ``u`` of ``problem`` at ``lam`` that belongs to no branch (a point of a
        two-parameter curve)."""
        _, sampled, measures = self.point_values(problem, u, lam, order_of(problem))
        return {**measures, **sampled}

    def point_values(self, problem, u, lam: float, nu: int) -> tuple:
        """What :meth:`point` computes of a stored point of ``problem`` (the engine's ``u`` at ``lam``): its full
        coefficients, its sampled measures and its measures. Reads nothing but the recorder's settings, so it
        may run in the thread that traced the point (:mod:`contin.analyses.side_by_side`)."""
        c, sampled = self._solution(None, u, lam, nu, problem)
        return c, sampled, self._measures(c, len(self.dof_names), nu, problem, lam)

    def point(self, branch_id: int, nu: int, branch, i: int, H: int | None = None, problem=None,
              values: tuple | None = None) -> None:
        """Write stored point ``i`` of ``branch``: its row, its checkpoint record and the special points found
        up to it. ``values``: its :meth:`point_values`, when computed already."""
        self.offsets.setdefault(branch_id, self.n_rows - i)
        self._engine_offsets.setdefault(branch_id, self.n_rows - i)
        if problem is not None:
            self.problems[branch_id] = problem
        lam = float(branch.parameter[i])
        if values is None:
            values = self.point_values(self.problems.get(branch_id), branch.unknowns[i], lam, nu)
        u, sampled, measures = values
        shooting = is_shooting(self.problems.get(branch_id))
        row = {"branch": branch_id, "nu": nu, self.parameter: lam}
        pd = branch.point_data
        if "stable" in pd and bool(pd["evaluated"][i] if "evaluated" in pd else True):
            row["stable"] = bool(pd["stable"][i])
            row["n_unstable"] = int(pd["n_unstable"][i])
            row["max_multiplier"] = float(pd["max_multiplier"][i])
        elif "stable" in pd:  # no verdict at this point: empty cells, not the monitor's placeholders
            row.update(stable=None, n_unstable=None, max_multiplier=None)
        row.update(measures)
        row.update(sampled)
        row["newton_iterations"] = int(branch.newton_iterations[i])
        row["residual_norm"] = float(branch.residual_norms[i])
        self.rows.write(row)
        if branch_id not in self._headers:
            self._headers.add(branch_id)
            su = branch.info.get("unknown_scale")
            kept = getattr(self.problems.get(branch_id), "dofs", None)
            header = {"type": "branch", "branch": branch_id, "nu": nu, "H": H,
                      "unknown_scale": None if su is None else np.asarray(su),
                      "parameter_scale": branch.info.get("parameter_scale"),
                      "dofs": None if kept is None else [int(d) for d in kept],
                      "unknowns": ENGINE_UNKNOWNS,  # the engine's (kept dofs'): contin.output.expansion
                      "torus": _torus_header(self.problems.get(branch_id))}
            if shooting:  # its points hold states (x, x') at t = 0; its rows the coefficients of nu*H harmonics
                header.update(_shooting_header(self.problems[branch_id]), H=nu * self.H)
            self.headers[branch_id] = header
            self.state.write(header)
        self.solutions[self.n_rows] = {"branch": branch_id, "lam": lam, "u": u, "H": nu * self.H if shooting else H,
                                       "nu": nu}
        su, sl = branch.info.get("unknown_scale"), branch.info.get("parameter_scale")
        self.state.write({
            "type": "point", "row": self.n_rows, "branch": branch_id, "nu": nu, "H": H, "lam": lam,
            "u": _vector(branch.unknowns[i]), "tangent": _vector(branch.tangents[i]),
            "scale": [None if su is None else np.asarray(su), sl], "s": float(branch.arclength[i]),
            "step": float(branch.step_sizes[i]), "iterations": int(branch.newton_iterations[i]),
            "residual": float(branch.residual_norms[i]),
            "data": {k: v[i] for k, v in pd.items()}})
        self.n_rows += 1
        self.special_points(branch_id, branch)
        prob = self.problems.get(branch_id)
        c = self.curves.setdefault(branch_id, {"x": [], "rows": [], "stable": [], "nu": nu,
                                               "torus": isinstance(prob, QuasiPeriodicBalance) or is_circle(prob)})
        c["x"].append(lam)
        c["rows"].append(row)
        c["stable"].append(row.get("stable"))
        kept = getattr(self.problems.get(branch_id), "dofs", None)
        if shooting:  # the tangent is the state's: no direction in the coefficients (drawn through the points)
            c["method"] = "shooting"
            self._keep_solution(c, u, branch.tangents[i], None, None, None, nu * self.H)
        else:
            self._keep_solution(c, u, branch.tangents[i], su, sl, kept, H)

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
                self.state.write(special_record(branch_id, sp, csv=False))
                continue
            i = min(max(sp.index, 0), len(branch) - 1)
            if i + 1 < len(branch) and abs(branch.parameter[i + 1] - sp.parameter) < abs(branch.parameter[i] - sp.parameter):
                i += 1
            row = {"branch": branch_id, "kind": sp.kind.value, self.parameter: float(sp.parameter), "index": off + i}
            nu = self.curves.get(branch_id, {}).get("nu", 1)
            if is_shooting(self.problems.get(branch_id)):
                nu = order_of(self.problems[branch_id])
            _, sampled, measures = self.point_values(self.problems.get(branch_id), sp.unknowns, float(sp.parameter),
                                                     nu)
            row.update(measures)
            row.update(sampled)
            lo, hi = sp.bracket
            row.update({"interval_lo": float(lo), "interval_hi": float(hi), "located": bool(sp.located),
                        "detail": _detail(sp)})
            self.special.write(row)
            self.special_list.append(dict(row, _before=off + min(max(sp.index, 0), len(branch) - 1)))
            self.state.write(special_record(branch_id, sp))

    def checkpoint(self, branch_id: int, branch, state: dict) -> None:
        """The engine's state after a step (or its monitors' at the branch's end): see :mod:`contin.output.checkpoint`."""
        self.special_points(branch_id, branch)  # the state holds them: write them first
        if "points" in state:
            self.state.engine({"type": "engine", "branch": branch_id, "state": state})
        else:
            info = {k: v for k, v in branch.info.items() if k in _END_INFO}
            self.state.write({"type": "end", "branch": branch_id, "status": branch.status.value,
                              "message": branch.message, "info": info, "monitors": state.get("monitors") or []})

    def restore(self, previous: dict, full=None) -> None:
        """Take up the rows and special points of an interrupted run (``--resume``).

        ``full``: the run's full problem, which expands the stored unknowns of condensed branches
        (:class:`contin.output.expansion.StoredExpansion`).
        """
        if full is not None:
            self.expansion.full = full
        expansion = self.expansion
        rows = read_csv(self.rows.path)
        self.n_rows = len(rows.get("branch", []))  # the rows of this run continue the numbering
        solutions = checkpoint_solutions(read_records(self.state.path))
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
                u, tangent, su, sl, kept, H, header, lam = solutions[r]
                if header.get("method") == "shooting":
                    c["method"] = "shooting"
                    if self.shooting_problem is not None:  # the coefficients of its orbit, as when it was written
                        u, _ = self._solution(bid, u, lam, c["nu"], self.shooting_problem(header))
                    su = sl = kept = None
                    H = header.get("H")
                u_full = u if header.get("method") == "shooting" else expansion(header, u, lam)
                if u_full is None:
                    raise ValueError(f"row {r} of the checkpoint holds the kept dofs only, and no problem expands it")
                self._keep_solution(c, u_full, tangent, su, sl, kept, H)
                c["torus"] = header.get("torus") is not None  # drawn as a torus, as when it was written
                self.headers.setdefault(bid, header)
                self.solutions[r] = {"branch": bid, "lam": lam, "u": u_full, "H": H, "nu": c["nu"]}
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

    def run_data(self, summary: dict | None = None):
        """The run's tables and every point's full coefficients as arrays
        (:func:`contin.output.exports.run_data`), from memory."""
        tables = {"branches.csv": self.rows.table(), "special_points.csv": self.special.table()}
        return run_data(tables, summary, self.solutions, self.headers, self.parameter)

    def close(self) -> None:
        self.rows.close()
        self.special.close()
        self.state.close()


class _NoState:
    """The checkpoint of a run held in memory: nothing is written (it is never resumed)."""

    path = None

    def write(self, record: dict) -> None:
        pass

    def engine(self, record: dict) -> None:
        pass

    def flush(self) -> None:
        pass

    def close(self) -> None:
        pass


def _vector(a):
    """A point's coefficients or tangent as written: a list when short (inline in its line), else the array
    (its bytes in ``state.bin``)."""
    a = np.asarray(a, dtype=float)
    return a.tolist() if a.size <= INLINE else a


def _shooting_header(problem) -> dict:
    """What a shooting branch's record says of its discretisation (its problem is rebuilt from it on resume)."""
    o = problem.options
    return {"method": "shooting", "unknowns": "state",
            "shooting": {"steps_per_period": int(o.steps_per_period), "segments": int(getattr(o, "segments", 1)),
                         "start_step": int(getattr(o, "start_step", 0))}}


def _torus_header(problem) -> dict | None:
    """What rebuilds a torus branch's problem from the checkpoint (None for a periodic branch); a circle's
    problem is made again by its start at the parent's Neimark-Sacker point, and its header says it."""
    if is_circle(problem):
        return {"circle": True, "points": problem.points, "steps_per_period": problem.options.steps_per_period,
                "winding": int(problem.winding)}
    if not isinstance(problem, QuasiPeriodicBalance):
        return None
    return {"harmonics": problem.H1, "harmonics2": problem.H2, "samples": problem.N1, "samples2": problem.N2,
            "crossings": problem.options.crossings, "pin": list(problem.pin)}


def _detail(sp) -> str:
    d = sp.data or {}
    parts = []
    if "multiplier" in d:
        z = complex(d["multiplier"])
        parts.append(f"multiplier {z.real:.6g}{z.imag:+.6g}j")
    if sp.message:
        parts.append(sp.message)
    return "; ".join(parts)


def _flag(value) -> bool | None:
    """A ``stable`` cell read back: True, False, or None where it is empty (no verdict)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    return {"true": True, "false": False}.get(value)
