"""The summary map of a sweep (``sweep_map.png``).

- One grid axis: a two-parameter diagram. The grid values run along x, the
  continuation parameter along y; at each grid value the intervals where a
  stable solution of order ``nu`` exists are drawn as bars (one colour per
  ``nu``), and the located folds, period doublings, Neimark-Sacker and
  branch points as markers. Failed points are marked on the x axis.
- Two or more axes: heat maps over the first two axes, one panel per
  quantity (the length of the stable interval set per ``nu``, the number of
  folds, of period doublings), failed points shown hatched. With more than
  two axes the map is the slice at the first value of the others (named in
  the title).
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from contin.output.plotting import MARKERS  # noqa: E402
from contin.util.naming import is_real  # noqa: E402

__all__ = ["sweep_map"]


def _positions(values):
    """x positions of the grid values: the values if all numbers, else 0, 1, 2, ..."""
    if all(is_real(v) for v in values):
        return [float(v) for v in values], None
    return list(range(len(values))), [str(v) for v in values]


def _intervals(text):
    out = []
    for part in str(text or "").split(";"):
        if ".." in part:
            a, b = part.split("..")
            out.append((float(a), float(b)))
    return out


def _values(text):
    return [float(v) for v in str(text or "").split(";") if v.strip()]


def _nus(rows):
    found = set()
    for r in rows:
        for k in r:
            if k.startswith("stable_nu") and k[9:].isdigit():
                found.add(int(k[9:]))
    return sorted(found)


def sweep_map(rows, axes, path: Path) -> list[str]:
    """Draw the map of a sweep's summary and save it to ``path``.

    Parameters
    ----------
    rows : list of dict
        The rows of ``sweep.csv`` (grid keys, ``status``, summary columns).
    axes : sequence of GridAxis
    path : Path

    Returns
    -------
    list of str
        The file names written (``[path.name]``).
    """
    path = Path(path)
    if len(axes) == 1:
        fig = _one_axis(rows, axes[0])
    else:
        fig = _two_axes(rows, axes)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return [path.name]


def _one_axis(rows, axis):
    fig, ax = plt.subplots(figsize=(7.2, 4.6), constrained_layout=True)
    xs, labels = _positions(list(axis.values))
    pos = {str(v): x for v, x in zip(axis.values, xs)}
    span = (max(xs) - min(xs)) if len(xs) > 1 else 1.0
    nus = _nus(rows)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    offset = {nu: (i - (len(nus) - 1) / 2) * 0.012 * span for i, nu in enumerate(nus)}
    parameter = next((r.get("parameter") for r in rows if r.get("parameter")), "parameter")
    seen = set()
    failed = []
    for r in rows:
        x = pos[str(r[axis.key])]
        if r.get("status") != "complete":
            failed.append(x)
            continue
        for i, nu in enumerate(nus):
            for a, b in _intervals(r.get(f"stable_nu{nu}")):
                lab = f"stable, nu = {nu}" if ("nu", nu) not in seen else None
                seen.add(("nu", nu))
                ax.plot([x + offset[nu]] * 2, [a, b], "-", color=colors[i % len(colors)], lw=4, alpha=0.7,
                        solid_capstyle="butt", label=lab)
        for kind in ("fold", "pd", "ns", "bp"):
            vals = _values(r.get(f"{kind}_at"))
            if vals:
                m, c = MARKERS[kind]
                ax.plot([x] * len(vals), vals, m, color=c, mfc="none", ms=6, zorder=5,
                        label=kind if kind not in seen else None)
                seen.add(kind)
    if failed:
        ax.plot(failed, [0.0] * len(failed), "x", color="0.4", ms=8, transform=ax.get_xaxis_transform(),
                clip_on=False, label="failed run")
    if labels is not None:
        ax.set_xticks(xs, labels)
    ax.set_xlabel(axis.key)
    ax.set_ylabel(parameter)
    ax.set_title("stable intervals and special points over the grid", fontsize=10)
    ax.grid(True, alpha=0.3)
    if seen or failed:
        ax.legend(fontsize=8, loc="best")
    return fig


def _two_axes(rows, axes):
    ax1, ax2 = axes[0], axes[1]
    rest = axes[2:]
    first_rest = {a.key: str(a.values[0]) for a in rest}
    sel = [r for r in rows if all(str(r[k]) == v for k, v in first_rest.items())]
    parameter = next((r.get("parameter") for r in rows if r.get("parameter")), "the parameter")
    quantities = [(f"stable_nu{nu}_length", f"length in {parameter} of the stable set, nu = {nu}") for nu in _nus(rows)]
    for kind, title in (("fold", "folds"), ("pd", "period doublings"), ("ns", "Neimark-Sacker points")):
        if any(r.get(f"n_{kind}") for r in rows) or (kind == "fold" and not quantities):
            quantities.append((f"n_{kind}", f"number of {title}"))
    quantities = quantities[:4]
    n1, n2 = len(ax1.values), len(ax2.values)
    i1 = {str(v): i for i, v in enumerate(ax1.values)}
    i2 = {str(v): i for i, v in enumerate(ax2.values)}
    ncol = len(quantities)
    fig, axs = plt.subplots(1, ncol, figsize=(max(4.2 * ncol, 5.0), 4.2), constrained_layout=True, squeeze=False)
    for (col, title), ax in zip(quantities, axs[0]):
        grid = np.full((n2, n1), np.nan)
        failed = np.zeros((n2, n1), bool)
        for r in sel:
            i, j = i1[str(r[ax1.key])], i2[str(r[ax2.key])]
            if r.get("status") != "complete":
                failed[j, i] = True
                continue
            v = r.get(col)
            grid[j, i] = float(v) if is_real(v) and math.isfinite(float(v)) else 0.0
        im = ax.imshow(np.ma.masked_invalid(grid), origin="lower", aspect="auto", cmap="viridis",
                       interpolation="nearest")
        for j, i in zip(*np.nonzero(failed)):
            ax.add_patch(plt.Rectangle((i - 0.5, j - 0.5), 1, 1, fill=False, hatch="xx", color="0.5"))
        if n1 * n2 <= 100:
            for j in range(n2):
                for i in range(n1):
                    if np.isfinite(grid[j, i]):
                        dark = im.norm(grid[j, i]) < 0.6  # light text on the dark end of viridis
                        ax.text(i, j, f"{grid[j, i]:.3g}", ha="center", va="center", fontsize=7,
                                color="w" if dark else "k")
        ax.set_xticks(range(n1), [_short(v) for v in ax1.values], rotation=45 if n1 > 8 else 0, fontsize=7)
        ax.set_yticks(range(n2), [_short(v) for v in ax2.values], fontsize=7)
        ax.set_xlabel(ax1.key)
        ax.set_ylabel(ax2.key)
        ax.set_title(title, fontsize=9)
        fig.colorbar(im, ax=ax, shrink=0.8)
    if rest:
        fig.suptitle("slice at " + ", ".join(f"{k}={v}" for k, v in first_rest.items()), fontsize=9)
    return fig


def _short(v) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)
