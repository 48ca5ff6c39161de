"""``static``: equilibria versus a load parameter (restoring-force curves).

The static residual is the harmonic balance with ``H = 0`` of the model
under its static load ``f_0``, the period mean of its excitation (constant
loads stay, harmonic forcing has mean zero;
:func:`contin.modal.equilibrium.static_problem`):

    R(x, lambda) = K x + f_nl(x, 0) - f_0(lambda),     dR/dx = K_t (tangent stiffness),

followed in ``parameter`` over ``range`` by the continuation engine, which
locates its folds (limit loads, snap-through) and branch points. Each
equilibrium gets its static stability from the tangent stiffness: the
eigenvalues of ``M^-1 K_t`` are the squared natural frequencies about it;
``n_unstable`` counts those that are not real and positive.

Result files: ``branches.csv`` (``branch``, the parameter, ``stable``,
``n_unstable``, ``lowest_eigenvalue`` (the smallest ``omega^2``), the value of
every dof and linear observable under its own name, the SPEC measures of the
dofs (``amp_`` = 0, ``max_`` = ``min_`` = the value), the model's own columns,
``newton_iterations``, ``residual_norm``), ``special_points.csv`` and the
restoring-force plot ``static.png`` (the parameter against the chosen
displacement, as the belt paper's Fig. 4 and 5 draw the load ``p_s`` against
``w(0.6)``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from contin.analyses.base import Analysis, RunError, ScaleCheck
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.measures import measure_names, point_measures
from contin.modal.equilibrium import solve_equilibrium, static_problem, time_varying_excitations
from contin.output.dense import dense_branch
from contin.output.labels import model_symbols
from contin.output.plotting import CHANGES, SPECIAL, bifurcation_diagram
from contin.scene.parse import check_parameter_values
from contin.scene.preflight import dofs_text
from contin.scene.registry import check_output, shortfalls
from contin.scene.schema import Key, SceneError, flag, is_number, mapping, number, string
from contin.scene.sweep_plan import SweepPlan, sweep_plan
from contin.util.naming import suggest

__all__ = ["STATIC", "Static", "StaticPlan", "result_columns", "static_stability"]

STATIC = {
    "type": string(required=True),
    "parameter": string(required=True),
    "range": Key("a list of two different numbers [start, end]",
                 lambda v: isinstance(v, list) and len(v) == 2 and all(is_number(x) for x in v) and v[0] != v[1],
                 required=True),
    "start": number(),
    "both_ways": flag(False),
    "measure": string(),
    "continuation": mapping(),
}


def static_stability(Ju: np.ndarray, M: np.ndarray) -> dict:
    """Stability of an equilibrium from its tangent stiffness.

    Parameters
    ----------
    Ju : ndarray, shape (n, n)
        Tangent stiffness ``K_t``.
    M : ndarray, shape (n, n)

    Returns
    -------
    dict
        ``stable`` (all ``omega^2`` real and positive), ``n_unstable`` (how many
        are not), ``lowest_eigenvalue`` (smallest real part of ``omega^2``).
    """
    lam = np.linalg.eigvals(np.linalg.solve(M, Ju))
    scale = max(float(np.abs(lam).max()), 1e-300)
    bad = (lam.real <= 0) | (np.abs(lam.imag) > 1e-9 * scale)
    return {"stable": bool(not bad.any()), "n_unstable": int(bad.sum()), "lowest_eigenvalue": float(lam.real.min())}


def result_columns(model, parameter: str, names_lin) -> dict:
    """``values`` (dofs and linear observables), and the columns of ``branches.csv`` and ``special_points.csv``."""
    obs_cols = list(getattr(model, "observable_names", ())) if getattr(model, "observables", None) else []
    values = list(model.dof_names) + list(names_lin)
    measures = measure_names(model.dof_names, 0, 0) + obs_cols
    head = ["branch", "nu", parameter, "stable", "n_unstable", "max_multiplier", "lowest_eigenvalue"]
    return {"values": values, "measures": measures,
            "branches.csv": head + values + measures + ["newton_iterations", "residual_norm"],
            "special_points.csv": ["branch", "kind", parameter, "index"] + values
            + ["stable", "n_unstable", "lowest_eigenvalue", "interval_lo", "interval_hi", "located", "detail"]}


@dataclass(frozen=True)
class StaticPlan:
    """The checked choices of a ``static`` scene.

    Attributes
    ----------
    sweep : SweepPlan
        The parameter, its range, the start and the direction.
    problem : HarmonicBalance
        The ``H = 0`` problem of the model under its static load.
    options : ContinuationOptions
        ``analysis.continuation``, its direction that of ``sweep``.
    linear_observables : dict
        Name -> coefficient row of the model's linear observables.
    measure : str
        The plotted column (a dof or a linear observable).
    columns : dict
        :func:`result_columns`.
    """

    sweep: SweepPlan
    problem: object
    options: ContinuationOptions
    linear_observables: dict
    measure: str
    columns: dict

    @property
    def model(self):
        """The model under its static load (the problem's)."""
        return self.problem.model


class _StaticRecorder:
    """Streams ``branches.csv`` and ``special_points.csv`` of a static analysis."""

    def __init__(self, sink, model, parameter, names_lin):
        self.model = model
        self.parameter = parameter
        self.lin = names_lin
        self.observables = getattr(model, "observables", None)
        cols = result_columns(model, parameter, names_lin)
        self.values, self.measures = cols["values"], cols["measures"]
        self.columns = cols["branches.csv"]
        self.special_columns = cols["special_points.csv"]
        self.rows = sink.table("branches.csv", self.columns)
        self.special = sink.table("special_points.csv", self.special_columns)
        self.n_rows = 0
        self.curves: dict = {}
        self.special_list: list = []

    def point_values(self, x) -> dict:
        """The dofs, linear observables and measures of the equilibrium ``x``."""
        out = {d: float(v) for d, v in zip(self.model.dof_names, x)}
        for name, c in self.lin.items():
            out[name] = float(np.asarray(c) @ x)
        out.update(point_measures(x, self.model.n_dof, self.model.dof_names, 0))
        if self.observables is not None:
            out.update(self.observables(x, self.model.n_dof, 1))
        return out

    def point(self, bid, branch, i) -> None:
        x = branch.unknowns[i]
        pd = branch.point_data
        row = {"branch": bid, "nu": 0, self.parameter: float(branch.parameter[i]), "stable": bool(pd["stable"][i]),
               "n_unstable": int(pd["n_unstable"][i]), "lowest_eigenvalue": float(pd["lowest_eigenvalue"][i]),
               "newton_iterations": int(branch.newton_iterations[i]),
               "residual_norm": float(branch.residual_norms[i])}
        row.update(self.point_values(x))
        self.rows.write(row)
        c = self.curves.setdefault(bid, {"rows": [], "offset": self.n_rows - i, "u": [], "direction": []})
        c["rows"].append(row)
        # the equilibrium and its tangent in the unknowns' units, for the dense curve
        c["u"].append(np.asarray(x, dtype=float))
        su, sl = branch.info.get("unknown_scale"), branch.info.get("parameter_scale")
        t = np.asarray(branch.tangents[i], dtype=float)
        if su is not None and sl is not None:
            c["scale"] = np.append(np.broadcast_to(np.asarray(su, dtype=float), (t.size - 1,)), float(sl))
        c["direction"].append(None if su is None or sl is None else t * c["scale"])
        self.n_rows += 1

    def specials(self, bid, branch) -> None:
        off = self.curves.get(bid, {}).get("offset", 0)
        for sp in branch.special_points:
            if sp.kind.value == "start":
                continue
            row = {"branch": bid, "kind": sp.kind.value, self.parameter: float(sp.parameter),
                   "index": off + min(max(sp.index, 0), len(branch) - 1), "interval_lo": sp.bracket[0],
                   "interval_hi": sp.bracket[1], "located": bool(sp.located), "detail": sp.message}
            row.update({k: v for k, v in self.point_values(sp.unknowns).items() if k in self.values})
            d = sp.point_data or {}
            for k in ("stable", "n_unstable", "lowest_eigenvalue"):
                if k in d:
                    v = np.asarray(d[k]).item()
                    row[k] = bool(v) if k == "stable" else (int(v) if k == "n_unstable" else float(v))
            self.special.write(row)
            self.special_list.append(row)

    def close(self) -> None:
        self.rows.close()
        self.special.close()


class Static(Analysis):
    """``static``: equilibria versus a load parameter, their folds and static stability (module docstring)."""

    name = "static"
    summary = "Equilibria against a load parameter, with limit loads."
    required = "parameter, range"
    schema = STATIC

    def validate(self, data, model, analysis, lines) -> None:
        """Refuse parameter values that make no physical sense (a negative frequency, mass, ...)."""
        check_parameter_values(model, analysis, analysis["parameter"],
                               [(f"analysis.{k}", analysis[k]) for k in ("range", "start") if analysis[k] is not None],
                               lines)

    def plan(self, scene, model) -> StaticPlan:
        """Every check of a ``static`` scene with its model (the parameter, the start, the options, the measure)."""
        a = scene.analysis
        sweep = sweep_plan(scene, model, need_frequency=False)
        param = sweep.parameter
        try:
            hb = static_problem(model, param)
        except ValueError as exc:
            raise SceneError("analysis", "a model with a static problem", None, hint=f": {exc}") from None
        auto = hb.model
        d = dict(a["continuation"])
        d.setdefault("direction", sweep.direction)
        try:
            opts = ContinuationOptions.from_dict(d)
        except ValueError as exc:
            raise SceneError("analysis.continuation", "valid continuation options", None, hint=f": {exc}") from None
        lin = dict(getattr(auto, "linear_observables", {}) or {})
        cols = result_columns(auto, param, lin)
        measure = a["measure"] or (next(iter(lin)) if lin else model.dof_names[0])
        if measure not in cols["values"]:
            raise scene.error("analysis.measure", "a dof or linear observable among " + ", ".join(cols["values"]),
                              measure, hint=suggest(str(measure), cols["values"]))
        check_output(scene, cols["branches.csv"][2:], [param])
        return StaticPlan(sweep=sweep, problem=hb, options=opts, linear_observables=lin, measure=measure,
                          columns=cols)

    def describe(self, plan: StaticPlan, scene, model) -> list[str]:
        a = scene.analysis
        return [f"  equilibria (H = 0) in {a['parameter']} over {a['range']}; unknowns: {model.n_dof} dof"]

    def scale_checks(self, plan: StaticPlan) -> list[ScaleCheck]:
        n = plan.problem.size
        return [ScaleCheck("analysis.continuation.unknown_scale", plan.options, n, f"the {dofs_text(n)}")]

    def run(self, plan: StaticPlan, ctx):
        """Follow the equilibria from the start over the range (both ways when asked); tables and summary."""
        model = ctx.model
        sweep, hb, opts = plan.sweep, plan.problem, plan.options
        param, lo, hi, lam0 = sweep.parameter, sweep.lo, sweep.hi, sweep.start
        auto, lin, measure = plan.model, plan.linear_observables, plan.measure
        t0 = time.perf_counter()
        res = solve_equilibrium(hb, lam0)
        if not res.converged:
            raise RunError(f"no equilibrium at {param}={lam0:g}: no static equilibrium of '{model.name}' found: "
                           f"{res.message}")
        x0 = res.x

        def monitor(u, lam, Ju, Jlam):
            return static_stability(Ju, auto.linear(hb.params_at(lam))[0])  # M may depend on the parameter

        rec = _StaticRecorder(ctx.sink, auto, param, lin)
        runs = sweep.runs(opts)
        branches = []
        try:
            for bid, o in enumerate(runs):
                def callback(branch, i, bid=bid):
                    rec.point(bid, branch, i)
                    ctx.progress.update(f"static branch {bid}: {param}={branch.parameter[i]:.6g}, point {i}",
                                        parameter=branch.parameter, bounds=(lo, hi), task=f"branch {bid}")
                    return not ctx.stop_requested

                br = continuation(hb, x0, lam0, (lo, hi), o, parameter_name=param, monitors=[monitor],
                                  callback=callback)
                rec.specials(bid, br)
                branches.append(br)
        finally:
            rec.close()
        ctx.timings["continuation"] = time.perf_counter() - t0
        ctx.interrupted = ctx.interrupted or any(b.status.value == "interrupted" for b in branches)
        missing = shortfalls([{"branch": i, "points": len(b), "status": b.status.value, "message": b.message,
                               "uncovered": b.info.get("uncovered")} for i, b in enumerate(branches)], param)
        part = {
            "parameter": param,
            "measure": measure,
            "dropped_excitations": time_varying_excitations(model),
            "equilibrium_at_start": {"parameter": lam0, "x": [float(v) for v in x0]},
            "branches": [{"branch": i, "nu": 0, "points": len(b), "status": b.status.value, "message": b.message,
                          "special_points": {k: sum(1 for s in b.special_points if s.kind.value == k)
                                             for k in ("fold", "bp")}}
                         for i, b in enumerate(branches)],
            "rows": rec.n_rows,
            "special_points": len(rec.special_list),
            "shortfalls": missing,
        }
        draw = (lambda: _plot(ctx, rec, param, measure)) if ctx.sink.writes else None
        return self.outcome(ctx, part, shortfalls=missing, draw=draw)


def _plot(ctx, rec, param, measure):
    out = ctx.scene.output

    def evaluate(lam, X):
        return np.array([rec.point_values(x)[measure] for x in X]), lam

    curves = []
    for bid, c in rec.curves.items():
        rows = c["rows"]
        lam = np.array([r[param] for r in rows])
        points = [{"x": s[measure], "y": s[param], "index": s["index"] - c["offset"], "changes": s["kind"] in CHANGES}
                  for s in rec.special_list if s["branch"] == bid and s["kind"] in SPECIAL]
        directions = np.array(c["direction"]) if all(d is not None for d in c["direction"]) else None
        d = dense_branch(lam, np.array(c["u"]), evaluate, directions=directions, scale=c.get("scale"),
                         stable=[r["stable"] for r in rows], special=points,
                         node_xy=(np.array([r[measure] for r in rows]), lam))
        # the two halves of the path followed both ways from one equilibrium
        curves.append({"x": d["x"], "y": d["y"], "stable": d["stable"], "nu": 0, "id": bid, "group": "equilibria"})
    special = [{"x": s[measure], "y": s[param], "kind": s["kind"], "branch": s["branch"]} for s in rec.special_list]
    return bifurcation_diagram(curves, special, param, measure, ctx.sink.path("static"), units=out["units"],
                               labels=out["labels"], symbols=model_symbols(ctx.model), title=out["title"],
                               formats=out["formats"], dpi=out["dpi"], style=out["style"], vertical_parameter=True)
