"""``Result.plot``: drawn into the caller's axes, every artist stays inside the figure, the layout keeps the
axes their size, and the special points' table is there only where asked for and given room."""

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.axis import Axis
from matplotlib.figure import Figure

import contin


@pytest.fixture(scope="module")
def duffing():
    """The tutorial's Duffing oscillator at few harmonics: a branch with two folds."""
    system = contin.System.builtin("duffing", {"c": 0.1, "g": 1.0, "F": 0.5})
    return contin.frequency_response(system, parameter="w", range=[0.5, 3.0], harmonics=3, stability="hill")


def _figure(**kwargs):
    fig = Figure(**kwargs)  # as plt.subplots() makes it: no layout engine unless asked for
    FigureCanvasAgg(fig)
    return fig, fig.subplots()


def _drawn(artist):
    """The visible artists under ``artist``; an axis as a whole (its ticks outside the view are not drawn)."""
    if not artist.get_visible():
        return
    yield artist
    if isinstance(artist, Axis):
        return
    for child in artist.get_children():
        yield from _drawn(child)


def _outside(fig) -> list:
    """The drawn artists whose window extent reaches past the figure (more than half a pixel)."""
    fig.draw_without_rendering()
    renderer = fig.canvas.get_renderer()
    box = fig.bbox
    out = []
    for artist in _drawn(fig):
        if artist is fig:
            continue
        ext = artist.get_tightbbox(renderer) if isinstance(artist, Axis) else artist.get_window_extent(renderer)
        if ext is None or ext.width == 0 and ext.height == 0 or not np.all(np.isfinite(ext.extents)):
            continue  # nothing drawn
        if ext.x0 < box.x0 - 0.5 or ext.y0 < box.y0 - 0.5 or ext.x1 > box.x1 + 0.5 or ext.y1 > box.y1 + 0.5:
            out.append((type(artist).__name__, getattr(artist, "get_text", lambda: "")(), ext.extents))
    return out


def test_plot_into_the_callers_axes_stays_inside_the_figure(duffing):
    assert [s.kind for s in duffing.special_points].count("fold") == 2
    fig, ax = _figure()
    assert duffing.plot(ax=ax) is ax
    assert _outside(fig) == []
    renderer = fig.canvas.get_renderer()
    assert ax.get_window_extent(renderer).contains(*ax.get_legend().get_window_extent(renderer).p0)
    assert ax.get_window_extent(renderer).contains(*ax.get_legend().get_window_extent(renderer).p1)
    # the special points are marked, their kind named in the legend, and no table stands beside the axes
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["stable", "unstable", "fold"]
    assert not [t for t in ax.texts if t.get_gid() in ("special-table", "special-number")]
    # tight_layout keeps the axes their size: at least half the figure's height and width
    fig.tight_layout()
    pos = ax.get_position()
    assert pos.height >= 0.5 and pos.width >= 0.5
    assert _outside(fig) == []


def test_table_asked_for_in_a_constrained_figure_fits_it(duffing):
    fig, ax = _figure(layout="constrained")
    duffing.plot(ax=ax, table=True)
    table = [t.get_text() for t in ax.texts if t.get_gid() == "special-table"]
    assert "fold" in table and "1.4387" in table  # the fold located at w = 1.4387 (the tutorial's H = 9: 1.4387)
    assert _outside(fig) == []


def test_table_must_be_a_flag(duffing):
    fig, ax = _figure()
    with pytest.raises(TypeError, match="table must be True, False or None, not 'yes'"):
        duffing.plot(ax=ax, table="yes")
