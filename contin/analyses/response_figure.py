"""The figure of a frequency response: its branches and special points as curves and markers, from its recorder."""

from __future__ import annotations

import numpy as np

from contin.analyses.branch_recorder import BranchRecorder
from contin.output.dense import as_number, dense_branch, kept_indices, value_between
from contin.output.labels import model_symbols
from contin.output.markers import CHANGES, SPECIAL, start_group

__all__ = ["diagram_branches", "draw_response"]


def draw_response(ctx, rec, hb) -> list[str]:
    """Draw the run's bifurcation diagram (``output.panels``: stacked panels); the files written."""
    out = ctx.scene.output
    measure = out["measure"] or f"amp_{hb.model.dof_names[0]}"  # checked by check()
    drawn = [(m, *diagram_branches(rec, m)) for m in out.get("panels") or [measure]]  # output.panels: stacked
    from contin.output.panels import panel_diagram  # deferred: matplotlib, loaded only to draw

    return panel_diagram(drawn, hb.parameter, ctx.outdir / "bifurcation_diagram", zoom=out.get("zoom"),
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
        if (measure in rec.measures and len(c.get("u", ())) == x.size and x.size > 1
                and c.get("method") != "shooting" and not c.get("torus")):
            # a function of u (a shooting row's extremes are sampled; a torus is drawn through its stored points)
            evaluate, U = _evaluator(rec, measure, c["nu"], rec.problems.get(bid)), np.array(c["u"])
            if all(d is not None for d in c["direction"]):
                directions = np.array(c["direction"])
        kept = kept_indices(c.get("kept"), n, c.get("H") or 0) if c.get("kept") is not None else None
        d = dense_branch(x, U, evaluate, directions=directions, kept=kept, scale=c.get("scale"), stable=stable,
                         special=points, node_xy=(x, y))
        # both halves of a branch followed both ways start at one point
        group = start_group(c["nu"], x[0], [as_number(v) for k, v in c["rows"][0].items() if k.startswith("amp_")]) \
            if x.size else ("branch", bid)
        branches.append({"x": d["x"], "y": d["y"], "stable": d["stable"], "nu": c["nu"], "id": bid, "group": group,
                         "torus": bool(c.get("torus"))})
    return branches, special


def _evaluator(rec: BranchRecorder, measure: str, nu: int, problem=None):
    """``evaluate(lam (K,), U (K, M)) -> (lam, measure (K,))`` with the function of the CSV columns."""
    n = len(rec.dof_names)

    def evaluate(lam, U):
        return lam, np.array([as_number(rec._measures(u, n, nu, problem, lv).get(measure)) for u, lv in zip(U, lam)])

    return evaluate
