"""The diagram of several measures in stacked panels with a zoom column: its axes, their labels and limits,
one numbering of the special points over every panel, and the single-measure figure of a scene without them."""

import re

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import contin.output.panels as panels_module
import contin.output.plotting as plotting_module
from contin.app.runner import run_scene
from contin.output.figures import figure_style
from contin.output.panel_options import ZoomWindow
from contin.output.panels import WINDOW_GID, draw_panels, panel_figure_size
from contin.scene.parse import parse_scene
from linear_scene import LINEAR_OSCILLATOR


def _figure(size=(11.2, 6.1)):
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _panels():
    """Two measures of one branch: y1 = x^2 and y2 = 3 - x over x in [0, 2]; three special points."""
    x = np.linspace(0.0, 2.0, 201)
    stable = [bool(v < 1.0) for v in x]
    points = [(0.5, "fold"), (1.0, "pd"), (1.05, "ns")]
    return [(m, [{"x": x, "y": f(x), "stable": stable, "nu": 1, "id": 0}],
             [{"x": v, "y": float(f(v)), "kind": k, "branch": 0} for v, k in points])
            for m, f in (("amp_x", lambda v: v**2), ("rms_x", lambda v: 3.0 - v))]


def _numbers(ax):
    """The point numbers each label of ``ax`` names (``1``, ``2,3``, ``1–3``)."""
    out = set()
    for t in ax.texts:
        if t.get_gid() != "special-number":
            continue
        for part in t.get_text().split(","):
            a, _, b = part.partition("\u2013")
            out.update(range(int(a), int(b or a) + 1))
    return out


def test_the_panels_share_the_parameter_axis_and_each_names_its_measure():
    fig = _figure((7.6, 6.1))
    axes = draw_panels(fig, _panels(), "w", symbols={"parameter:w": r"\Omega"}, title="two measures", table=False)
    # the panels and the table's column (an empty axes as tall as the figure)
    assert axes.shape == (2, 1) and len(fig.axes) == 3 and not fig.axes[-1].axison
    assert [ax.get_ylabel() for ax in axes[:, 0]] == ["amplitude of $x$", "RMS of $x$"]
    assert [ax.get_xlabel() for ax in axes[:, 0]] == ["", r"$\Omega$"]  # one parameter axis, at the bottom
    assert axes[0, 0].get_shared_x_axes().joined(axes[0, 0], axes[1, 0])
    assert fig.get_suptitle() == "two measures"
    # the curves are the measures' (x^2 and 3 - x), solid where stable, dashed where not
    for ax, f in zip(axes[:, 0], (lambda v: v**2, lambda v: 3.0 - v)):
        lines = [ln for ln in ax.get_lines() if ln.get_linestyle() in ("-", "--") and ln.get_gid() is None]
        xy = np.vstack([ln.get_xydata() for ln in lines])
        np.testing.assert_allclose(xy[:, 1], f(xy[:, 0]), rtol=1e-12)
        assert {ln.get_linestyle() for ln in lines} == {"-", "--"}
    # one legend: in the top panel, where it hides no curve
    assert axes[0, 0].get_legend() is not None and axes[1, 0].get_legend() is None


def test_the_zoom_column_draws_the_window_and_fits_each_measure_inside_it():
    fig = _figure()
    zoom = ZoomWindow((0.9, 1.2), {"rms_x": (1.5, 2.5)})
    axes = draw_panels(fig, _panels(), "w", zoom=zoom, table=False)
    assert axes.shape == (2, 2) and len(fig.axes) == 5 and not fig.axes[-1].axison
    for ax in axes[:, 1]:
        assert ax.get_xlim() == (0.9, 1.2)
    # amp_x = x^2 is fitted to its span in the window, [0.81, 1.44], with 8 % margins
    lo, hi = 0.9**2, 1.2**2
    np.testing.assert_allclose(axes[0, 1].get_ylim(), (lo - 0.08 * (hi - lo), hi + 0.08 * (hi - lo)), rtol=1e-9)
    assert axes[1, 1].get_ylim() == (1.5, 2.5)  # the measure's window as given
    # the whole range keeps its limits and shows the window shaded
    assert axes[0, 0].get_xlim()[0] < 0.0 and axes[0, 0].get_xlim()[1] > 2.0
    for ax in axes[:, 0]:
        bands = [p for p in ax.patches if p.get_gid() == WINDOW_GID]
        assert len(bands) == 1
        box = bands[0].get_extents()  # display coordinates: back to the parameter's
        np.testing.assert_allclose(ax.transData.inverted().transform([[box.x0, 0.0], [box.x1, 0.0]])[:, 0], [0.9, 1.2],
                                   rtol=1e-9)
    assert axes[1, 1].get_xlabel() == axes[1, 0].get_xlabel() == "$w$"


def test_a_point_has_one_number_in_every_panel_and_one_row_in_the_table():
    fig = _figure()
    axes = draw_panels(fig, _panels(), "w", zoom=ZoomWindow((0.9, 1.2)))
    # numbered by parameter: fold 0.5 -> 1, pd 1.0 -> 2, ns 1.05 -> 3, in every panel that shows them
    assert _numbers(axes[0, 0]) == _numbers(axes[1, 0]) == {1, 2, 3}
    assert _numbers(axes[0, 1]) == _numbers(axes[1, 1]) == {2, 3}  # the fold lies outside the window
    table = [t.get_text() for ax in fig.axes for t in ax.texts if t.get_gid() == "special-table"]
    assert [v for v in table if re.fullmatch(r"\d\.\d+", v)] == ["0.5", "1.05"] and "1" in table
    assert table.count("fold") == 1 and table.count("Neimark-Sacker") == 1 and table.count("period doubling") == 1
    # the table stands in its own column right of the panels (beside one panel it would stretch that row),
    # once
    holder = [ax for ax in fig.axes if any(t.get_gid() == "special-table" for t in ax.texts)]
    assert len(holder) == 1 and holder[0] not in axes.ravel() and not holder[0].axison
    assert holder[0].get_position().x0 >= axes[0, 1].get_position().x1


def test_a_zoom_alone_draws_one_measure_beside_its_window():
    fig = _figure((11.2, 4.6))
    axes = draw_panels(fig, _panels()[:1], "w", zoom=ZoomWindow((0.4, 0.6)), table=False)
    assert axes.shape == (1, 2) and axes[0, 1].get_xlim() == (0.4, 0.6)
    assert axes[0, 0].get_ylabel() == "amplitude of $x$" and axes[0, 1].get_ylabel() == ""
    assert panel_figure_size(1, True)[0] > panel_figure_size(1, False)[0] == 7.6


def test_long_labels_of_low_panels_are_wrapped_and_never_overlap():
    labels = {"amp_x": r"forward whirl of the disc at $\Omega$", "rms_x": r"forward whirl of the disc at $\Omega/2$"}
    with figure_style("paper"):  # a journal column: low panels
        fig = _figure(panel_figure_size(2, True))
        axes = draw_panels(fig, _panels(), "w", zoom=ZoomWindow((0.9, 1.2)), labels=labels, table=False)
        fig.draw_without_rendering()
        renderer = fig.canvas.get_renderer()
        top, bottom = (ax.yaxis.label.get_window_extent(renderer) for ax in axes[:, 0])
    assert "\n" in axes[0, 0].get_ylabel() and "$\\Omega/2$" in axes[1, 0].get_ylabel()  # broken at a space
    assert top.y0 > bottom.y1  # the two labels one above the other, apart
    for ax, box in zip(axes[:, 0], (top, bottom)):  # each within its panel's height
        frame = ax.get_window_extent(renderer)
        assert box.y0 >= frame.y0 - 1.0 and box.y1 <= frame.y1 + 1.0


def test_an_empty_list_of_panels_is_refused():
    with pytest.raises(ValueError, match=r"panels: expected at least one"):
        draw_panels(_figure(), [], "w")


SCENE = LINEAR_OSCILLATOR + """output:
  measure: amp_x
"""


def _saved(monkeypatch, module):
    """The figures ``module`` saves (its ``save_figure`` wrapped)."""
    figures, save = [], module.save_figure

    def keep(fig, *args, **kwargs):
        figures.append(fig)
        return save(fig, *args, **kwargs)

    monkeypatch.setattr(module, "save_figure", keep)
    return figures


def _linear_amplitude(w):
    return 0.5 / np.abs(2.0 - w**2 + 0.2j * w)  # the linear oscillator's |X|: the scene's closed form


@pytest.mark.slow
def test_a_scene_without_panels_draws_its_one_measure_in_one_axes(tmp_path, monkeypatch):
    single, stacked = _saved(monkeypatch, plotting_module), _saved(monkeypatch, panels_module)
    run_scene(parse_scene(SCENE), tmp_path / "out", progress=False)
    assert stacked == [] and len(single) == 1
    (ax,) = single[0].axes
    assert ax.get_ylabel() == "amplitude of $x$"
    xy = np.vstack([ln.get_xydata() for ln in ax.get_lines() if ln.get_linestyle() != "None"])
    np.testing.assert_allclose(xy[:, 1], _linear_amplitude(xy[:, 0]), rtol=2e-3)


@pytest.mark.slow
def test_a_scene_with_panels_and_a_zoom_draws_them(tmp_path, monkeypatch):
    single, stacked = _saved(monkeypatch, plotting_module), _saved(monkeypatch, panels_module)
    text = SCENE + "  panels: [amp_x, rms_x]\n  zoom: {range: [1.2, 1.6]}\n"
    run_scene(parse_scene(text), tmp_path / "out", progress=False)
    assert single == [] and len(stacked) == 1
    axes = np.array(stacked[0].axes[:4]).reshape(2, 2, order="F")  # the panels by column, then the table's
    assert [ax.get_ylabel() for ax in axes[:, 0]] == ["amplitude of $x$", "RMS of $x$"]
    assert axes[0, 1].get_xlim() == axes[1, 1].get_xlim() == (1.2, 1.6)
    # the amplitude grows through the window (the resonance is at sqrt(2) = 1.414): its zoom spans the peak
    w = np.linspace(1.2, 1.6, 4001)
    a = _linear_amplitude(w)
    lo, hi = axes[0, 1].get_ylim()
    assert lo < a.min() and hi > a.max() and (hi - lo) < 1.2 * (a.max() - a.min())
    assert (tmp_path / "out" / "bifurcation_diagram.png").is_file()
    assert sum(p.get_gid() == WINDOW_GID for ax in axes[:, 0] for p in ax.patches) == 2


def test_grazing_points_are_marked_and_named_in_the_legend_but_neither_numbered_nor_listed():
    """A bouncing orbit has dozens of grazing points: numbered, they would crowd out the bifurcations."""
    panels = []
    for measure, branches, special in _panels():
        extra = [{"x": v, "y": float(np.interp(v, branches[0]["x"], branches[0]["y"])), "kind": "grazing",
                  "branch": 0} for v in (0.7, 0.8, 0.9)]
        panels.append((measure, branches, special + extra))
    fig = _figure()
    axes = draw_panels(fig, panels, "w", zoom=ZoomWindow((0.6, 1.2)))
    table = [t.get_text() for ax in fig.axes for t in ax.texts if t.get_gid() == "special-table"]
    assert "grazing" not in table and table.count("fold") == 1
    assert _numbers(axes[0, 0]) == {1, 2, 3}  # the fold, the pd and the ns only
    legend = [t.get_text() for t in axes[0, 0].get_legend().get_texts()]
    assert "grazing" in legend
    stars = [ln for ax in axes.ravel() for ln in ax.lines if ln.get_marker() == "*"]
    assert len(stars) == 3 * 4  # in both panels of the whole range and of the window (which holds them)


def test_the_legend_stands_where_it_hides_the_least_of_the_curves():
    """A top panel filled by curves everywhere, a lower one with a single diagonal: the legend goes to the lower
    panel, in a corner the diagonal does not cross."""
    x = np.linspace(0.0, 2.0, 201)
    stable = [bool(v < 1.0) for v in x]
    full = [{"x": x, "y": np.full_like(x, c), "stable": stable, "nu": 1, "id": 0, "group": "a"}
            for c in np.linspace(0.0, 1.0, 41)]
    diagonal = [{"x": x, "y": x, "stable": stable, "nu": 1, "id": 0, "group": "a"}]
    fig = _figure((7.6, 6.1))
    axes = draw_panels(fig, [("amp_x", full, []), ("rms_x", diagonal, [])], "w", table=False)
    assert axes[0, 0].get_legend() is None and axes[1, 0].get_legend() is not None
    fig.draw_without_rendering()
    box = axes[1, 0].get_legend().get_window_extent()
    t = np.linspace(0.0, 2.0, 2001)
    xy = axes[1, 0].transData.transform(np.column_stack([t, t]))
    assert not np.any((xy[:, 0] > box.x0) & (xy[:, 0] < box.x1) & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1))


def test_a_legend_that_would_hide_curves_in_every_panel_goes_under_the_table_where_the_figure_has_room():
    """Both panels filled by curves everywhere, two special points listed: no place in the panels is free, and the
    legend is put under the special points' table, clear of every panel (the table's column as wide as the
    legend); without a table it stays in a panel."""
    x = np.linspace(0.0, 2.0, 201)
    stable = [bool(v < 1.0) for v in x]
    full = [{"x": x, "y": np.full_like(x, c), "stable": stable, "nu": 1, "id": 0, "group": "a"}
            for c in np.linspace(0.0, 1.0, 41)]
    point = [{"x": 1.0, "y": 0.5, "kind": "fold", "branch": 0}, {"x": 1.2, "y": 0.5, "kind": "ns", "branch": 0}]
    fig = _figure((7.6, 6.1))
    axes = draw_panels(fig, [("amp_x", full, point), ("rms_x", full, point)], "w")
    assert all(ax.get_legend() is None for ax in axes.ravel())
    (legend,) = [a.get_legend() for a in fig.axes if a.get_legend() is not None]
    fig.draw_without_rendering()
    box = legend.get_window_extent()
    table = [t.get_window_extent() for ax in fig.axes for t in ax.texts if t.get_gid() == "special-table"]
    assert box.y1 <= min(t.y0 for t in table) and box.x0 >= min(t.x0 for t in table) - 20
    assert box.y0 >= 0 and box.x1 <= fig.bbox.x1
    assert all(box.x0 >= ax.get_window_extent().x1 for ax in axes.ravel())
    fig = _figure((7.6, 6.1))
    axes = draw_panels(fig, [("amp_x", full, point), ("rms_x", full, point)], "w", table=False)
    assert any(ax.get_legend() is not None for ax in axes.ravel())
