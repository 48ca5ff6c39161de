"""The two-parameter diagram: curves drawn smooth through their points, tongues shaded, one legend entry a kind."""

import numpy as np
from matplotlib.figure import Figure

from contin.output.plane_plot import _tongue, draw_two_parameter, smooth_arc, two_parameter_diagram


def test_smooth_arc_passes_through_the_points_without_overshooting():
    x = np.array([0.0, 0.1, 0.5, 0.55, 1.0])
    y = np.array([0.0, 0.5, 0.6, 0.9, 1.0])  # few points, unevenly spaced: a coarse continuation
    xs, ys = smooth_arc(x, y)
    assert xs.size > 100
    for xi, yi in zip(x, y):  # every stored point is on the drawn curve
        assert np.min(np.hypot(xs - xi, ys - yi)) < 1e-12
    # monotone data stays monotone (PCHIP in the arc length): no wiggle between two points
    assert np.all(np.diff(xs) >= -1e-15) and np.all(np.diff(ys) >= -1e-15)
    # two points, or repeated ones, are drawn as given
    np.testing.assert_array_equal(smooth_arc([0.0, 1.0], [1.0, 2.0])[0], [0.0, 1.0])
    xs, ys = smooth_arc([0.0, 0.0, 1.0, 2.0], [0.0, 0.0, 1.0, 0.0])
    assert np.all(np.isfinite(xs)) and np.isclose(ys.max(), 1.0)


def test_two_sides_of_a_tongue_are_shaded_between_them_up_the_side_they_leave_by():
    eps = np.linspace(0.05, 1.0, 20)
    low = np.linspace(0.05, 0.75, 15)
    left = (0.25 - 0.6 * low, low)  # ends on the side x = -0.2 below the top
    right = (0.25 + 0.35 * eps, eps)
    poly = _tongue(left, right, (-0.2, 0.8), (1.0, 1.0))
    assert poly is not None
    px, py = poly
    assert py.max() == 1.0 and np.any(np.isclose(px, -0.2) & (py == 1.0))  # closed along the side at the far top
    assert _tongue(left, (np.array([0.7, 0.8]), np.array([0.05, 1.0])), (-0.2, 0.8), (1.0, 1.0)) is None


def test_curves_of_one_kind_share_a_legend_entry_and_axes_show_symbols(tmp_path):
    eps = np.linspace(0.05, 1.0, 6)
    curves = [{"kind": "pd", "x": 0.25 - 0.4 * eps, "y": eps, "id": 0, "label": "period doubling"},
              {"kind": "pd", "x": 0.25 + 0.4 * eps, "y": eps, "id": 1, "label": "period doubling"}]
    points = [{"kind": "pd", "x": 0.25 - 0.16, "y": 0.4}]
    ax = Figure().add_subplot()
    draw_two_parameter(ax, curves, [{"kind": "cusp", "x": 0.25, "y": 0.05}], points, "delta", "eps", lines=[0.4],
                       xlim=(-0.2, 0.8), ylim=(0.05, 1.0))
    texts = ax.get_legend_handles_labels()[1]
    assert texts[0] == "curves 0, 1: period doubling"
    assert "one-parameter runs" in texts and "cusp" in texts
    assert ax.get_xlabel() == r"$\delta$" and ax.get_ylabel() == r"$\varepsilon$"
    assert len(ax.lines[0].get_xdata()) > 6  # drawn through more points than stored
    names = two_parameter_diagram(curves, [], points, "delta", "eps", tmp_path / "curves.png", lines=[0.4],
                                  xlim=(-0.2, 0.8), ylim=(0.05, 1.0), formats=["png", "svg"], dpi=60,
                                  labels={"eps": "parametric excitation"}, units={"delta": "1"})
    assert names == ["curves.png", "curves.svg"]
    assert all((tmp_path / n).stat().st_size > 1000 for n in names)


def test_an_unlocated_one_parameter_point_is_grey_and_said_so():
    eps = np.linspace(0.05, 1.0, 6)
    curves = [{"kind": "fold", "x": 1.0 + 0.3 * eps, "y": eps, "id": 0, "label": "fold"}]
    points = [{"kind": "fold", "x": 1.12, "y": 0.4, "located": True},
              {"kind": "fold", "x": 1.24, "y": 0.8, "located": False}]
    ax = Figure().add_subplot()
    draw_two_parameter(ax, curves, [], points, "w", "F", xlim=(0.9, 1.5), ylim=(0.05, 1.0))
    found, lost = ([ln for ln in ax.lines if ln.get_xydata().shape == (1, 2)
                    and np.allclose(ln.get_xydata(), [[q["x"], q["y"]]])][0] for q in points)
    assert found.get_color() == "tab:red" and lost.get_color() == "0.45"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "found by the one-parameter runs: fold (not located)" in labels
    assert "located by the one-parameter runs: fold" in labels
