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
import matplotlib.ticker
import numpy as np
from matplotlib.patches import Rectangle

from contin.output.figures import figure_style, legend_below, new_figure, save_figure
from contin.output.labels import axis_label, math as mathtext
from contin.util.naming import is_real

__all__ = ["sweep_map", "draw_one_axis", "draw_two_axes"]

#: marker and colour of each kind of special point (those of the bifurcation diagram)
MARKERS = {"fold": ("o", "tab:red"), "pd": ("s", "tab:purple"), "ns": ("D", "tab:green"), "bp": ("^", "tab:orange")}


def _key_label(key: str) -> str:
    """Axis label of a grid key: ``model.parameters.F`` -> the parameter's symbol, other keys as written."""
    parts = key.split(".")
    if len(parts) == 3 and parts[:2] == ["model", "parameters"]:
        return axis_label(parts[2])
    return f"{key}"


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


def sweep_map(rows, axes, path: Path, *, formats=("png",), dpi: float | None = None,
              style: str | None = "contin") -> list[str]:
    """Draw the map of a sweep's summary and save it to ``path``.

    Parameters
    ----------
    rows : list of dict
        The rows of ``sweep.csv`` (grid keys, ``status``, summary columns).
    axes : sequence of GridAxis
    path : Path
        The file name; its suffix is replaced by each of ``formats``.
    formats, dpi, style
        As ``output.formats``, ``output.dpi``, ``output.style`` of a scene.

    Returns
    -------
    list of str
        The file names written.
    """
    with figure_style(style):
        if len(axes) == 1:
            fig = new_figure((7.2, 5.0))
            ax = fig.add_subplot()
            draw_one_axis(ax, rows, axes[0], legend=False)
            legend_below(fig, ax, ncols=min(len(ax.get_legend_handles_labels()[0]), 4) or 1)
        else:
            fig = _two_axes(rows, axes)
        return save_figure(fig, Path(path), formats, dpi)


def draw_one_axis(ax, rows, axis, legend: bool = True) -> None:
    """Stable intervals (bars, one colour per order ``nu``) and special points over one grid axis, into ``ax``.

    Parameters
    ----------
    ax : matplotlib Axes
    rows : list of dict
        The rows of ``sweep.csv``.
    axis : GridAxis
    legend : bool
        Draw the legend inside the axes.
    """
    xs, labels = _positions(list(axis.values))
    pos = {str(v): x for v, x in zip(axis.values, xs)}
    span = (max(xs) - min(xs)) if len(xs) > 1 else 1.0
    nus = _nus(rows)
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    offset = {nu: (i - (len(nus) - 1) / 2) * 0.012 * span for i, nu in enumerate(nus)}
    parameter = next((r.get("parameter") for r in rows if r.get("parameter")), None)
    seen = set()
    failed = []
    for r in rows:
        x = pos[str(r[axis.key])]
        if r.get("status") != "complete":
            failed.append(x)
            continue
        for i, nu in enumerate(nus):
            for a, b in _intervals(r.get(f"stable_nu{nu}")):
                lab = rf"stable, $\nu$ = {nu}" if ("nu", nu) not in seen else None
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
    ax.set_xlabel(_key_label(axis.key))
    ax.set_ylabel(axis_label(parameter) if parameter else "continuation parameter")
    ax.set_title("stable intervals and special points over the grid")
    if legend and (seen or failed):
        ax.legend(loc="best")


def _two_axes(rows, axes):
    first_rest = {a.key: str(a.values[0]) for a in axes[2:]}
    quantities = _quantities(rows)
    fig = new_figure((max(4.4 * len(quantities), 5.2), 4.6))
    axs = fig.subplots(1, len(quantities), squeeze=False)[0]
    for (col, title), ax in zip(quantities, axs):
        draw_two_axes(ax, rows, axes, col, title)
    if first_rest:
        fig.suptitle("slice at " + ", ".join(f"{k} = {v}" for k, v in first_rest.items()))
    return fig


def _quantities(rows) -> list:
    """The columns mapped (at most four) and their titles."""
    parameter = next((r.get("parameter") for r in rows if r.get("parameter")), None)
    where = mathtext(parameter) if parameter else "the parameter"
    quantities = [(f"stable_nu{nu}_length", rf"length in {where} of the stable set, $\nu$ = {nu}")
                  for nu in _nus(rows)]
    for kind, title in (("fold", "folds"), ("pd", "period doublings"), ("ns", "Neimark-Sacker points")):
        if any(r.get(f"n_{kind}") for r in rows) or (kind == "fold" and not quantities):
            quantities.append((f"n_{kind}", f"number of {title}"))
    return quantities[:4]


def draw_two_axes(ax, rows, axes, col: str, title: str) -> None:
    """A heat map of the column ``col`` over the first two grid axes (the slice at the first value of the others)."""
    ax1, ax2 = axes[0], axes[1]
    first_rest = {a.key: str(a.values[0]) for a in axes[2:]}
    sel = [r for r in rows if all(str(r[k]) == v for k, v in first_rest.items())]
    n1, n2 = len(ax1.values), len(ax2.values)
    i1 = {str(v): i for i, v in enumerate(ax1.values)}
    i2 = {str(v): i for i, v in enumerate(ax2.values)}
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
        ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, fill=False, hatch="xx", color="0.5"))
    if n1 * n2 <= 100:
        for j in range(n2):
            for i in range(n1):
                if np.isfinite(grid[j, i]):
                    dark = im.norm(grid[j, i]) < 0.6  # light text on the dark end of viridis
                    ax.text(i, j, f"{grid[j, i]:.3g}", ha="center", va="center", fontsize=7,
                            color="w" if dark else "k")
    ax.set_xticks(range(n1), [_short(v) for v in ax1.values], rotation=45 if n1 > 8 else 0, fontsize=7)
    ax.set_yticks(range(n2), [_short(v) for v in ax2.values], fontsize=7)
    ax.set_xlabel(_key_label(ax1.key))
    ax.set_ylabel(_key_label(ax2.key))
    ax.set_title(title, fontsize=9)
    ax.grid(False)
    bar = ax.figure.colorbar(im, ax=ax, shrink=0.8)
    bar.ax.tick_params(labelsize=7)
    if col.startswith("n_"):  # counts: whole numbers on the colour bar
        bar.ax.yaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))


def _short(v) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)
