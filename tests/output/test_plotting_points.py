"""Special points in the bifurcation diagram as they are: unlocated ones open and named so, one name per kind."""

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from contin.engine.branch import SpecialKind
from contin.output.plotting import SPECIAL, draw_bifurcation_diagram, kind_name


def _axes():
    fig = Figure(figsize=(7.6, 4.6), layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.add_subplot()


def _diagram(special, table):
    x = np.linspace(0.0, 1.0, 200)
    fig, ax = _axes()
    draw_bifurcation_diagram(ax, [{"x": x, "y": x ** 2, "stable": [True] * 200}], special, "w", "amp_x",
                             table=table)
    fig.draw_without_rendering()
    return fig, ax


def _marker_at(ax, x, y):
    """The marker line drawn at (x, y) in data coordinates (one)."""
    (line,) = [ln for ln in ax.get_lines() if ln.get_marker() not in (None, "None", "", " ")
               and ln.get_gid() is None and ln.get_xydata().shape == (1, 2) and np.allclose(ln.get_xydata(), [[x, y]])]
    return line


SPECIAL_POINTS = [{"x": 0.3, "y": 0.09, "kind": "pd", "located": False},
                  {"x": 0.7, "y": 0.49, "kind": "pd", "located": True},
                  {"x": 0.5, "y": 0.25, "kind": "fold"}]


@pytest.mark.parametrize("table", [True, False])
def test_an_unlocated_point_is_drawn_open_and_a_located_one_filled(table):
    fig, ax = _diagram(SPECIAL_POINTS, table)
    lost, found, fold = (_marker_at(ax, sp["x"], sp["y"]) for sp in SPECIAL_POINTS)
    assert lost.get_marker() == found.get_marker() == "s"
    assert lost.get_fillstyle() == "none"
    assert found.get_fillstyle() == "full" and found.get_markerfacecolor() == "white"
    assert fold.get_fillstyle() == "full"  # located unless said otherwise


def test_the_table_says_not_located_and_its_marker_is_open():
    fig, ax = _diagram(SPECIAL_POINTS, True)
    texts = [t.get_text() for t in ax.texts if t.get_gid() == "special-table"]
    assert texts.count("period doubling (not located)") == 1 and texts.count("period doubling") == 1
    marks = [ln for ln in ax.get_lines() if ln.get_gid() == "special-table" and ln.get_marker() == "s"]
    assert sorted(m.get_fillstyle() for m in marks) == ["full", "none"]


def test_the_legend_without_a_table_says_not_located():
    fig, ax = _diagram(SPECIAL_POINTS, False)
    handles, labels = ax.get_legend_handles_labels()
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "period doubling (not located)" in legend and "period doubling" in legend and "fold" in legend
    (entry,) = [h for h in ax.get_legend().legend_handles if h.get_label() == "period doubling (not located)"]
    assert entry.get_fillstyle() == "none"


@pytest.mark.parametrize("table", [True, False])
def test_a_kink_is_called_kink_as_in_special_points_csv(table):
    fig, ax = _diagram([{"x": 0.4, "y": 0.16, "kind": "kink"}], table)
    words = [t.get_text() for t in ax.texts] + [t.get_text() for t in ax.get_legend().get_texts()]
    assert "kink" in words and not any("corner" in w for w in words)


def test_every_drawn_kind_of_the_file_has_one_name():
    """special_points.csv's kinds (SpecialKind's values) drawn in the figure: named by kind_name, a kink as kink."""
    drawn = [k.value for k in SpecialKind if k.value in SPECIAL]
    assert {"fold", "pd", "ns", "bp", "kink", "grazing", "locking"} <= set(drawn)
    names = [kind_name(k) for k in drawn]
    assert len(set(names)) == len(names) and kind_name("kink") == "kink"
    assert kind_name("ns", located=False, short=True) == "NS (not located)"
