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

import numpy as np

from contin.scene.registry import register_analysis, shortfalls
from contin.util.naming import suggest
from contin.scene.schema import Key, SceneError, flag, is_number, mapping, number, string

__all__ = ["STATIC", "check", "result_columns", "run", "static_stability"]

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
    from contin.hb.measures import measure_names

    obs_cols = list(getattr(model, "observable_names", ())) if getattr(model, "observables", None) else []
    values = list(model.dof_names) + list(names_lin)
    measures = measure_names(model.dof_names, 0, 0) + obs_cols
    head = ["branch", "nu", parameter, "stable", "n_unstable", "max_multiplier", "lowest_eigenvalue"]
    return {"values": values, "measures": measures,
            "branches.csv": head + values + measures + ["newton_iterations", "residual_norm"],
            "special_points.csv": ["branch", "kind", parameter, "index"] + values
            + ["stable", "n_unstable", "lowest_eigenvalue", "interval_lo", "interval_hi", "located", "detail"]}


class _StaticRecorder:
    """Streams ``branches.csv`` and ``special_points.csv`` of a static analysis."""

    def __init__(self, outdir, model, parameter, names_lin):
        from contin.output.results import CsvStream

        self.model = model
        self.parameter = parameter
        self.lin = names_lin
        self.observables = getattr(model, "observables", None)
        cols = result_columns(model, parameter, names_lin)
        self.values, self.measures = cols["values"], cols["measures"]
        self.columns = cols["branches.csv"]
        self.special_columns = cols["special_points.csv"]
        self.rows = CsvStream(outdir / "branches.csv", self.columns)
        self.special = CsvStream(outdir / "special_points.csv", self.special_columns)
        self.n_rows = 0
        self.curves: dict = {}
        self.special_list: list = []

    def _values(self, x) -> dict:
        from contin.hb.measures import point_measures

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
        row.update(self._values(x))
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
            row.update({k: v for k, v in self._values(sp.unknowns).items() if k in self.values})
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


def validate(data, model, analysis, lines) -> None:
    """Refuse parameter values that make no physical sense (a negative frequency, mass, ...)."""
    from contin.scene.parse import check_parameter_values

    check_parameter_values(model, analysis, analysis["parameter"],
                           [(f"analysis.{k}", analysis[k]) for k in ("range", "start") if analysis[k] is not None],
                           lines)


def check(scene, model) -> dict:
    """Every check of a ``static`` scene with its model; returns its setup.

    Returns
    -------
    dict
        ``param``, ``lo``, ``hi``, ``lam0``, ``auto`` (the model under its
        static load), ``hb`` (its ``H = 0`` problem), ``opts``, ``lin``
        (linear observables) and ``measure`` (the plotted column).
    """
    from contin.scene.registry import check_output
    from contin.engine.continuation import ContinuationOptions
    from contin.modal.equilibrium import static_problem

    a = scene.analysis
    param = a["parameter"]
    if param not in model.parameters:
        raise scene.error("analysis.parameter", f"a parameter of the model {list(model.parameters)}", param)
    lam_a, lam_b = float(a["range"][0]), float(a["range"][1])
    lo, hi = min(lam_a, lam_b), max(lam_a, lam_b)
    lam0 = float(a["start"]) if a["start"] is not None else lam_a
    if not lo <= lam0 <= hi:
        raise scene.error("analysis.start", f"a value inside range [{lo:g}, {hi:g}]", lam0)
    try:
        hb = static_problem(model, param)
    except ValueError as exc:
        raise SceneError("analysis", "a model with a static problem", None, hint=f": {exc}") from None
    auto = hb.model
    d = dict(a["continuation"])
    d.setdefault("direction", 1 if (lam_b if lam0 != lam_b else lam_a) > lam0 else -1)
    try:
        opts = ContinuationOptions.from_dict(d)
    except ValueError as exc:
        raise SceneError("analysis.continuation", "valid continuation options", None, hint=f": {exc}") from None
    lin = dict(getattr(auto, "linear_observables", {}) or {})
    cols = result_columns(auto, param, lin)
    measure = a["measure"] or (next(iter(lin)) if lin else model.dof_names[0])
    if measure not in cols["values"]:
        raise scene.error("analysis.measure", "a dof or linear observable among " + ", ".join(cols["values"]), measure,
                          hint=suggest(str(measure), cols["values"]))
    check_output(scene, cols["branches.csv"][2:], [param])
    return {"param": param, "lo": lo, "hi": hi, "lam0": lam0, "auto": auto, "hb": hb, "opts": opts, "lin": lin,
            "measure": measure, "columns": cols}


@register_analysis("static", STATIC, validate=validate, check=check)
def run(ctx) -> dict:
    """Run a ``static`` scene; returns its part of ``summary.json``."""
    from contin.engine.continuation import continuation
    from contin.modal.equilibrium import solve_equilibrium, time_varying_excitations
    from contin.scene.registry import RunError

    scene, model = ctx.scene, ctx.model
    a = scene.analysis
    plan = ctx.plan  # check(), made before anything was written
    param, lo, hi, lam0 = plan["param"], plan["lo"], plan["hi"], plan["lam0"]
    auto, hb, opts, lin, measure = plan["auto"], plan["hb"], plan["opts"], plan["lin"], plan["measure"]
    t0 = time.perf_counter()
    res = solve_equilibrium(hb, lam0)
    if not res.converged:
        raise RunError(f"no equilibrium at {param}={lam0:g}: no static equilibrium of '{model.name}' found: "
                       f"{res.message}")
    x0 = res.x

    def monitor(u, lam, Ju, Jlam):
        return static_stability(Ju, auto.linear(hb.params_at(lam))[0])  # M may depend on the parameter

    rec = _StaticRecorder(ctx.outdir, auto, param, lin)
    runs = [opts] + ([opts.replace(direction=-opts.direction)] if a["both_ways"] and lo < lam0 < hi else [])
    branches = []
    try:
        for bid, o in enumerate(runs):
            def callback(branch, i, bid=bid):
                rec.point(bid, branch, i)
                ctx.progress.update(f"static branch {bid}: {param}={branch.parameter[i]:.6g}, point {i}",
                                    parameter=branch.parameter, bounds=(lo, hi), task=f"branch {bid}")
                return not ctx.stop_requested

            br = continuation(hb, x0, lam0, (lo, hi), o, parameter_name=param, monitors=[monitor], callback=callback)
            rec.specials(bid, br)
            branches.append(br)
    finally:
        rec.close()
    ctx.timings["continuation"] = time.perf_counter() - t0
    ctx.interrupted = ctx.interrupted or any(b.status.value == "interrupted" for b in branches)
    ctx.plot = lambda: _plot(ctx, rec, param, measure)
    return {
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
        "shortfalls": shortfalls([{"branch": i, "points": len(b), "status": b.status.value, "message": b.message,
                                   "uncovered": b.info.get("uncovered")} for i, b in enumerate(branches)], param),
    }


def _plot(ctx, rec, param, measure):
    from contin.output.dense import dense_branch
    from contin.output.labels import model_symbols
    from contin.output.plotting import CHANGES, SPECIAL, bifurcation_diagram

    out = ctx.scene.output

    def evaluate(lam, X):
        return np.array([rec._values(x)[measure] for x in X]), lam

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
    return bifurcation_diagram(curves, special, param, measure, ctx.outdir / "static", units=out["units"],
                               labels=out["labels"], symbols=model_symbols(ctx.model), title=out["title"],
                               formats=out["formats"], dpi=out["dpi"], style=out["style"], vertical_parameter=True)
