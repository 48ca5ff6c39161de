"""The two-parameter diagram: fold and period-doubling curves in the plane of two parameters.

The curves a ``bifurcation_curve`` run traces are stored at the points the
continuation stepped to; they are drawn through those points by a
shape-preserving interpolation along their arc (piecewise cubic Hermite in
the arc length, so a curve with few points is drawn smooth without
overshooting its points). A curve that turns in the second parameter (a
tongue or a wedge: the jump region between two folds, the region of a
period-doubled solution) is shaded inside, and so is the region between two
curves of one kind that meet at a tip (the two sides of a Mathieu tongue).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.interpolate import PchipInterpolator

from contin.output.figures import figure_style, legend_below, new_figure, save_figure
from contin.output.labels import axis_label
from contin.output.plotting import NOT_LOCATED

__all__ = ["CURVE_STYLE", "CODIM2_MARKERS", "POINT_MARKERS", "smooth_arc", "draw_two_parameter",
           "two_parameter_diagram"]

#: colour and legend text of each kind of curve
CURVE_STYLE = {"fold": ("tab:red", "fold curve (jump region)"),
               "pd": ("tab:purple", "period-doubling curve (2nu-subharmonic region)"),
               "ns": ("tab:blue", "Neimark-Sacker curve (a torus is born)")}
#: marker, colour and size of the codimension-two points and of a curve that stopped early
CODIM2_MARKERS = {"cusp": ("^", "k", 8), "fold_flip": ("*", "tab:green", 11), "extremum": ("o", "0.4", 4),
                  "r1": ("D", "tab:orange", 8), "r2": ("D", "tab:green", 8), "r3": ("v", "tab:olive", 8),
                  "r4": ("<", "tab:olive", 8), "flip_ns": ("P", "tab:cyan", 9), "fold_ns": ("P", "tab:pink", 9),
                  "stop": ("X", "tab:brown", 8)}
#: marker and colour of the points located by one-parameter runs (those of the bifurcation diagram)
POINT_MARKERS = {"fold": ("o", "tab:red"), "pd": ("s", "tab:purple"), "ns": ("x", "tab:blue")}

_CODIM2_TEXT = {"cusp": "cusp", "fold_flip": "fold-flip point", "extremum": "turning point of the curve",
                "r1": "1:1 resonance", "r2": "1:2 resonance", "r3": "1:3 resonance", "r4": "1:4 resonance",
                "flip_ns": "flip-Neimark-Sacker point", "fold_ns": "fold-Neimark-Sacker point",
                "stop": "curve stops early"}


def smooth_arc(x, y, scale=(1.0, 1.0), density: float = 600.0):
    """Points along a curve through ``(x, y)``, interpolated in its arc length.

    The arc length is measured in units of ``scale`` (the axes' spans), so
    the curve is as smooth in x as in y whatever their units; each coordinate
    is a monotone piecewise cubic (PCHIP) of it, so the drawn curve passes
    through every stored point and does not overshoot between two of them.

    Parameters
    ----------
    x, y : array_like, shape (P,)
    scale : (float, float)
        Spans of the axes.
    density : float
        Points per unit of scaled arc length (at least the stored points are kept).

    Returns
    -------
    xs, ys : ndarray, shape (Q,)
        With ``Q >= P``; the input itself when it has fewer than 3 finite points.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if x.size < 3:
        return x, y
    sx, sy = (abs(float(v)) or 1.0 for v in scale)
    step = np.hypot(np.diff(x) / sx, np.diff(y) / sy)
    keep = np.concatenate([[True], step > 1e-12])  # repeated points: no arc between them
    x, y = x[keep], y[keep]
    s = np.concatenate([[0.0], np.cumsum(step[step > 1e-12])])
    if s.size < 3:
        return x, y
    n = int(min(max(density * s[-1], 4 * s.size), 20000))
    t = np.union1d(np.linspace(0.0, s[-1], n), s)
    return PchipInterpolator(s, x)(t), PchipInterpolator(s, y)(t)


def _turns(y) -> bool:
    """A curve whose second parameter has an interior extremum (a tongue's or wedge's tip)."""
    return y.size >= 3 and (0 < int(np.argmin(y)) < y.size - 1 or 0 < int(np.argmax(y)) < y.size - 1)


def _tongue(a, b, xlim, span):
    """The polygon between two curves of one kind that meet at a tip, or None.

    Both curves must be monotone in the second parameter with their lower (or
    upper) ends within 10 % of the axes' spans of each other. Where one curve
    ends on a side of the plot below the other's far end, the polygon runs up
    that side.
    """
    (xa, ya), (xb, yb) = a, b
    if xa.size < 2 or xb.size < 2 or _turns(ya) or _turns(yb):
        return None
    for tip in (np.argmin, np.argmax):
        ia, ib = int(tip(ya)), int(tip(yb))
        if abs(xa[ia] - xb[ib]) < 0.1 * span[0] and abs(ya[ia] - yb[ib]) < 0.1 * span[1]:
            break
    else:
        return None
    # from a's far end to the tip, then along b to its far end
    pa = (xa, ya) if ia == xa.size - 1 else (xa[::-1], ya[::-1])
    pb = (xb, yb) if ib == 0 else (xb[::-1], yb[::-1])
    px, py = list(pa[0]) + list(pb[0]), list(pa[1]) + list(pb[1])
    ends = ((pa[0][0], pa[1][0]), (pb[0][-1], pb[1][-1]))
    far = max if tip is np.argmin else min
    top = far(ends[0][1], ends[1][1])
    if xlim is not None:
        for k, (ex, ey) in enumerate(ends):
            on_side = min(abs(ex - xlim[0]), abs(ex - xlim[1])) < 1e-6 * span[0]
            if on_side and ey != top:  # the curve left the plot through a side: close along that side
                if k == 0:
                    px.insert(0, ex), py.insert(0, top)
                else:
                    px.append(ex), py.append(top)
    return np.array(px), np.array(py)


def draw_two_parameter(ax, curves, codim2, points, p1: str, p2: str, *, lines=(), reference=(), xlim=None,
                       ylim=None, units=None, labels=None, symbols=None, title: str | None = None,
                       legend: bool = True):
    """Draw fold and period-doubling curves in the plane ``(p1, p2)`` into ``ax``.

    The points located by one-parameter runs are drawn on top, with the lines
    ``p2 = const`` along which those runs went, so that one sees them fall on
    the curves.

    Parameters
    ----------
    ax : matplotlib Axes
    curves : list of dict
        ``kind`` ('fold', 'pd' or 'ns'), ``x`` (P,) = p1, ``y`` (P,) = p2, ``color`` (optional), ``label``
        (the legend text; curves of one kind with the same label share an
        entry, which names their ``id`` s when given).
    codim2 : list of dict
        ``kind`` (cusp, fold_flip, extremum, or ``stop``: a curve that ended
        before its range), ``x``, ``y``.
    points : list of dict
        One-parameter special points: ``kind`` ('fold' or 'pd'), ``x``, ``y`` and optionally
        ``located`` (False: drawn grey and named "(not located)" in the legend).
    p1, p2 : str
        Parameter names (axis labels from :func:`contin.output.labels.axis_label`).
    lines : sequence of float
        Values of ``p2`` of the one-parameter runs.
    reference : list of dict
        Period doublings of the integrated flow: ``x``, ``y``.
    xlim, ylim : (float, float), optional
        Axis limits. A non-negative ``p2`` spanning more than 50 times its
        smallest positive value is drawn on a symmetric-log axis.
    units, labels, symbols : dict, optional
        ``output.units``, ``output.labels`` and the model's symbols.
    legend : bool
        Draw the legend inside the axes.
    """
    span = (xlim[1] - xlim[0] if xlim is not None else np.ptp(np.concatenate([np.ravel(c["x"]) for c in curves]))
            if curves else 1.0,
            ylim[1] - ylim[0] if ylim is not None else np.ptp(np.concatenate([np.ravel(c["y"]) for c in curves]))
            if curves else 1.0)
    span = tuple(float(s) if np.isfinite(s) and s > 0 else 1.0 for s in span)
    groups: dict = {}  # (kind, text) -> ids
    drawn = []
    colors = {}
    for c in curves:
        color, text = CURVE_STYLE.get(c["kind"], ("k", c["kind"]))
        color = c.get("color") or color
        groups.setdefault((c["kind"], c.get("label") or text), []).append(c.get("id"))
        colors[(c["kind"], c.get("label") or text)] = color
        xs, ys = smooth_arc(c["x"], c["y"], span)
        drawn.append((c["kind"], xs, ys))
        if _turns(ys):
            ax.fill(xs, ys, color=color, alpha=0.12, lw=0)  # a tongue or wedge: the region inside its tip
        ax.plot(xs, ys, "-", color=color, lw=1.6)
    for i in range(len(drawn)):
        for j in range(i + 1, len(drawn)):
            if drawn[i][0] == drawn[j][0]:
                poly = _tongue(drawn[i][1:], drawn[j][1:], xlim, span)
                if poly is not None:
                    ax.fill(*poly, color=CURVE_STYLE.get(drawn[i][0], ("k",))[0], alpha=0.12, lw=0)
    for (kind, text), ids in groups.items():
        text0 = text
        if all(i is not None for i in ids):
            text = ("curve " if len(ids) == 1 else "curves ") + ", ".join(str(i) for i in ids) + ": " + text
        ax.plot([], [], "-", color=colors[(kind, text0)], lw=1.6, label=text)
    if len(lines):
        for v in lines:
            ax.axhline(v, color="0.6", lw=0.8, ls=":", zorder=0)
        ax.plot([], [], ":", color="0.6", lw=0.8, label="one-parameter runs")
    done = set()
    for q in codim2:
        if q["kind"] not in CODIM2_MARKERS:
            continue
        m, color, ms = CODIM2_MARKERS[q["kind"]]
        ax.plot(q["x"], q["y"], m, color=color, ms=ms, label=_CODIM2_TEXT[q["kind"]] if q["kind"] not in done
                else None, zorder=6)
        if q["kind"] in ("cusp", "fold_flip"):
            ax.annotate(_CODIM2_TEXT[q["kind"]], (q["x"], q["y"]), textcoords="offset points", xytext=(6, -12),
                        fontsize=8)
        done.add(q["kind"])
    for q in points:
        m, color = POINT_MARKERS.get(q["kind"], ("x", "k"))
        key = "located by the one-parameter runs: " + q["kind"]
        if not q.get("located", True):  # only bracketed: grey, and said so in the legend
            color, key = "0.45", f"found by the one-parameter runs: {q['kind']} {NOT_LOCATED}"
        ax.plot(q["x"], q["y"], m, color=color, mfc="none", ms=7, mew=1.3, label=key if key not in done else None,
                zorder=7)
        done.add(key)
    if len(reference):
        ax.plot([q["x"] for q in reference], [q["y"] for q in reference], "o", color="k", ms=3.5, zorder=8,
                label="period doubling of the integrated flow (shooting)")
    if xlim is not None:
        ax.set_xlim(*xlim)
    ys = np.concatenate([np.asarray(c["y"], float).ravel() for c in curves] + [np.asarray(lines, float).ravel()]
                        + [np.array([q["y"] for q in reference], float)])
    positive = ys[ys > 0]
    if ylim is not None and ylim[0] >= 0 and positive.size and ylim[1] > 50 * positive.min():
        # a second parameter over decades (a damping from 0.005 to 5): logarithmic above the smallest value
        ax.set_yscale("symlog", linthresh=max(float(positive.min()), 1e-3 * ylim[1]), linscale=0.3)
        ax.set_ylim(ylim[0], ylim[1] * 1.2)
    elif ylim is not None:
        pad = 0.02 * (ylim[1] - ylim[0])
        ax.set_ylim(ylim[0] - pad, ylim[1] + pad)
    ax.set_xlabel(axis_label(p1, units, labels, symbols))
    ax.set_ylabel(axis_label(p2, units, labels, symbols))
    if title:
        ax.set_title(title)
    if legend and ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best")


def two_parameter_diagram(curves, codim2, points, p1: str, p2: str, path: Path, *, lines=(), reference=(),
                          xlim=None, ylim=None, units=None, labels=None, symbols=None, title: str | None = None,
                          formats=("png",), dpi: float | None = None, style: str | None = "contin") -> list[str]:
    """Draw :func:`draw_two_parameter` into a new figure, its legend below the axes, and save it.

    Parameters
    ----------
    path : Path
        The file name without its suffix (a suffix given is replaced).
    formats, dpi, style
        ``output.formats``, ``output.dpi`` and ``output.style``.

    The other parameters are those of :func:`draw_two_parameter`.

    Returns
    -------
    list of str
        The file names written.
    """
    with figure_style(style):
        fig = new_figure((7.2, 5.8))
        ax = fig.add_subplot()
        draw_two_parameter(ax, curves, codim2, points, p1, p2, lines=lines, reference=reference, xlim=xlim,
                           ylim=ylim, units=units, labels=labels, symbols=symbols, title=title, legend=False)
        legend_below(fig, ax)
        return save_figure(fig, path, formats, dpi)
