"""A bifurcation diagram of several measures in stacked panels, with a zoom window beside them.

``output.panels`` draws each measure in its own panel, the panels stacked
over one parameter axis; ``output.zoom`` adds a column of the same panels
over a window of the parameter (:class:`contin.output.panel_options.ZoomWindow`),
so that a narrow region (a subharmonic window) reads beside the whole range.
Each panel draws its branches and special points as the single diagram does
(:func:`contin.output.plotting.draw_curves`); the special points carry one
numbering over the whole figure (by parameter value, so a point has the same
number in every panel) and one table beside the top right panel lists them.
The window is shaded in the whole-range panels. The legend stands in one
whole-range panel: the one where it hides the least of the curves.
"""

from __future__ import annotations

import re

import matplotlib
import numpy as np
from matplotlib.lines import Line2D

from contin.output.figures import figure_style, new_figure, save_figure
from contin.output.labels import axis_label
from contin.output.panel_options import ZoomWindow
from contin.output.plotting import (
    bifurcation_diagram,
    draw_curves,
    fill_table,
    kind_name,
    laid_out_renderer,
    place_numbers,
    point_marker,
    special_table,
)

__all__ = ["draw_panels", "panel_diagram", "panel_figure_size"]

#: the default figure (``contin`` style): inches of the whole-range column, the zoom column, one panel's height
_WIDTH, _ZOOM_WIDTH, _ROW, _FRAME = 7.6, 3.6, 2.55, 1.0
#: kinds drawn as markers only (named in the legend), neither numbered nor listed in the table
UNNUMBERED = ("grazing",)
#: gid of the shaded window in the whole-range panels (not a curve: the numbers may cover it)
WINDOW_GID = "zoom-window"


def panel_figure_size(rows: int, zoom: bool) -> tuple[float, float]:
    """The figure's size (inches) for ``rows`` panels, with or without the zoom column.

    The ``contin`` style's default figure (7.6 x 4.6 in with its table) grows by a column for the
    zoom and by a panel's height per further panel; another style's ``figure.figsize`` grows alike.
    """
    default = tuple(matplotlib.rcParams["figure.figsize"]) == tuple(matplotlib.rcParamsDefault["figure.figsize"])
    w, h = (_WIDTH, 4.6) if default else tuple(matplotlib.rcParams["figure.figsize"])
    width = w * (1.0 + (_ZOOM_WIDTH / _WIDTH if zoom else 0.0))
    height = h if rows == 1 else h * (_FRAME + _ROW * rows) / 4.6
    return float(width), float(height)


def _label_points() -> float:
    """The size (points) of the axis labels in the current style."""
    return float(matplotlib.font_manager.FontProperties(size=matplotlib.rcParams["axes.labelsize"])
                 .get_size_in_points())


def _number_text(numbers) -> str:
    """``1``, ``1,2``, ``1–3``, ``1–3,7``: runs of three or more consecutive numbers joined by a dash."""
    numbers = sorted(numbers)
    runs, start = [], 0
    for i in range(1, len(numbers) + 1):
        if i == len(numbers) or numbers[i] != numbers[i - 1] + 1:
            runs.append(numbers[start:i])
            start = i
    parts = []
    for r in runs:
        parts.extend([f"{r[0]}\u2013{r[-1]}"] if len(r) > 2 else [str(k) for k in r])
    return ",".join(parts)


def _given_numbers(points, p, groups) -> list:
    """Labels of groups of points numbered beforehand (``number`` of each point), lowest number first."""
    ordered = sorted(groups, key=lambda g: min(points[i]["number"] for i in g))
    return [(_number_text([points[i]["number"] for i in g]), sorted(g, key=lambda i: points[i]["number"]))
            for g in ordered]


def _visible_length(text: str) -> int:
    """About how many characters ``text`` shows: a mathtext command (``\\Omega``) is one, ``$`` none."""
    return len(re.sub(r"\\[A-Za-z]+|[${}_^]", lambda m: "x" if m.group(0).startswith("\\") else "", text))


def _wrapped(label: str, room: float) -> str:
    """``label`` broken into lines of at most ``room`` shown characters, at spaces outside mathtext
    (a long label beside a low panel would run into its neighbour's)."""
    if _visible_length(label) <= room:
        return label
    words, inside = [""], False
    for ch in label:  # split at the spaces outside $...$
        if ch == "$":
            inside = not inside
        if ch == " " and not inside:
            words.append("")
        else:
            words[-1] += ch
    lines = [words[0]]
    for w in words[1:]:
        if _visible_length(lines[-1] + " " + w) <= room:
            lines[-1] += " " + w
        else:
            lines.append(w)
    return "\n".join(lines)


def _fit_window(ax, branches, window, limits) -> None:
    """The zoom's limits: x the window, y ``limits`` or the curves' span inside the window with a margin."""
    lo, hi = window
    ax.set_xlim(lo, hi)
    if limits is not None:
        ax.set_ylim(*limits)
        return
    ys = []
    for br in branches:
        x, y = np.asarray(br["x"], float), np.asarray(br["y"], float)
        ok = np.isfinite(x) & np.isfinite(y)
        x, y = x[ok], y[ok]
        ys.append(y[(x >= lo) & (x <= hi)])
        for edge in (lo, hi):  # where a curve crosses the window's edge between two of its points
            k = np.nonzero(np.diff(np.sign(x - edge)) != 0)[0]
            ys.append(y[k] + (y[k + 1] - y[k]) * (edge - x[k]) / np.where(x[k + 1] != x[k], x[k + 1] - x[k], 1.0))
    y = np.concatenate(ys) if ys else np.zeros(0)
    if not y.size:  # nothing inside the window: the whole range's limits
        return
    a, b = float(np.min(y)), float(np.max(y))
    pad = 0.08 * (b - a) if b > a else max(0.05 * abs(a), 1e-3)
    ax.set_ylim(a - pad, b + pad)


def _visible(ax, points) -> list:
    """The points inside the axes' limits."""
    (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
    return [sp for sp in points if x0 <= sp["x"] <= x1 and y0 <= sp["y"] <= y1]


#: where a legend may stand in a panel, in the order of preference among equals
_LEGEND_PLACES = ("upper left", "upper right", "lower left", "lower right", "center left", "center right",
                  "upper center", "lower center")
#: a special point's marker hidden under the legend counts as this much hidden curve (pixels)
_MARKER_WEIGHT = 20.0
#: the room (points) around a legend where a special point's marker counts as hidden: its number's label
#: would have to go elsewhere, often far, with a long leader line
_LABEL_ROOM = 14.0
#: the gap (points) between the special points' table and a legend put under it
_LEGEND_GAP = 24.0


def _hidden(ax, box) -> float:
    """The length (pixels) of the curves of ``ax`` inside the display box ``(x0, y0, x1, y1)``, markers
    counted as :data:`_MARKER_WEIGHT` each within :data:`_LABEL_ROOM` of it (their number labels need the room)."""
    x0, y0, x1, y1 = box
    room = _LABEL_ROOM * ax.figure.dpi / 72.0
    length = 0.0
    for line in ax.get_lines():
        xy = ax.transData.transform(np.asarray(line.get_xydata(), dtype=float))
        if line.get_linestyle() in ("None", "none", "") or len(xy) < 2:  # markers (NaN compares False: outside)
            inside = ((xy[:, 0] >= x0 - room) & (xy[:, 0] <= x1 + room) & (xy[:, 1] >= y0 - room)
                      & (xy[:, 1] <= y1 + room))
            length += _MARKER_WEIGHT * float(np.sum(inside))
            continue
        a, b = xy[:-1], xy[1:]
        ok = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
        for p, q in zip(a[ok], b[ok]):  # points a pixel or so apart along each segment
            d = float(np.hypot(*(q - p)))
            t = np.linspace(0.0, 1.0, int(min(d, 4000)) + 2)
            x, y = p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])
            length += d * float(np.mean((x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)))
    return length


def _legend_panel(fig, column, entries):
    """The panel of ``column`` (the whole-range panels, top first) and the place in it where the legend of
    ``entries`` hides the least of the curves (:func:`_hidden`; the first of equals in :data:`_LEGEND_PLACES`
    and from the top); the legend is put there. Returns the panel, the length hidden and the renderer of the
    layout (a legend inside a panel leaves it as it is)."""
    probe = column[0].legend(handles=entries, loc="upper right")
    renderer = laid_out_renderer(fig)
    lb, ab = probe.get_window_extent(renderer), column[0].get_window_extent(renderer)
    w, h, pad = lb.width, lb.height, ab.x1 - lb.x1  # the legend's size and its gap to the frame
    probe.remove()
    best = None
    for ax in column:
        a = ax.get_window_extent(renderer)
        for place in _LEGEND_PLACES:
            x0 = {"left": a.x0 + pad, "right": a.x1 - pad - w}.get(place.split()[-1], 0.5 * (a.x0 + a.x1 - w))
            y0 = {"upper": a.y1 - pad - h, "lower": a.y0 + pad}.get(place.split()[0], 0.5 * (a.y0 + a.y1 - h))
            score = _hidden(ax, (x0, y0, x0 + w, y0 + h))
            if best is None or score < best[0]:
                best = (score, ax, place)
    best[1].legend(handles=entries, loc=best[2])
    return best[1], best[0], renderer


def _legend_below_table(fig, holder, rows, entries, renderer):
    """Put the legend of ``entries`` under the special points' table (``rows``, beside ``holder``; ``renderer``
    of the figure's layout as it stands) where the figure has room for it there (the layout widens the table's
    column for a wider legend); the renderer of the new layout if it was put there, else None."""
    bottom = min(name.get_window_extent(renderer).y0 for _, name, _ in rows)
    frame = holder.get_window_extent(renderer)
    y = (bottom - _LEGEND_GAP * fig.dpi / 72.0 - frame.y0) / frame.height
    legend = holder.legend(handles=entries, loc="upper left", bbox_to_anchor=(1.0, y), frameon=False)
    renderer = laid_out_renderer(fig)
    if legend.get_window_extent(renderer).y0 >= fig.bbox.y0:
        return renderer
    legend.remove()
    return None


def draw_panels(fig, panels, parameter: str, *, zoom: ZoomWindow | None = None, units=None, labels=None,
                symbols=None, title: str | None = None, table: bool = True, short_names: bool | None = None):
    """Draw stacked panels of several measures, and a zoom column, into ``fig``.

    Parameters
    ----------
    fig : matplotlib Figure
        With ``constrained`` layout (:func:`contin.output.figures.new_figure`): it makes room for the table.
    panels : sequence of (str, list of dict, list of dict)
        ``(measure, branches, special)`` of each panel, top to bottom, as
        :func:`contin.output.plotting.draw_bifurcation_diagram` takes them;
        the special points of every panel are the same points in the same
        order (matched by their place in the list), each panel with its own ``y``.
    parameter : str
        The continuation parameter (the shared x axis).
    zoom : ZoomWindow, optional
        Adds a column of the same panels over ``zoom.range`` (its y-limits
        ``zoom.limits(measure)``, else fitted to the curves in the window).
    units, labels, symbols : dict, optional
        The scene's ``output.units`` and ``output.labels``, the model's symbols.
    title : str, optional
        The figure's title.
    table : bool
        Number the special points and list them beside the top right panel (else they are marked only).
    short_names : bool, optional
        Short kind names in the table (default: when the figure is narrower than 5 inches).

    Returns
    -------
    numpy.ndarray of Axes
        (rows, 1), or (rows, 2) with the zoom: the whole range left, the window right.
    """
    if not panels:
        raise ValueError("panels: expected at least one (measure, branches, special)")
    rows, cols = len(panels), 2 if zoom is not None else 1
    # a last, empty column as tall as the figure holds the table: beside one panel it would stretch that row
    grid = fig.add_gridspec(rows, cols + 1, width_ratios=[_WIDTH - 2.6, _ZOOM_WIDTH - 0.6][:cols] + [0.01])
    axes = np.empty((rows, cols), dtype=object)
    for c in range(cols):
        for r in range(rows):
            axes[r, c] = fig.add_subplot(grid[r, c], sharex=axes[0, c] if r else None)
    holder = fig.add_subplot(grid[:, cols])
    holder.axis("off")
    legend, entries = None, []
    drawn = []  # (ax, points, ms) of every panel
    # the characters a y label may take along one panel (the frame and the x axis take about an inch)
    room = max((fig.get_size_inches()[1] - 1.0) / rows * 72.0 / (0.55 * _label_points()), 8.0)
    for r, (measure, branches, special) in enumerate(panels):
        for c in range(cols):
            ax = axes[r, c]
            # each point keeps its place in ``special``: the same point in every panel
            handles, points, ms = draw_curves(ax, branches, [dict(sp, _k=k) for k, sp in enumerate(special)])
            if c == 1:
                _fit_window(ax, branches, zoom.range, zoom.limits(measure))
            elif zoom is not None:  # the window, shaded behind the curves
                band = ax.axvspan(*zoom.range, color="0.5", alpha=0.12, lw=0, zorder=0)
                band.set_gid(WINDOW_GID)
            ax.set_ylabel(_wrapped(axis_label(measure, units, labels, symbols), room) if c == 0 else "")
            if r == rows - 1:
                ax.set_xlabel(axis_label(parameter, units, labels, symbols, "parameter"))
            else:
                ax.tick_params(labelbottom=False)
            if r == 0 and c == 0:
                own = [h for h in ax.get_legend_handles_labels()[0] if h not in handles]
                entries = handles + own
            drawn.append((ax, points, ms))
    if zoom is not None:  # tie the column to the shading
        axes[0, 1].set_title("zoom on the shaded window", fontsize=matplotlib.rcParams["axes.labelsize"])
    if title:
        fig.suptitle(title, fontsize=matplotlib.rcParams["axes.titlesize"])
    # one numbering for the figure: by parameter value, the same point the same number in every panel
    union = {}
    for _, points, _ in drawn:
        for sp in points:
            sp.setdefault("parameter", sp["x"])
            union.setdefault(sp["_k"], sp)
    # grazing points (a bouncing orbit has dozens) keep their markers, named in the legend, not numbered
    listed = sorted((sp for sp in union.values() if sp["kind"] not in UNNUMBERED),
                    key=lambda sp: (sp["parameter"], sp["_k"]))
    if table and entries and len(listed) < len(union):
        entries = entries + [Line2D([], [], label=kind_name(k), **{**point_marker(k, True), "linestyle": "none"})
                             for k in dict.fromkeys(sp["kind"] for sp in union.values() if sp["kind"] in UNNUMBERED)]
    numbered = bool(table and union and listed)
    if numbered:
        number = {sp["_k"]: n + 1 for n, sp in enumerate(listed)}
        for i, (ax, points, ms) in enumerate(drawn):
            points = [sp for sp in points if sp["_k"] in number]
            drawn[i] = (ax, points, ms)
            for sp in points:
                sp["number"] = number[sp["_k"]]
        if short_names is None:
            short_names = fig.get_size_inches()[0] < 5.0
        # the table first (it narrows the axes), then the legend and the numbers from the final layout, then the
        # table's rows
        rows_ = special_table(holder, listed, parameter, symbols, short_names, units)
    home, legend, renderer = axes[0, 0], None, None
    if entries:
        home, hidden, laid_out = _legend_panel(fig, axes[:, 0], entries)
        legend = home.get_legend()
        # where every place in the panels hides some curve, under the table if the figure has room there
        if hidden > 0 and numbered:
            renderer = _legend_below_table(fig, holder, rows_, entries, laid_out)
            if renderer is not None:
                legend.remove()
                home, legend = None, None
        else:  # a legend inside a panel leaves the layout as it was laid out
            renderer = laid_out
    if not numbered:
        return axes
    if renderer is None:  # the final layout (the numbers take no room in it): run once for every panel
        renderer = laid_out_renderer(fig)
    for ax, points, ms in drawn:
        shown = _visible(ax, points)
        if shown:
            place_numbers(ax, shown, legend if ax is home else None, ms, numbering=_given_numbers,
                           renderer=renderer)
    fill_table(rows_, listed, short_names)
    return axes


def panel_diagram(panels, parameter: str, path, *, zoom=None, units=None, labels=None, symbols=None,
                  title: str | None = None, formats=("png",), dpi=None, style: str | None = None) -> list[str]:
    """Draw :func:`draw_panels` into a figure of its own and write it in every format; one panel without a
    zoom is the single diagram (:func:`contin.output.plotting.bifurcation_diagram`).

    Parameters
    ----------
    panels, parameter, units, labels, symbols, title
        As :func:`draw_panels` takes them.
    path : Path
        The files' path without suffix (``outdir / "bifurcation_diagram"``).
    zoom : ZoomWindow or mapping, optional
        The window (a mapping is the scene's ``output.zoom``: :meth:`ZoomWindow.from_dict`).
    formats, dpi, style
        The scene's ``output.formats``, ``output.dpi`` and ``output.style``.

    Returns
    -------
    list of str
        The file names written.
    """
    if len(panels) == 1 and zoom is None:  # one measure, no window: the single diagram
        measure, branches, special = panels[0]
        return bifurcation_diagram(branches, special, parameter, measure, path, units=units, labels=labels,
                                   symbols=symbols, title=title, formats=formats, dpi=dpi, style=style)
    if zoom is not None and not isinstance(zoom, ZoomWindow):
        zoom = ZoomWindow.from_dict(zoom)
    with figure_style(style):
        fig = new_figure(panel_figure_size(len(panels), zoom is not None))
        draw_panels(fig, panels, parameter, zoom=zoom, units=units, labels=labels, symbols=symbols, title=title)
        return save_figure(fig, path, formats, dpi)
