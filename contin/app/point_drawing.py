"""Parts of the point figure (:func:`contin.app.pointplot.draw_point`): the contact elements' clearances,
their orbits, and the names of the spectrum's main lines placed where none covers another."""

from __future__ import annotations

import numpy as np

from contin.analyses.simulate import frequency_text
from contin.model.elements.gap import GapForce
from contin.model.elements.radial_gap import RadialGapForce
from contin.output.labels import axis_label, math

__all__ = ["contact_geometry", "contact_panels", "closed_period", "draw_contact", "draw_contact_panel",
           "fill_places", "legend_above", "name_lines"]

#: colour of a clearance (circle or stop line) and of the part of an orbit in contact
CLEARANCE_COLOR, CONTACT_COLOR = "0.35", "C3"


def contact_geometry(model, p) -> list[dict]:
    """The contact elements of ``model`` with their clearance at the parameters ``p``.

    Returns
    -------
    list of dict
        ``{"type": "radial_gap", "dofs": (i, j), "clearance": r}`` for a radial clearance of the dofs
        ``i, j`` and ``{"type": "gap", "dof": i, "clearance": g, "sides": "+"|"-"|"both"}`` for a stop on
        dof ``i``; in the order of the model's forces.
    """
    out = []
    for el in getattr(model, "forces", ()):
        if isinstance(el, RadialGapForce):
            out.append({"type": "radial_gap", "dofs": (int(el.ix), int(el.iy)),
                        "clearance": float(el.clearance.value(p))})
        elif isinstance(el, GapForce):
            out.append({"type": "gap", "dof": int(el.dof), "clearance": float(el.clearance.value(p)),
                        "sides": el.sides})
    return out


def _orbit_dofs(n: int) -> tuple:
    """The dofs of the orbit panel: the first two, or the first (a phase portrait) for one dof."""
    return (0, 1) if n >= 2 else (0,)


def _contact_dofs(c: dict) -> tuple:
    return tuple(c["dofs"]) if c["type"] == "radial_gap" else (c["dof"],)


def contact_panels(contacts, n: int) -> list[dict]:
    """The contacts that need an axes of their own: those whose dofs are not the orbit panel's."""
    shown = _orbit_dofs(n)
    return [c for c in contacts if not set(_contact_dofs(c)) <= set(shown)]


def closed_period(t, x, xd):
    """One period sampled without its end, closed: the first sample appended again at ``t = T``.

    ``t`` is uniform (``T = t[0] + S dt``); the time history then ends where it starts and the orbit
    has no gap.
    """
    t = np.asarray(t, float)
    step = (t[1] - t[0]) if t.size > 1 else 0.0
    return (np.append(t, t[0] + t.size * step), np.vstack([x, x[:1]]), np.vstack([xd, xd[:1]]))


def _in_contact(c: dict, x) -> np.ndarray:
    """Per sample, whether the contact's law acts (beyond the clearance)."""
    if c["type"] == "radial_gap":
        i, j = c["dofs"]
        return np.hypot(x[:, i], x[:, j]) > c["clearance"]
    u, g = x[:, c["dof"]], c["clearance"]
    return {"+": u > g, "-": u < -g}.get(c["sides"], np.abs(u) > g)


def _stops(c: dict) -> list:
    """The stop positions of a ``gap``: ``+g``, ``-g`` or both."""
    g = c["clearance"]
    return {"+": [g], "-": [-g]}.get(c["sides"], [-g, g])


def draw_contact(ax, c: dict, X, Y, x, *, horizontal: bool = True, label: bool = True) -> None:
    """Draw a contact's clearance into an orbit axes, and the part of the orbit ``(X, Y)`` in contact.

    Parameters
    ----------
    ax : matplotlib Axes
    c : dict
        An entry of :func:`contact_geometry`.
    X, Y : ndarray, shape (S,)
        The orbit as drawn in ``ax``.
    x : ndarray, shape (S, n)
        All displacements (which samples are in contact).
    horizontal : bool
        For a ``gap``: its dof is on the horizontal axis (the stops are vertical lines), else on the
        vertical axis.
    label : bool
        Name the clearance and the contact in the legend.
    """
    if c["type"] == "radial_gap":
        phi = np.linspace(0.0, 2.0 * np.pi, 361)
        r = c["clearance"]
        ax.plot(r * np.cos(phi), r * np.sin(phi), "--", color=CLEARANCE_COLOR, lw=1.0, zorder=3,
                label=f"clearance {r:.4g}" if label else None)
    else:
        stops = _stops(c)
        name = (f"stop at {stops[0]:.4g}" if len(stops) == 1 else f"stops at \u00b1{c['clearance']:.4g}")
        for k, s in enumerate(stops):
            (ax.axvline if horizontal else ax.axhline)(s, ls="--", color=CLEARANCE_COLOR, lw=1.0, zorder=3,
                                                       label=name.replace("-", "\u2212") if label and k == 0 else None)
    touch = _in_contact(c, x)
    if touch.any():  # the arcs beyond the clearance: a light band under the orbit, which stays visible
        ax.plot(np.where(touch, X, np.nan), np.where(touch, Y, np.nan), color=CONTACT_COLOR, lw=6.0, alpha=0.35,
                solid_capstyle="round", zorder=1.5, label="in contact" if label else None)


def draw_contact_panel(ax, c: dict, x, xd, dofs, *, units=None, labels=None, symbols=None) -> None:
    """A contact's own axes: the orbit of its dofs (a radial clearance) or the phase portrait of its
    dof (a stop), with the clearance and the part in contact."""
    if c["type"] == "radial_gap":
        i, j = c["dofs"]
        X, Y = x[:, i], x[:, j]
        ax.plot(X, Y, color="C0", lw=1.2, label="orbit")
        draw_contact(ax, c, X, Y, x)
        ax.set_xlabel(axis_label(dofs[i], units, labels, symbols))
        ax.set_ylabel(axis_label(dofs[j], units, labels, symbols))
        ax.set_aspect("equal", adjustable="box")  # the clearance a circle; the limits as set below
        ax.set_title(f"radial clearance of {math(dofs[i], symbols)}, {math(dofs[j], symbols)}")
    else:
        d = c["dof"]
        X, Y = x[:, d], xd[:, d]
        ax.plot(X, Y, color="C0", lw=1.2, label="phase portrait")
        draw_contact(ax, c, X, Y, x)
        ax.set_xlabel(axis_label(dofs[d], units, labels, symbols))
        ax.set_ylabel(axis_label(dofs[d] + "_dot", units, labels, symbols))
        ax.set_title(f"stop on {math(dofs[d], symbols)}")
    legend_above(ax)


def legend_above(ax, ncols: int = 2) -> None:
    """The legend in a band at the axes' top, above the curves: the y range grows to leave it free."""
    import matplotlib

    handles, _ = ax.get_legend_handles_labels()
    if not handles:
        return
    fig = ax.figure
    ax.relim()
    ax.autoscale_view()
    lo, hi = ax.get_ylim()
    slot = ax.get_position(original=True)
    height = slot.height * fig.get_figheight() * 72.0
    size = matplotlib.font_manager.FontProperties(size="small").get_size_in_points()
    rows = -(-len(handles) // ncols)
    band = min((rows * 1.45 * size + 8.0) / (0.8 * height), 0.6)  # the band's share of the new range
    hi = hi + (hi - lo) * band / (1.0 - band)
    ax.set_ylim(lo, hi)
    ax.legend(loc="upper center", ncols=ncols, fontsize="small", handlelength=1.6, columnspacing=1.0,
              borderaxespad=0.3)


def fill_places(axs) -> None:
    """Widen the x range of the equal-aspect axes among ``axs`` (orbits about a clearance circle) to the
    shape of their place in the laid-out figure, so that they fill it rather than leave it half empty."""
    equal = [ax for ax in axs if ax.get_aspect() == 1.0]
    if not equal:
        return
    equal[0].figure.draw_without_rendering()  # the layout: each axes' place
    for ax in equal:
        slot = ax.get_position(original=True)
        ratio = (slot.width * ax.figure.get_figwidth()) / (slot.height * ax.figure.get_figheight())
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        half = max(0.5 * (x1 - x0), 0.5 * (y1 - y0) * ratio)
        ax.set_xlim(0.5 * (x0 + x1) - half, 0.5 * (x0 + x1) + half)


def _boxes(ax, renderer, scale) -> np.ndarray:
    """Boxes (K, 4; points) of the stems and their heads drawn in the spectrum axes, and its legend."""
    out = []
    for coll in ax.collections:  # stems: vertical segments
        for seg in coll.get_segments():
            if len(seg):
                q = ax.transData.transform(np.asarray(seg, float)) * scale
                out.append((q[:, 0].min() - 1.5, q[:, 1].min(), q[:, 0].max() + 1.5, q[:, 1].max() + 2.5))
    for line in ax.get_lines():  # stem heads
        if line.get_marker() not in (None, "None", "none", ""):
            q = ax.transData.transform(np.asarray(line.get_xydata(), float)) * scale
            r = 0.5 * float(line.get_markersize()) + 1.0
            out.extend((a - r, b - r, a + r, b + r) for a, b in q if np.isfinite(a) and np.isfinite(b))
    legend = ax.get_legend()
    if legend is not None:
        out.append(tuple(np.array(legend.get_window_extent(renderer).extents) * scale + [-2, -2, 2, 2]))
    return np.array(out, float).reshape(-1, 4)


def _free(box, obstacles: np.ndarray) -> bool:
    if not len(obstacles):
        return True
    o = obstacles
    return not np.any((box[0] < o[:, 2]) & (o[:, 0] < box[2]) & (box[1] < o[:, 3]) & (o[:, 1] < box[3]))


def name_lines(ax, lines, w: str, fontsize: float = 8.0) -> list:
    """Name the spectrum's main lines, each where its name covers no other name, stem or the legend.

    A name stands above its line if it can, else beside its head, else higher up in the free space
    above the stems, tied to its line by a leader; a line with no free place for its name stays
    unnamed (its frequency is on the axis).

    Parameters
    ----------
    ax : matplotlib Axes
        The spectrum, drawn, its limits and legend set.
    lines : sequence of (float, float)
        Frequency / ``w`` and amplitude of each line, the most important first.
    w : str
        Mathtext of the frequency's symbol.

    Returns
    -------
    list of matplotlib.text.Annotation
    """
    fig = ax.figure
    fig.draw_without_rendering()  # the final layout: the places are those of the saved figure
    renderer = fig.canvas.get_renderer() if hasattr(fig.canvas, "get_renderer") else fig._get_renderer()
    scale = 72.0 / fig.dpi
    frame = np.array(ax.get_window_extent(renderer).extents) * scale
    obstacles = _boxes(ax, renderer, scale)
    pitch = 1.3 * fontsize
    names = []
    for fk, ak in lines:
        text = frequency_text(fk, w)
        probe = ax.text(0, 0, text, fontsize=fontsize)
        ext = probe.get_window_extent(renderer)
        probe.remove()
        tw, th = ext.width * scale + 2.0, ext.height * scale + 1.0
        px, py = ax.transData.transform((fk, ak)) * scale
        # (dx, dy) of the name's centre from the line's head, points; beside first, then higher with a leader
        spots = [(0.0, 4.0 + th / 2), (4.0 + tw / 2, 0.0), (-4.0 - tw / 2, 0.0)]
        # straight up first (the leader then reads as the line's continuation), then up and aside
        spots += [(s * k * 0.6 * tw, 4.0 + th / 2 + row * pitch)
                  for k in range(0, 6) for row in range(1, 7) for s in ((1, -1) if k else (1,))]
        for dx, dy in spots:
            box = (px + dx - tw / 2, py + dy - th / 2, px + dx + tw / 2, py + dy + th / 2)
            inside = frame[0] < box[0] and box[2] < frame[2] and frame[1] < box[1] and box[3] < frame[3]
            if inside and _free(box, obstacles):
                break
        else:
            continue
        leader = (dx, dy) not in spots[:3]  # away from its line: tied to it
        props = dict(arrowstyle="-", lw=0.5, color="0.4", shrinkA=0.5, shrinkB=2.5) if leader else None
        ann = ax.annotate(text, (fk, ak), textcoords="offset points", xytext=(dx, dy), ha="center", va="center",
                          fontsize=fontsize, arrowprops=props, annotation_clip=False)
        ann.set_in_layout(False)
        names.append(ann)
        taken = [box]
        if leader:  # no later name on the leader: small boxes along it, from the line's head to the name
            for f in np.linspace(0.0, 1.0, 16):
                qx, qy = px + f * dx, py + f * dy
                taken.append((qx - 1.5, qy - 1.5, qx + 1.5, qy + 1.5))
        obstacles = np.vstack([obstacles, taken])
    return names
