"""``Result.plot``: a run's diagram drawn into the user's axes, with the user's backend and style."""

from __future__ import annotations

import numpy as np

from contin.hb.measures import point_measures
from contin.output.dense import dense_branch
from contin.output.labels import axis_label
from contin.output.markers import start_group
from contin.output.plotting import CHANGES, draw_bifurcation_diagram

__all__ = ["plot_result", "diagram_data"]


def _evaluator(result, measure: str, nu: int):
    """``evaluate(lam, U) -> (lam, measure)`` with the function of the CSV columns, or None for a column
    that is no function of the solution alone (a multiplier, a model's own column)."""
    n, dofs = len(result.dofs), list(result.dofs)
    columns = int((result.scene.get("output") or {}).get("harmonic_columns", 5))
    probe = point_measures(np.zeros(n * 3), n, dofs, columns)
    if measure not in probe:
        return None

    def evaluate(lam, U):
        return lam, np.array([float(point_measures(u, n, dofs, columns)[measure]) for u in U])

    return evaluate


def _solutions(result, branch) -> np.ndarray | None:
    """The branch's full coefficient vectors, (P, n(2H+1)) in the order of contin.hb.harmonics, or None."""
    data = result.data
    if "coefficients" not in data:
        return None
    where = {int(r): i for i, r in enumerate(data["coefficient_rows"])}
    if not all(int(r) in where for r in branch.rows):
        return None
    idx = [where[int(r)] for r in branch.rows]
    H = {int(data["harmonics"][i]) for i in idx}
    if len(H) != 1:
        return None
    h = H.pop()
    return data["coefficients"][idx, :2 * h + 1].reshape(len(idx), -1)


def diagram_data(result, measure: str) -> tuple[list, list]:
    """The branch and special-point dicts :func:`draw_bifurcation_diagram` takes, for ``measure``.

    Between stored points each branch is drawn from its interpolated harmonic coefficients
    (:func:`contin.output.dense.dense_branch`), the measure evaluated on them as for the CSV columns.
    """
    curves, special = [], []
    for b in result.branches:
        if measure not in b.columns:
            raise KeyError(f"no column {measure!r}; the columns are {', '.join(b.columns)}")
        x, y = np.asarray(b.parameter, float), np.asarray(b[measure], float)
        stable = None if b.stable is None else [None if s < 0 else bool(s) for s in b.stable]
        points = []
        for s in b.special_points:
            sy = float(s.measures.get(measure, np.nan))
            if not np.isfinite(sy):
                continue
            j = int(np.clip(np.searchsorted(b.rows, s.row), 0, len(b) - 1))
            if j > 0 and min(x[j - 1], x[j]) <= s.parameter <= max(x[j - 1], x[j]):
                j -= 1  # the stored point before it along the branch
            points.append({"x": s.parameter, "y": sy, "index": j, "changes": s.kind in CHANGES})
            special.append({"x": s.parameter, "y": sy, "kind": s.kind, "branch": b.id, "located": s.located})
        U = None if b.torus else _solutions(result, b)  # a torus is drawn through its stored points
        evaluate = _evaluator(result, measure, b.nu) if U is not None and len(b) > 1 else None
        d = dense_branch(x, U if evaluate is not None else np.zeros((x.size, 0)), evaluate, stable=stable,
                         special=points, node_xy=(x, y))
        # both halves of a branch followed both ways start at one point: one colour, one legend entry
        group = start_group(b.nu, x[0], [b[c][0] for c in b.columns if c.startswith("amp_")]) if x.size \
            else ("branch", b.id)
        curves.append({"x": d["x"], "y": d["y"], "stable": d["stable"], "nu": b.nu, "id": b.id, "group": group,
                       "torus": b.torus})
    return curves, special


def plot_result(result, ax=None, measure: str | None = None, *, table: bool | None = None, **options):
    """Draw ``result`` into ``ax`` (a new pyplot figure when None); see :meth:`Result.plot`."""
    if table is not None and not isinstance(table, (bool, np.bool_)):
        raise TypeError(f"Result.plot: table must be True, False or None, not {table!r}")
    if table is None:
        # the table stands right of the axes: only a figure made here is sure to have room for it
        table = ax is None
    if ax is None:
        import matplotlib.pyplot as plt  # the user's figure, on the user's backend

        _, ax = plt.subplots(layout="constrained")
    out = (result.scene.get("output") or {})
    symbols = (result.summary.get("model") or {}).get("symbols") or {}
    if not result.branches:
        cols = result.columns
        if not cols:
            raise ValueError(f"this {result.analysis or 'run'} has no table to draw; its files: {result.files}")
        names = list(cols)
        x = names[0]
        ys = [measure] if measure else [c for c in names[1:] if np.issubdtype(np.asarray(cols[c]).dtype, np.number)][:4]
        for y in ys:
            ax.plot(cols[x], cols[y], label=axis_label(y, out.get("units"), out.get("labels"), symbols))
        ax.set_xlabel(axis_label(x, out.get("units"), out.get("labels"), symbols))
        if len(ys) > 1:
            ax.legend()
        else:
            ax.set_ylabel(axis_label(ys[0], out.get("units"), out.get("labels"), symbols))
        return ax
    measure = measure or out.get("measure") or f"amp_{result.dofs[0]}"
    curves, special = diagram_data(result, measure)
    draw_bifurcation_diagram(ax, curves, special, result.parameter, measure, units=out.get("units"),
                             labels=out.get("labels"), symbols=symbols, table=bool(table), **options)
    return ax
