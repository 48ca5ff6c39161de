"""``bifurcation_curve``'s result files and figure, for curves by harmonic balance and by shooting.

``curves.csv`` (one row per curve point), ``curve_points.csv`` (codimension-two
points, turning points, starts and ends), ``one_parameter_points.csv`` (the
one-parameter runs' points and their distance to the curves) and
``bifurcation_curves.<format>`` (:mod:`contin.output.plane_plot`).
"""

from __future__ import annotations

from contin.output.labels import math
from contin.output.plane_plot import two_parameter_diagram

__all__ = ["CODIM2_COUNTED", "CURVE_POINT_KINDS", "curve_progress", "curve_summary", "not_started", "plot_curves",
           "write_curve_points", "write_one_parameter_points", "write_table"]

#: codimension-two kinds counted in the summary and drawn on the diagram
CODIM2_COUNTED = ("cusp", "fold_flip", "extremum", "r1", "r2", "r3", "r4", "flip_ns", "fold_ns")
CURVE_POINT_KINDS = CODIM2_COUNTED + ("start", "end")
#: the colours of the curves of subharmonic (nu > 1) solutions, apart from those of the harmonic ones
SUBHARMONIC_COLORS = {"ns": "tab:cyan", "fold": "tab:orange", "pd": "tab:pink"}


def not_started(near, count: int, max_curves: int, tol: float) -> dict | None:
    """Why a located point starts no curve: it lies on curve ``near[0]`` (``near`` = ``(curve, p1, distance)``
    within ``tol``), or ``max_curves`` are traced; None when it starts one."""
    if near is not None and near[2] <= tol:
        return {"on_curve": near[0]}
    if count >= max_curves:
        return {"reason": "max_curves"}
    return None


def curve_progress(ctx, kind: str, cid: int, p1: str, p2: str, bounds):
    """The engine callback of curve ``cid``: the progress line; False (stop) once a stop is requested."""
    def callback(branch, i):
        ctx.progress.update(f"{kind} curve {cid}  {p2}={branch.parameter[i]:.6g}  {p1}={branch.unknowns[i][-1]:.6g}"
                            f"  point {i}", parameter=branch.parameter, bounds=bounds, task=f"curve {cid}")
        return not ctx.stop_requested

    return callback


def curve_summary(cid, cur, p1, p2) -> dict:
    """A curve's entry of ``summary.json``: kind, order, points, ends, codimension-two points, ranges."""
    out = {"curve": cid, "kind": cur.kind.value, "nu": cur.nu, "points": len(cur), "closed": cur.closed,
           "ends": cur.ends,
           "special_points": {k: len(cur.points_of_kind(k)) for k in CODIM2_COUNTED if cur.points_of_kind(k)
                              or k in ("cusp", "fold_flip", "extremum")}}
    if len(cur):
        out[f"{p1}_range"] = [float(cur.p1.min()), float(cur.p1.max())]
        out[f"{p2}_range"] = [float(cur.p2.min()), float(cur.p2.max())]
        out["start"] = {p1: float(cur.p1[cur.start_index]), p2: float(cur.p2[cur.start_index])}
    return out


def write_table(ctx, name: str, columns: list, rows) -> None:
    """Write the rows (an iterable of dicts) to the result table ``name``."""
    out = ctx.sink.table(name, columns)
    try:
        for row in rows:
            out.write(row)
    finally:
        out.close()


def write_curve_points(ctx, curves, p1, p2) -> None:
    """``curve_points.csv``: every special point of every curve."""
    write_table(ctx, "curve_points.csv", ["curve", "kind", p1, p2, "located", "parameter", "detail"],
                ({"curve": cid, "kind": sp.kind.value, p1: sp.p1, p2: sp.p2, "located": sp.located,
                  "parameter": sp.data.get("parameter", ""), "detail": sp.message}
                 for cid, cur in enumerate(curves) for sp in cur.special_points))


def write_one_parameter_points(ctx, checks: list, p1, p2, nu: bool = False) -> list:
    """``one_parameter_points.csv`` from the rows ``checks``; returns them."""
    cols = ["branch", p2, "kind"] + (["nu"] if nu else []) + [p1, "located", "interval_lo", "interval_hi", "curve",
                                                              f"curve_{p1}", "distance"]
    write_table(ctx, "one_parameter_points.csv", cols, checks)
    return checks


def _label(cur) -> str:
    """Legend text of a curve (curves of one text share an entry that names their numbers)."""
    if cur.kind.value == "fold":
        return "fold (jump region)" if cur.nu == 1 else rf"fold of the $\nu = {cur.nu}$ solutions"
    if cur.kind.value == "ns":
        return "Neimark-Sacker (a torus is born)" if cur.nu == 1 else \
            rf"Neimark-Sacker of the $\nu = {cur.nu}$ solutions"
    return f"period doubling (1/{2 * cur.nu}-subharmonic region)"


def plot_curves(ctx, curves, checks, p1, p2, range1, range2, lines, reference=(), on_curves_only=False) -> list:
    """``bifurcation_curves.<format>`` in the result directory (a run that writes files); ``on_curves_only``
    draws only the one-parameter points that lie on a curve (the rest stay in ``one_parameter_points.csv``)."""
    out, sym = ctx.scene.output, getattr(ctx.model, "symbols", None)
    ref_y = [q["y"] for q in reference]
    marks = []
    for c in curves:
        for sp in c.special_points:
            if not ((sp.kind.value in CODIM2_COUNTED and sp.located) or (sp.kind.value == "end" and not sp.located)):
                continue
            q = {"kind": sp.kind.value if sp.kind.value != "end" else "stop", "x": sp.p1, "y": sp.p2}
            # a point where two curves meet (a 1:2 resonance ends a Neimark-Sacker curve on a period-doubling
            # curve) is drawn once
            if not any(r["kind"] == q["kind"] and abs(r["x"] - q["x"]) <= 1e-3 * (range1[1] - range1[0]) and
                       abs(r["y"] - q["y"]) <= 1e-3 * (range2[1] - range2[0]) for r in marks):
                marks.append(q)
    if on_curves_only:  # the points checked against a curve, and lying on it
        checks = [c for c in checks if c["distance"] is not None and c["distance"] <= 1e-3 * (range1[1] - range1[0])]
    return two_parameter_diagram(
        [{"kind": c.kind.value, "x": c.p1, "y": c.p2, "id": i, "label": _label(c),
          "color": SUBHARMONIC_COLORS.get(c.kind.value) if c.nu > 1 else None} for i, c in enumerate(curves)],
        marks,
        [{"kind": c["kind"], "x": c[p1], "y": c[p2], "located": c["located"]} for c in checks],
        p1, p2, ctx.sink.path("bifurcation_curves"), lines=sorted(set(lines)), reference=reference, xlim=range1,
        ylim=(min([range2[0]] + lines + ref_y), max([range2[1]] + lines + ref_y)), units=out["units"],
        labels=out["labels"], symbols=sym, formats=out["formats"], dpi=out["dpi"], style=out["style"],
        title=out["title"] or f"{ctx.model.name}: bifurcation curves in ({math(p1, sym)}, {math(p2, sym)})")
