"""The bifurcation diagram: numbered special points that never overlap, a legend whose styles are the
curves', smooth curves from the harmonic coefficients, files in every format, and no global state touched."""

import itertools

import matplotlib
import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from contin.output.plotting import bifurcation_diagram, branch_label, draw_bifurcation_diagram


def _axes(size=(7.6, 4.6)):
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.add_subplot()


def _boxes(fig, gid):
    renderer = fig.canvas.get_renderer()
    return [t.get_window_extent(renderer) for t in fig.axes[0].texts if t.get_gid() == gid]


def _overlap(a, b):
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def _branch(x, y, stable, **kw):
    return {"x": np.asarray(x, float), "y": np.asarray(y, float), "stable": stable, **kw}


@pytest.mark.parametrize("spacing", [0.004, 0.012, 0.08])
def test_the_numbers_of_a_cluster_of_ten_points_never_overlap(spacing):
    x = np.linspace(0.0, 1.0, 400)
    branch = _branch(x, np.sin(3 * x), [True] * 400)
    xs = 0.1 + spacing * np.arange(10)
    special = [{"x": v, "y": np.sin(3 * v), "kind": k} for v, k in zip(xs, itertools.cycle(["fold", "pd", "ns"]))]
    fig, ax = _axes()
    draw_bifurcation_diagram(ax, [branch], special, "w", "amp_x")
    fig.canvas.draw()
    boxes = _boxes(fig, "special-number")
    assert boxes and all(not _overlap(a, b) for a, b in itertools.combinations(boxes, 2))
    numbers = [t.get_text() for t in ax.texts if t.get_gid() == "special-number"]
    # every point is named once, alone or in a range "3-9" of a cluster tighter than a number
    named = []
    for text in numbers:
        if "\u2013" in text:
            a, b = map(int, text.split("\u2013"))
            named += range(a, b + 1)
        else:
            named += [int(v) for v in text.split(",")]
    assert sorted(named) == list(range(1, 11))
    if spacing == 0.08:  # far enough apart for a number each
        assert len(numbers) == 10
    # the table lists all ten with their parameter values
    table = [t.get_text() for t in ax.texts if t.get_gid() == "special-table"]
    assert f"{xs[3]:.5g}" in table and f"{xs[9]:.5g}" in table


def test_the_numbers_keep_off_the_legend_and_inside_the_axes():
    x = np.linspace(0.0, 1.0, 200)
    branches = [_branch(x, x, [True] * 100 + [False] * 100, nu=1), _branch(x, 1 - x, [False] * 200, nu=2)]
    special = [{"x": v, "y": v, "kind": "fold"} for v in (0.02, 0.5, 0.98)] + [{"x": 0.98, "y": 0.02, "kind": "pd"}]
    fig, ax = _axes()
    draw_bifurcation_diagram(ax, branches, special, "w", "amp_x")
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legend = ax.get_legend().get_window_extent(renderer)
    frame = ax.get_window_extent(renderer)
    for box in _boxes(fig, "special-number"):
        assert not _overlap(box, legend)
        assert frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0 and box.y1 <= frame.y1


def _legend(ax):
    leg = ax.get_legend()
    handles = getattr(leg, "legend_handles", None) or leg.legendHandles
    return {t.get_text(): h for t, h in zip(leg.get_texts(), handles)}


def test_the_legend_shows_the_curves_styles_and_names_the_branches_by_order():
    x = np.linspace(1.0, 2.0, 50)
    branches = [_branch(x, x, [True] * 40 + [False] * 10, nu=1, id=0),
                _branch(x, 2 * x, [False] * 45 + [True] * 5, nu=2, id=1)]
    fig, ax = _axes()
    draw_bifurcation_diagram(ax, branches, [], "w", "amp_x")
    drawn = {(line.get_color(), line.get_linestyle()) for line in ax.get_lines()}
    entries = _legend(ax)
    assert set(entries) == {"harmonic", "1/2 subharmonic", "stable", "unstable"}
    assert entries["stable"].get_linestyle() == "-" and entries["unstable"].get_linestyle() == "--"
    widths = {line.get_linestyle(): line.get_linewidth() for line in ax.get_lines()}
    for key in ("stable", "unstable"):
        assert entries[key].get_linewidth() == widths[entries[key].get_linestyle()]
    # a branch's entry is a swatch of its colour (its style changes along it and is keyed by the entries above)
    colors = {matplotlib.colors.to_hex(c) for c, _ in drawn}
    for name in ("harmonic", "1/2 subharmonic"):
        assert matplotlib.colors.to_hex(entries[name].get_facecolor()) in colors
    assert entries["harmonic"].get_facecolor() != entries["1/2 subharmonic"].get_facecolor()


def test_one_branch_has_no_entry_and_branches_of_one_order_are_told_apart():
    x = np.linspace(1.0, 2.0, 20)
    fig, ax = _axes()
    draw_bifurcation_diagram(ax, [_branch(x, x, [True] * 20, nu=1)], [], "w", "amp_x")
    assert set(_legend(ax)) == {"stable"}
    fig, ax = _axes()
    halves = [_branch(x, x, [True] * 20, nu=2, id=1, group="a"), _branch(x, -x, [True] * 20, nu=2, id=2, group="a")]
    draw_bifurcation_diagram(ax, halves, [], "w", "amp_x")  # two halves of one branch: one entry, one colour
    assert set(_legend(ax)) == {"stable"} and len({line.get_color() for line in ax.get_lines()}) == 1
    fig, ax = _axes()
    draw_bifurcation_diagram(ax, [_branch(x, x, None, nu=2, id=1), _branch(x, -x, None, nu=2, id=3)], [], "w", "amp_x")
    assert set(_legend(ax)) == {"1/2 subharmonic (branch 1)", "1/2 subharmonic (branch 3)"}
    assert [branch_label(nu) for nu in (1, 2, 3)] == ["harmonic", "1/2 subharmonic", "1/3 subharmonic"]


def test_the_axes_read_symbols_and_words():
    fig, ax = _axes()
    x = np.linspace(0.0, 1.0, 5)
    draw_bifurcation_diagram(ax, [_branch(x, x, None)], [{"x": 0.5, "y": 0.5, "kind": "pd"}], "delta",
                             "max_multiplier", symbols={"w": r"\Omega"})
    assert ax.get_xlabel() == r"$\delta$" and "multiplier" in ax.get_ylabel()
    assert r"$\delta$" in [t.get_text() for t in ax.texts if t.get_gid() == "special-table"]


def test_files_in_every_format_and_no_global_state_touched(tmp_path):
    backend, before = matplotlib.get_backend(), matplotlib.rcParams.copy()
    x = np.linspace(0.0, 1.0, 30)
    names = bifurcation_diagram([_branch(x, x ** 2, [True] * 15 + [False] * 15)],
                                [{"x": 0.5, "y": 0.25, "kind": "fold"}], "w", "amp_x", tmp_path / "bifurcation_diagram",
                                formats=["png", "pdf", "svg"], dpi=60, style="paper")
    assert names == ["bifurcation_diagram.png", "bifurcation_diagram.pdf", "bifurcation_diagram.svg"]
    assert all((tmp_path / n).stat().st_size > 1000 for n in names)
    assert matplotlib.get_backend() == backend
    assert matplotlib.rcParams == before

