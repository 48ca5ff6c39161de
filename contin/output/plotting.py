"""The bifurcation diagram (the two-parameter diagram is :mod:`contin.output.plane_plot`).

The bifurcation diagram draws each branch in one colour: stable parts solid,
unstable parts dashed, parts without a stability verdict dotted. Its special
points are marked by kind and numbered on the plot; a table beside the plot
gives each number's kind and parameter value. Points closer than a number's
size share one label (``3-5``); a number that had to move away from its point
is tied to it by a leader line. :func:`draw_bifurcation_diagram` draws into
any axes (a user's ``Result.plot``); :func:`bifurcation_diagram` writes the
files of a run.
"""

from __future__ import annotations

import math as _math
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.transforms import Affine2D, ScaledTranslation

from contin.output.figures import figure_style, new_figure, save_figure
from contin.output.labels import axis_label, math

__all__ = ["bifurcation_diagram", "draw_bifurcation_diagram", "draw_curves", "branch_label", "axis_label", "kind_name",
           "point_marker", "SPECIAL", "CHANGES"]

from contin.output.markers import CHANGES, NOT_LOCATED, SPECIAL  # noqa: E402  (re-exported)


def kind_name(kind: str, located: bool = True, short: bool = False) -> str:
    """The name of a special point's kind in tables and legends, ``(not located)`` added for an unlocated one."""
    name = SPECIAL[kind][2 if short else 1]
    return name if located else f"{name} {NOT_LOCATED}"


def point_marker(kind: str, located: bool = True, ms: float | None = None) -> dict:
    """``Line2D`` keywords of a special point's marker: white-filled when located, open and grey when not
    (the curve shows through it: the point lies somewhere in its bracket)."""
    style = {"marker": SPECIAL[kind][0], "linestyle": "none", "mew": 0.8}
    if ms is not None:
        style["ms"] = ms
    if located:
        style.update(mfc="white", mec="k", fillstyle="full")
    else:
        style.update(mfc="none", mec="0.35", fillstyle="none")
    return style


def branch_label(nu: int) -> str:
    """The name of a branch of order ``nu``: ``harmonic``, ``1/2 subharmonic``, ...; ``equilibria`` for 0."""
    nu = int(nu)
    return "equilibria" if nu == 0 else "harmonic" if nu == 1 else f"1/{nu} subharmonic"


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


def _line_styles() -> dict:
    """Line style and width of stable, unstable and unknown (no verdict) parts, from the style's line width."""
    lw = float(matplotlib.rcParams["lines.linewidth"])
    return {True: ("-", lw), False: ("--", 0.75 * lw), None: (":", 0.9 * lw)}


def _groups(branches) -> list:
    """Branches drawn alike (one colour, one legend entry): ``[(label or None, [indices])]`` in order."""
    keys, out = {}, []
    for i, br in enumerate(branches):
        key = br.get("group", ("branch", i))
        if key not in keys:
            keys[key] = len(out)
            out.append([i])
        else:
            out[keys[key]].append(i)
    labels = []
    for g in out:
        br = branches[g[0]]
        ids = list(dict.fromkeys(str(branches[i].get("id", i)) for i in g))
        which = f" (branch {ids[0]})" if len(ids) == 1 else f" (branches {', '.join(ids)})"
        if "label" in br:
            labels.append(br["label"] or None)
        elif br.get("torus"):
            shared = sum(bool(branches[h[0]].get("torus")) for h in out) > 1
            labels.append("quasi-periodic" + (which if shared else ""))
        elif br.get("nu") is None:
            labels.append(f"branch {br.get('id', g[0])}")
        else:
            shared = sum(branches[h[0]].get("nu") == br["nu"] and not branches[h[0]].get("torus") for h in out) > 1
            labels.append(branch_label(br["nu"]) + (which if shared else ""))
    return list(zip(labels, out))


def draw_curves(ax, branches, special) -> tuple:
    """Draw the branches and mark the special points in ``ax``, without axis labels, legend or numbers.

    Parameters
    ----------
    ax : matplotlib Axes
    branches, special : list of dict
        As :func:`draw_bifurcation_diagram` takes them.

    Returns
    -------
    handles : list
        The legend's entries: a colour per group of branches (with more than one group) and the line
        styles drawn.
    points : list of dict
        The special points drawn (finite ones of a kind of :data:`SPECIAL`), copies with ``located`` set.
    ms : float
        The markers' size (points).
    """
    styles = _line_styles()
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key().get("color", ["C0"])
    groups = _groups(branches)
    seen_styles = set()
    handles = []
    for gi, (label, members) in enumerate(groups):
        color = colors[gi % len(colors)]
        for i in members:
            br = branches[i]
            if br.get("torus"):  # quasi-periodic: a light band under the line
                ax.plot(br["x"], br["y"], linewidth=5 * styles[True][1], alpha=0.22, color=color,
                        solid_capstyle="round")
                seen_styles.add("torus")
            for xs, ys, st in _segments(np.asarray(br["x"], float), np.asarray(br["y"], float), br.get("stable")):
                ls, lw = styles[st]
                ax.plot(xs, ys, linestyle=ls, linewidth=lw, color=color)
                seen_styles.add(st if br.get("stable") is not None else "plain")
        if label and len(groups) > 1:  # a colour swatch: the branch's style varies along it, keyed below
            handles.append(Patch(facecolor=color, edgecolor=color, label=label))
    key_color = colors[0] if len(groups) == 1 else "0.3"
    for st, text in ((True, "stable"), (False, "unstable"), (None, "no stability verdict")):
        if st in seen_styles:  # the styles drawn (none for branches without stability)
            handles.append(Line2D([], [], linestyle=styles[st][0], linewidth=styles[st][1], color=key_color,
                                  label=text))
    if "torus" in seen_styles:
        handles.append(Line2D([], [], linewidth=5 * styles[True][1], alpha=0.22, color=key_color,
                              label="quasi-periodic (torus)"))
    points = [dict(sp) for sp in special
              if sp.get("kind") in SPECIAL and np.isfinite(sp["x"]) and np.isfinite(sp["y"])]
    ms = 0.9 * float(matplotlib.rcParams["lines.markersize"])
    for sp in points:
        sp["located"] = bool(sp.get("located", True))
        ax.plot(sp["x"], sp["y"], zorder=5, **point_marker(sp["kind"], sp["located"], ms))
    return handles, points, ms


def draw_bifurcation_diagram(ax, branches, special, parameter: str, measure: str, *, units=None, labels=None,
                             symbols=None, title: str | None = None, extra=None, vertical_parameter: bool = False,
                             log_y: bool = False, table: bool = True, short_names: bool | None = None):
    """Draw a bifurcation diagram into ``ax``.

    The numbered table of special points stands right of the axes: a figure
    with ``constrained`` layout (:func:`contin.output.figures.new_figure`,
    ``plt.subplots(layout="constrained")``) makes room for it. The numbers
    are placed for the figure's size at the call.

    Parameters
    ----------
    ax : matplotlib Axes
    branches : list of dict
        Each with ``x`` (P,), ``y`` (P,) (plotted coordinates), ``stable``
        (None, or P flags True, False or None where a point has no
        verdict), and optionally ``nu``, ``id``, ``group`` (branches of one
        group share colour and legend entry: the two halves of a branch
        followed both ways) and ``label`` (the legend's name; None for none;
        made from ``nu`` when absent). With one group there is no branch entry.
    special : list of dict
        Each with ``x``, ``y``, ``kind`` and optionally ``parameter`` (the
        value the table gives; ``x``, or ``y`` with ``vertical_parameter``)
        and ``located`` (False: drawn with an open marker and named
        "(not located)" in the table and legend; True by default).
    parameter, measure : str
        Names of the parameter and the plotted measure (axis labels from
        :func:`contin.output.labels.axis_label`).
    units, labels, symbols : dict, optional
        The scene's ``output.units`` and ``output.labels``, the model's symbols.
    title : str, optional
    extra : callable, optional
        ``extra(ax)`` draws more (before the legend is made).
    vertical_parameter : bool
        The parameter is on the y axis and the measure on the x axis (a restoring-force curve).
    log_y : bool
        Logarithmic y axis.
    table : bool
        Number the special points and list them beside the axes (else they are marked and their kinds
        named in the legend, and nothing is drawn outside the axes).
    short_names : bool, optional
        Short kind names in the table (default: when the figure is narrower than 5 inches).

    Returns
    -------
    Axes
    """
    handles, points, ms = draw_curves(ax, branches, special)
    if log_y:
        ax.set_yscale("log")
    if extra is not None:
        extra(ax)
    xname, yname = (measure, parameter) if vertical_parameter else (parameter, measure)
    ax.set_xlabel(axis_label(xname, units, labels, symbols, "parameter" if xname == parameter else None))
    ax.set_ylabel(axis_label(yname, units, labels, symbols, "parameter" if yname == parameter else None))
    if title:
        ax.set_title(title)
    if points and not table:  # no table to name the kinds: the legend does, once per kind drawn
        for kind, located in dict.fromkeys((sp["kind"], sp["located"]) for sp in points):
            handles.append(Line2D([], [], label=kind_name(kind, located), **point_marker(kind, located, ms)))
    own = [h for h in ax.get_legend_handles_labels()[0] if h not in handles]
    legend = ax.legend(handles=handles + own, loc="best") if handles or own else None
    if points and table:
        if short_names is None:
            short_names = ax.figure.get_size_inches()[0] < 5.0
        for sp in points:
            sp.setdefault("parameter", sp["y"] if vertical_parameter else sp["x"])
        # the table first (it narrows the axes), then the numbers from the final layout, then the table's rows
        rows = special_table(ax, points, parameter, symbols, short_names, units)
        place_numbers(ax, points, legend, ms)
        fill_table(rows, points, short_names)
    return ax


# ---------------------------------------------------------------- numbers and table
#: radii (points) of the rings of places tried for a number, beyond the places beside its point
_RINGS = (14.0, 22.0, 32.0, 44.0, 60.0, 80.0)
#: directions tried on each ring (degrees, the first preferred)
_ANGLES = (45, 135, -45, -135, 90, -90, 0, 180, 22.5, 157.5, -22.5, -157.5, 67.5, 112.5, -67.5, -112.5)


def _fontsize() -> float:
    """Size (points) of the numbers and the table: the legend's."""
    return float(matplotlib.font_manager.FontProperties(size=matplotlib.rcParams["legend.fontsize"])
                 .get_size_in_points())


def laid_out_renderer(fig):
    """The renderer of ``fig`` after its layout has run (the axes in their final place)."""
    fig.draw_without_rendering()  # runs the layout: the axes have their final place
    return text_renderer(fig)


def text_renderer(fig):
    """A renderer of ``fig`` as it stands, its layout not run: enough to measure texts, whose extents do not
    depend on where the axes are."""
    get = getattr(fig.canvas, "get_renderer", None)
    return get() if get is not None else fig._get_renderer()


def _display_points(ax, x, y) -> np.ndarray:
    """Data to display coordinates in points (K, 2)."""
    xy = ax.transData.transform(np.column_stack([np.asarray(x, float), np.asarray(y, float)]))
    return xy * 72.0 / ax.figure.dpi


def _clusters(p: np.ndarray, threshold: float) -> list:
    """Groups of the points ``p`` (K, 2) (display, points) within ``threshold`` of each other in x and y,
    each point joining the first group all of whose points are that close (no chains)."""
    groups = []
    for i in np.lexsort((p[:, 1], p[:, 0])):
        for g in groups:
            if np.all(np.abs(p[g] - p[i]) < threshold):
                g.append(int(i))
                break
        else:
            groups.append([int(i)])
    return groups


def _numbering(points, p: np.ndarray, groups) -> list:
    """Number the points group after group from left to right; labels ``[(text, member indices)]``
    (``3``, ``3,4``, ``3-5``), and ``number`` in each point."""
    ordered = sorted(groups, key=lambda c: (min(p[c, 0]), min(p[c, 1])))
    out, k = [], 1
    for c in ordered:
        c = sorted(c, key=lambda i: (points[i]["parameter"], points[i]["y"]))
        text = str(k) if len(c) == 1 else f"{k},{k + 1}" if len(c) == 2 else f"{k}\u2013{k + len(c) - 1}"
        for i in c:
            points[i]["number"] = k
            k += 1
        out.append((text, c))
    return out


def _value_texts(values) -> list:
    """Values with 5 significant digits; up to 7 for those that would read as another one does. Two values
    alike to 7 digits are one point found twice (on two branches, say): they are not told apart, but each
    still from the other values."""
    v = [float(x) for x in values]
    twice = [[f"{x:.7g}" == f"{y:.7g}" for y in v] for x in v]

    def clashes(texts):
        return [i for i, t in enumerate(texts) if any(t == u and v[i] != v[k] and not twice[i][k]
                                                      for k, u in enumerate(texts) if k != i)]

    digits = [5] * len(v)
    for _ in range(2):
        for i in clashes([f"{x:.{d}g}" for x, d in zip(v, digits)]):
            digits[i] += 1
    return [f"{x:.{d}g}".replace("-", "\u2212") for x, d in zip(v, digits)]


def special_table(ax, points, parameter, symbols, short_names, units) -> list:
    """The list of the special points beside the axes (right of it, from its top), one row per point.

    Returns the rows' artists ``(marker, kind, value)``, filled by :func:`fill_table` once the points
    are numbered: the columns are as wide as their widest entry, whatever the order.
    """
    fig = ax.figure
    fontsize = _fontsize()
    renderer = text_renderer(fig)  # the widths of texts alone
    values = _value_texts([sp["parameter"] for sp in points])
    for sp, v in zip(points, values):
        sp["value_text"] = v
    names = [kind_name(sp["kind"], sp.get("located", True), short_names) for sp in points]
    unit = (units or {}).get(parameter)
    head = math(parameter, symbols, "parameter") + (f" [{unit}]" if unit else "")

    def width(text):
        t = matplotlib.text.Text(0, 0, text, fontsize=fontsize, figure=fig)
        return t.get_window_extent(renderer).width * 72.0 / fig.dpi

    pitch = 1.45 * fontsize
    w_num = width(str(len(points)))
    w_name = max(width(n) for n in names)
    w_val = max(width(v) for v in values)
    ms = 0.8 * fontsize
    # columns (points from the axes' right edge): number (right-aligned), marker, kind, value (right-aligned);
    # the value's heading may reach over the kind column
    x_num = 10.0 + w_num
    x_mark = x_num + 4.0 + ms / 2
    x_name = x_mark + ms / 2 + 4.0
    x_val = x_name + max(w_name + 6.0 + w_val, width(head))
    rows_per_column = max(int((fig.get_size_inches()[1] * 72.0 * 0.78) // pitch) - 1, 4)
    col_width = x_val + 4.0
    # points from the axes' top right corner (following the figure's dpi, which saving may change)
    corner = Affine2D().scale(1.0 / 72.0) + fig.dpi_scale_trans + ScaledTranslation(1.0, 1.0, ax.transAxes)
    rows = []
    for r in range(len(points)):
        c, row = divmod(r, rows_per_column)
        dx, y = c * col_width, -pitch * (row + 1.5)
        if row == 0:
            _table_text(ax, corner, dx + x_val, -pitch * 0.5, head, "right", fontsize)
            rule = Line2D([dx + x_num - w_num, dx + x_val], [-pitch, -pitch], lw=0.5, color="0.3", transform=corner,
                          clip_on=False)
            rule.set_gid("special-table")
            ax.add_line(rule)
        _table_text(ax, corner, dx + x_num, y, str(r + 1), "right", fontsize)
        mark = Line2D([dx + x_mark], [y], marker="o", ms=ms, mfc="white", mec="k", mew=0.7, linestyle="none",
                      transform=corner, clip_on=False)
        mark.set_gid("special-table")
        ax.add_line(mark)
        rows.append((mark, _table_text(ax, corner, dx + x_name, y, max(names, key=len), "left", fontsize),
                     _table_text(ax, corner, dx + x_val, y, max(values, key=len), "right", fontsize)))
    return rows


def fill_table(rows, points, short_names) -> None:
    """Write each point into the row of its number."""
    for sp in points:
        mark, name, value = rows[sp["number"] - 1]
        style = point_marker(sp["kind"], sp.get("located", True))
        mark.set_marker(style["marker"])
        mark.set_fillstyle(style["fillstyle"])
        mark.set_markerfacecolor(style["mfc"])
        mark.set_markeredgecolor(style["mec"])
        name.set_text(kind_name(sp["kind"], sp.get("located", True), short_names))
        value.set_text(sp["value_text"])


def _table_text(ax, corner, x, y, text, ha, fontsize):
    t = ax.text(x, y, text, ha=ha, va="center", fontsize=fontsize, clip_on=False,
                transform=corner)
    t.set_gid("special-table")
    return t


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def place_numbers(ax, points, legend, ms, numbering=None, renderer=None) -> None:
    """Number the points and put each label where it covers no other label, marker or the legend,
    and as little of the curves as it can: beside its point, else farther out with a leader line.

    Points whose markers touch share a label; a label that finds no free place joins the
    nearest other group, and the search starts again. ``numbering(points, p, groups)`` makes the
    labels (default :func:`_numbering`: left to right; the panels' figure gives numbers of its own).
    ``renderer``: of the figure's final layout, when the caller has run it (else it is run here).
    """
    fig = ax.figure
    renderer = renderer or laid_out_renderer(fig)  # the final layout: the distances are those of the saved figure
    fontsize = _fontsize()
    scale = 72.0 / fig.dpi
    frame = np.array(ax.get_window_extent(renderer).extents) * scale
    blocked = []
    if legend is not None:
        # "best" would move the legend once the numbers are there: keep it where it is now
        (getattr(legend, "set_loc", None) or legend._set_loc)(_frozen_loc(ax, legend, renderer))
        blocked.append(tuple(np.array(legend.get_window_extent(renderer).extents) * scale + [-2, -2, 2, 2]))
    p = _display_points(ax, [s["x"] for s in points], [s["y"] for s in points])
    r_mark = ms / 2 + 1.0
    groups = _clusters(p, 2 * r_mark)
    curve = _curve_points(ax)
    while True:
        numbers = (numbering or _numbering)(points, p, groups)
        spots = _search(numbers, p, r_mark, frame, blocked, curve, fig, renderer, fontsize, scale)
        failed = next((k for k, spot in enumerate(spots) if spot is None), None)
        if failed is None or len(numbers) == 1:
            break
        lost = numbers[failed][1]
        centre = p[lost].mean(axis=0)
        rest = [g for _, g in numbers if g is not lost]
        nearest = min(rest, key=lambda g: float(np.min(np.linalg.norm(p[g] - centre, axis=1))))
        groups = [g + lost if g is nearest else g for g in rest]
    for (text, members), spot in zip(numbers, spots):
        if spot is None:  # a single label with no free place at all: beside its points
            spot = p[members].mean(axis=0) + np.array([r_mark + 6.0, r_mark + 4.0])
        c, box = spot, None
        w, h = _label_size(text, fig, renderer, fontsize, scale)
        box = (c[0] - w / 2, c[1] - h / 2, c[0] + w / 2, c[1] + h / 2)
        # a leader line to the nearest of the label's points, unless the label is right beside it
        near = p[members][np.argmin(np.linalg.norm(p[members] - c, axis=1))]
        gap = np.hypot(max(box[0] - near[0], 0.0, near[0] - box[2]), max(box[1] - near[1], 0.0, near[1] - box[3]))
        leader = gap > r_mark + 2.5
        anchor = near if leader else p[members].mean(axis=0)
        props = dict(arrowstyle="-", lw=0.6, color="0.35", shrinkA=0.0, shrinkB=r_mark) if leader else None
        ann = ax.annotate(text, tuple(ax.transData.inverted().transform(anchor / scale)),
                          xytext=(float(c[0] - anchor[0]), float(c[1] - anchor[1])), textcoords="offset points",
                          ha="center", va="center", fontsize=fontsize, arrowprops=props, annotation_clip=False,
                          zorder=6, bbox=dict(boxstyle="square,pad=0.1", fc="white", ec="none", alpha=0.85))
        ann.set_in_layout(False)
        ann.set_gid("special-number")


def _label_size(text, fig, renderer, fontsize, scale) -> tuple:
    """Width and height (points) a label takes: its text, its white box and a margin."""
    ext = matplotlib.text.Text(0, 0, text, fontsize=fontsize, figure=fig).get_window_extent(renderer)
    return ext.width * scale + 3.0, ext.height * scale + 2.0


def _search(numbers, p, r_mark, frame, blocked, curve, fig, renderer, fontsize, scale) -> list:
    """The centre (points) of each label of ``numbers``, or None where no place is free, greedily in turn."""
    markers = [(q[0] - r_mark, q[1] - r_mark, q[0] + r_mark, q[1] + r_mark) for q in p]
    placed, out = [], []
    for text, members in numbers:
        w, h = _label_size(text, fig, renderer, fontsize, scale)
        anchor = p[members].mean(axis=0)
        spread = float(np.max(np.linalg.norm(p[members] - anchor, axis=1))) + r_mark
        others = [m for k, m in enumerate(markers) if k not in members]
        best = None
        for ring, radius in enumerate((None,) + _RINGS):
            for n_angle, angle in enumerate(_ANGLES):
                u = np.array([_math.cos(_math.radians(angle)), _math.sin(_math.radians(angle))])
                if radius is None:  # beside the point: the box just clears the marker(s)
                    k = min(abs(w / 2 / u[0]) if abs(u[0]) > 1e-9 else np.inf,
                            abs(h / 2 / u[1]) if abs(u[1]) > 1e-9 else np.inf)
                    c = anchor + (spread + 1.0 + k) * u
                else:
                    c = anchor + (spread + radius) * u
                box = (c[0] - w / 2, c[1] - h / 2, c[0] + w / 2, c[1] + h / 2)
                if box[0] < frame[0] or box[2] > frame[2] or box[1] < frame[1] or box[3] > frame[3]:
                    continue
                if any(_overlap(box, b) for b in blocked + placed + markers):
                    continue
                covered = _inside(curve, (box[0] - 1.0, box[1] - 1.0, box[2] + 1.0, box[3] + 1.0))
                cost = 4.0 * covered + 3.0 * ring + 0.05 * n_angle
                if radius is not None:  # a leader line should cross no label and no other marker
                    line = anchor + np.outer(np.linspace(0.0, 1.0, 24), c - anchor)
                    cost += 10.0 * sum(_inside(line, b) > 0 for b in placed + others + blocked)
                if best is None or cost < best[0]:
                    best = (cost, c, covered)
            if best is not None and best[2] == 0:  # a place that covers no curve: no need to go farther
                break
        out.append(None if best is None else best[1])
        if best is not None:
            c = best[1]
            placed.append((c[0] - w / 2, c[1] - h / 2, c[0] + w / 2, c[1] + h / 2))
    return out


def _inside(q: np.ndarray, box) -> int:
    """How many of the points ``q`` (K, 2) lie inside ``box``."""
    if not q.size:
        return 0
    return int(np.count_nonzero((q[:, 0] > box[0]) & (q[:, 0] < box[2]) & (q[:, 1] > box[1]) & (q[:, 1] < box[3])))


def _frozen_loc(ax, legend, renderer):
    """The legend's place as it is drawn now (``best`` would move it once the numbers are there)."""
    bb = legend.get_window_extent(renderer).transformed(ax.transAxes.inverted())
    return (float(bb.x0), float(bb.y0))


def _curve_points(ax) -> np.ndarray:
    """Points (K, 2) every two points (display, in points) along the curves drawn in the axes."""
    out = []
    for line in ax.get_lines():
        if line.get_gid() == "special-table" or line.get_linestyle() in ("None", "none", " ", ""):
            continue
        xy = line.get_xydata()
        if len(xy) < 2 or line.get_transform() != ax.transData:
            continue
        q = ax.transData.transform(np.asarray(xy, float)) * 72.0 / ax.figure.dpi
        q = q[np.all(np.isfinite(q), axis=1)]
        if len(q) < 2:
            continue
        seg = np.diff(q, axis=0)
        n = np.maximum(np.ceil(np.hypot(seg[:, 0], seg[:, 1]) / 2.0).astype(int), 1)
        for a, d, k in zip(q[:-1], seg, n):
            out.append(a + np.outer(np.arange(k) / k, d))
        out.append(q[-1:])
    return np.vstack(out) if out else np.zeros((0, 2))


def bifurcation_diagram(branches, special, parameter: str, measure: str, path: Path, *, units=None, labels=None,
                        symbols=None, title: str | None = None, extra=None, formats=("png",), dpi=None,
                        style: str | None = None, **options) -> list[str]:
    """Draw a bifurcation diagram (:func:`draw_bifurcation_diagram`) and write it in every format.

    Parameters
    ----------
    path : Path
        The files' path without suffix (``outdir / "bifurcation_diagram"``).
    formats, dpi, style
        The scene's ``output.formats``, ``output.dpi`` and ``output.style``.
    **options
        Passed to :func:`draw_bifurcation_diagram`.

    Returns
    -------
    list of str
        The file names written.
    """
    with figure_style(style):
        default = tuple(matplotlib.rcParams["figure.figsize"]) == tuple(matplotlib.rcParamsDefault["figure.figsize"])
        fig = new_figure((7.6, 4.6) if default else None)  # the default size, widened for the table
        ax = fig.add_subplot()
        draw_bifurcation_diagram(ax, branches, special, parameter, measure, units=units, labels=labels,
                                 symbols=symbols, title=title, extra=extra, **options)
        return save_figure(fig, path, formats, dpi)
