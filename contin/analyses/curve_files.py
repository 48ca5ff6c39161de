"""``bifurcation_curve``'s result files and figure, for curves by harmonic balance and by shooting.

``curves.csv`` (one row per curve point), ``curve_points.csv`` (codimension-two
points, turning points, starts and ends), ``one_parameter_points.csv`` (the
one-parameter runs' points and their distance to the curves) and
``bifurcation_curves.<format>`` (:mod:`contin.output.plane_plot`).
"""

from __future__ import annotations

from contin.bifurcation.two_parameter import special_point_kind
from contin.output.labels import math
from contin.output.plane_plot import two_parameter_diagram
from contin.scene.registry import shortfalls

__all__ = ["CODIM2_COUNTED", "CURVE_POINT_KINDS", "curve_progress", "curve_shortfalls", "curve_summary", "not_started", "on_curve",
           "plot_curves", "point_checks", "write_curve_points", "write_one_parameter_points", "write_table"]

#: codimension-two kinds counted in the summary and drawn on the diagram
CODIM2_COUNTED = ("cusp", "fold_flip", "extremum", "r1", "r2", "r3", "r4", "flip_ns", "fold_ns")
CURVE_POINT_KINDS = CODIM2_COUNTED + ("start", "end")
#: the colours of the curves of subharmonic (nu > 1) solutions, apart from those of the harmonic ones
SUBHARMONIC_COLORS = {"ns": "tab:cyan", "fold": "tab:orange", "pd": "tab:pink"}


def on_curve(curves, kind: str, p1: float, p2: float, nu: int | None = None):
    """``(curve id, p1 on the curve, distance)`` of the nearest curve of ``kind`` (and order ``nu``, when given)
    crossing ``p2``, or None."""
    best = None
    for cid, cur in enumerate(curves):
        if cur.kind.value != kind or (nu is not None and cur.nu != nu) or not len(cur):
            continue
        for q1, _ in cur.crossings(p2):
            if best is None or abs(q1 - p1) < best[2]:
                best = (cid, q1, abs(q1 - p1))
    return best


def point_checks(entries, curves, kinds, p1: str, p2: str, point_kinds=("fold", "pd"), with_nu: bool = False) -> list:
    """The rows of ``one_parameter_points.csv``: each point of ``point_kinds`` of the one-parameter branches
    ``entries`` (``(branch id, p2 value, branch, nu)``) with the nearest curve of its kind (and order, with
    ``with_nu``) when ``kinds`` traces that kind, and the distance."""
    out = []
    for j, value, br, nu in entries:
        for sp in br.special_points:
            kind = special_point_kind(sp).value
            if kind not in point_kinds:
                continue
            near = on_curve(curves, kind, float(sp.parameter), value, nu if with_nu else None) if kind in kinds \
                else None
            out.append({"branch": j, p2: value, "kind": kind, **({"nu": nu} if with_nu else {}),
                        p1: float(sp.parameter), "located": bool(sp.located), "interval_lo": sp.bracket[0],
                        "interval_hi": sp.bracket[1], "curve": None if near is None else near[0],
                        f"curve_{p1}": None if near is None else near[1],
                        "distance": None if near is None else near[2]})
    return out


def curve_shortfalls(ctx, curves, skipped, p1: str, p2: str) -> list[str]:
    """What the curves left undone: the sides that gave up (as :func:`contin.scene.registry.shortfalls` tells
    them), and the located points that started no curve because the default ``max_curves`` was reached (a cap
    the scene did not set)."""
    out = shortfalls([{**e, "branch": f"{cid} ({cur.kind.value}), {e['side']} side,"}
                      for cid, cur in enumerate(curves) for e in cur.ends], p2, what="curve")
    capped = [q for q in skipped if q.get("reason") == "max_curves"]
    if capped and "max_curves" not in (ctx.scene.data.get("analysis") or {}):
        out.append(f"{len(capped)} located point(s) started no curve ({p1} = "
                   f"{', '.join(f'{q[p1]:.6g}' for q in capped)}): the default cap analysis.max_curves = "
                   f"{ctx.scene.analysis['max_curves']} was reached")
    return out


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
