"""Figures: the bifurcation diagram (stable solid, unstable dashed, special points labelled) and the
two-parameter diagram of fold and period-doubling curves."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

__all__ = ["bifurcation_diagram", "axis_label", "two_parameter_diagram"]

MARKERS = {"fold": ("o", "tab:red"), "pd": ("s", "tab:purple"), "ns": ("D", "tab:green"), "kink": ("v", "tab:gray"),
           "bp": ("^", "tab:orange"), "stability": ("x", "k"), "grazing": ("*", "tab:brown")}


def axis_label(name: str, units: dict | None = None, labels: dict | None = None) -> str:
    """``label [unit]`` for a parameter or measure, from the scene's ``output.labels``/``units``."""
    text = (labels or {}).get(name, name)
    unit = (units or {}).get(name)
    return f"{text} [{unit}]" if unit else text


def _segments(x, y, stable):
    """Split a curve where the stability flag (True, False, or None: no verdict) changes; segments share ends."""
    if stable is None or len(x) < 2:
        return [(x, y, True)]
    segs, start = [], 0
    for i in range(1, len(x)):
        if stable[i] != stable[start]:
            segs.append((x[start:i + 1], y[start:i + 1], stable[start]))
            start = i
    segs.append((x[start:], y[start:], stable[start]))
    return [(xs, ys, None if st is None else bool(st)) for xs, ys, st in segs]


#: line style and width of stable, unstable and unknown (no stability verdict) parts of a branch
_STYLES = {True: ("-", 1.6), False: ("--", 1.1), None: (":", 1.1)}


# offsets (points) tried in turn for a label, and the box (points) a label of a few letters covers
_LABEL_OFFSETS = ((4, 4), (4, -11), (-6, 4), (-6, -11), (4, 14), (4, -21))
_LABEL_BOX = (34.0, 9.0)


def _label_points(ax, points):
    """Name each special point beside its marker without letting two names overlap.

    Points of one kind closer than a label's height are named once, with their
    count (``grazing (2)``); a name that would cover another is moved to the
    next free offset of ``_LABEL_OFFSETS``, or left out where none is free
    (the legend still names the marker).
    """
    if not points:
        return
    ax.autoscale_view()
    fig = ax.figure
    xy = ax.transData.transform(np.array([[float(p["x"]), float(p["y"])] for p in points]))
    xy = xy * 72.0 / fig.dpi  # display pixels to points
    groups = []  # [kind, index of the first point, count]
    for i, p in enumerate(points):
        for g in groups:
            if g[0] == p["kind"] and np.all(np.abs(xy[i] - xy[g[1]]) < _LABEL_BOX[1]):
                g[2] += 1
                break
        else:
            groups.append([p["kind"], i, 1])
    boxes = []  # lower-left and upper-right corners of the labels placed, in points
    for kind, i, count in groups:
        text = kind if count == 1 else f"{kind} ({count})"
        width = _LABEL_BOX[0] * max(len(text), 4) / 7.0
        for dx, dy in _LABEL_OFFSETS:
            x0 = xy[i, 0] + (dx if dx > 0 else dx - width)
            box = (x0, xy[i, 1] + dy, x0 + width, xy[i, 1] + dy + _LABEL_BOX[1])
            if all(box[2] <= b[0] or b[2] <= box[0] or box[3] <= b[1] or b[3] <= box[1] for b in boxes):
                boxes.append(box)
                ax.annotate(text, (float(points[i]["x"]), float(points[i]["y"])), textcoords="offset points",
                            xytext=(dx, dy), ha="left" if dx > 0 else "right", fontsize=7,
                            color=MARKERS[kind][1])
                break


def bifurcation_diagram(branches, special, parameter: str, measure: str, path: Path, *,
                        units=None, labels=None, title: str | None = None, extra=None):
    """Draw and save a bifurcation diagram.

    Parameters
    ----------
    branches : list of dict
        Each with ``x`` (P,), ``y`` (P,), ``stable`` (None, or (P,) of True, False or None where a
        point has no stability verdict), ``label``.
    special : list of dict
        Each with ``x``, ``y``, ``kind``.
    parameter, measure : str
        Axis names.
    path : Path
        Output file (format from the suffix).
    extra : callable, optional
        ``extra(ax)`` to draw more on the axes.
    """
    fig, ax = plt.subplots(figsize=(7.0, 4.6), constrained_layout=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    unknown = False
    for i, br in enumerate(branches):
        c = colors[i % len(colors)]
        for xs, ys, st in _segments(np.asarray(br["x"]), np.asarray(br["y"]), br.get("stable")):
            ax.plot(xs, ys, _STYLES[st][0], color=c, lw=_STYLES[st][1])
            unknown = unknown or st is None
        if br.get("label"):  # the legend shows the branch's colour; the styles are keyed below
            ax.plot([], [], "-", color=c, lw=1.6, label=br["label"])
    seen = set()
    drawn = [sp for sp in special if sp["kind"] in MARKERS]
    for sp in drawn:
        kind = sp["kind"]
        m, c = MARKERS[kind]
        ax.plot(sp["x"], sp["y"], m, color=c, ms=6, mfc="none" if kind != "stability" else c,
                label=kind if kind not in seen else None, zorder=5)
        seen.add(kind)
    _label_points(ax, drawn)
    if extra is not None:
        extra(ax)
    ax.set_xlabel(axis_label(parameter, units, labels))
    ax.set_ylabel(axis_label(measure, units, labels))
    if title:
        ax.set_title(title)
    ax.grid(True, alpha=0.3)
    if any(br.get("stable") is not None for br in branches):
        ax.plot([], [], "k-", label="stable")
        ax.plot([], [], "k--", label="unstable")
    if unknown:
        ax.plot([], [], "k:", label="no stability verdict")
    if ax.get_legend_handles_labels()[0]:  # an empty diagram (a start that failed) has none
        ax.legend(fontsize=8, loc="best")
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


CURVE_STYLE = {"fold": ("tab:red", "fold curve (jump region)"),
               "pd": ("tab:purple", "period-doubling curve (2nu-subharmonic region)")}
CODIM2_MARKERS = {"cusp": ("^", "k", 8), "fold_flip": ("*", "tab:green", 11), "extremum": ("o", "0.4", 4),
                  "stop": ("X", "tab:brown", 8)}


def two_parameter_diagram(curves, codim2, points, p1: str, p2: str, path: Path, *, lines=(), reference=(),
                          xlim=None, ylim=None, units=None, labels=None, title: str | None = None):
    """Fold and period-doubling curves in the plane of two parameters.

    A curve that turns in ``p2`` (a tongue or a wedge with a tip or a cusp:
    the jump region between two folds, the region of a period-doubled
    solution) is drawn with the region inside it shaded (the polygon of the
    curve closed by the chord between its ends). The points located by
    one-parameter runs are drawn on top, with the lines ``p2 = const`` along
    which those runs went, so that one sees them fall on the curves.

    Parameters
    ----------
    curves : list of dict
        ``kind`` ('fold' or 'pd'), ``x`` (P,) = p1, ``y`` (P,) = p2, ``label``.
    codim2 : list of dict
        ``kind`` (cusp, fold_flip, extremum, or ``stop``: a curve that ended
        before its range, see its message), ``x``, ``y``.
    points : list of dict
        One-parameter special points: ``kind`` ('fold' or 'pd'), ``x``, ``y``.
    p1, p2 : str
        Axis names.
    path : Path
    lines : sequence of float
        Values of ``p2`` of the one-parameter runs.
    reference : list of dict
        Period doublings of the integrated flow (:mod:`contin.timedomain.shooting`): ``x``, ``y``.
    xlim, ylim : (float, float), optional
        Axis limits. A non-negative ``p2`` spanning more than 50 times its
        smallest positive value is drawn on a symmetric-log axis.
    """
    fig, ax = plt.subplots(figsize=(7.2, 5.0), constrained_layout=True)
    seen = set()
    for c in curves:
        x, y = np.asarray(c["x"]), np.asarray(c["y"])
        color, text = CURVE_STYLE.get(c["kind"], ("k", c["kind"]))
        if x.size >= 3 and (0 < int(np.argmin(y)) < y.size - 1 or 0 < int(np.argmax(y)) < y.size - 1):
            ax.fill(x, y, color=color, alpha=0.12, lw=0)  # a tongue or wedge: the region inside its tip
        ax.plot(x, y, "-", color=color, lw=1.6, label=c.get("label") or (text if c["kind"] not in seen else None))
        seen.add(c["kind"])
    for v in lines:
        ax.axhline(v, color="0.6", lw=0.8, ls=":", zorder=0)
    done = set()
    for q in codim2:
        if q["kind"] not in CODIM2_MARKERS:
            continue
        m, color, ms = CODIM2_MARKERS[q["kind"]]
        text = "curve stops early" if q["kind"] == "stop" else q["kind"]
        ax.plot(q["x"], q["y"], m, color=color, ms=ms, label=text if q["kind"] not in done else None, zorder=6)
        if q["kind"] in ("cusp", "fold_flip"):
            ax.annotate(q["kind"], (q["x"], q["y"]), textcoords="offset points", xytext=(5, -10), fontsize=8)
        done.add(q["kind"])
    for q in points:
        m, color = MARKERS.get(q["kind"], ("x", "k"))
        key = "one-parameter " + q["kind"]
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
    ax.set_xlabel(axis_label(p1, units, labels))
    ax.set_ylabel(axis_label(p2, units, labels))
    if title:
        ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path
