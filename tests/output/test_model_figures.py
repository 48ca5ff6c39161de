"""Figures a model adds to a run (``Model.extra_figures``): the hook and the Mathieu stability chart."""

import numpy as np
import pytest
from matplotlib.figure import Figure

from contin.app.runner import run_scene
from contin.model.catalog import build_model
from contin.models.mathieu import draw_stability_chart, transition_curves
from contin.output.model_figures import FigureHook, RunData, model_figures, stability_segments
from contin.output.results import read_csv
from contin.scene.parse import parse_scene


def test_stability_segments_end_at_the_located_changes():
    x = [0.0, 1.0, 2.0, 3.0, 4.0]
    segs = stability_segments(x, [False, False, True, True, False], [1.3, 3.9])
    assert segs == [(0.0, 1.3, False), (1.3, 3.9, True), (3.9, 4.0, False)]
    # no located change between two verdicts: they meet half-way; a branch run backwards too
    assert stability_segments([2.0, 1.0, 0.0], [True, None, None]) == [(1.5, 2.0, True), (0.0, 1.5, None)]
    assert stability_segments([], []) == []


def test_a_model_without_hooks_or_a_hook_that_does_not_apply_writes_nothing(tmp_path):
    class Plain:
        parameters, effects = {"a": 1.0}, ()

    out = {"formats": ["png"], "dpi": 50, "style": "contin", "units": {}, "labels": {}}
    assert model_figures(Plain(), "frequency_response", "a", {}, [], tmp_path, out) == []
    seen = []
    Plain.extra_figures = (FigureHook("never", lambda ax, data: seen.append(data) or False),
                           FigureHook("always", lambda ax, data: ax.plot([0, 1]) and True))
    branches = {0: {"nu": 1, "x": [0.0, 1.0], "stable": [True, False], "rows": [{}, {}]}}
    files = model_figures(Plain(), "frequency_response", "a", branches, [{"branch": 0, "kind": "pd", "a": 0.5}],
                          tmp_path, out)
    assert files == ["always.png"] and not (tmp_path / "never.png").exists()
    assert seen[0].special == ({"branch": 0, "kind": "pd", "x": 0.5},) and seen[0].branches[0]["id"] == 0


def test_transition_curves_scale_with_the_excitation_frequency():
    a, b = transition_curves([0.0, 0.3], w=1.0, orders=3)
    np.testing.assert_allclose(a[:, 0], [0.0, 0.25, 1.0], atol=1e-12)  # tongue tips (r/2)^2 at eps = 0
    assert np.isnan(b[0]).all() and np.all(b[1:, 1] < a[1:, 1])  # each tongue opens: b_r < a_r
    a2, b2 = transition_curves([0.0, 1.2], w=2.0, orders=3)  # s = w t / 2: delta = w^2 a_r(2 eps / w^2) / 4
    np.testing.assert_allclose(a2, 4.0 * transition_curves([0.0, 0.3], 1.0, 3)[0], rtol=1e-12)


MATHIEU = """
model:
  builtin: mathieu
  parameters: {eps: 0.4, c: 0.0, g: 0.0, w: 1.0}
  effects: [parametric]
analysis:
  type: frequency_response
  parameter: delta
  range: [-0.2, 0.6]
  harmonics: 8
  stability: hill
  continuation: {ds_max: 0.05}
output:
  measure: max_multiplier
  dpi: 50
"""


def test_the_mathieu_run_draws_its_stability_chart_on_the_closed_form_curves(tmp_path):
    summary = run_scene(parse_scene(MATHIEU), tmp_path, progress=False)
    assert "stability_chart.png" in summary["plots"]
    assert (tmp_path / "stability_chart.png").stat().st_size > 5_000
    sp = read_csv(tmp_path / "special_points.csv")
    a, b = transition_curves([0.4], 1.0, 2)
    # the stability changes contin located lie on the chart's curves: a_0, b_1, a_1 at q = 2 eps
    located = sorted(d for d, k in zip(sp["delta"], sp["kind"]) if k in ("pd", "bp"))
    np.testing.assert_allclose(located, sorted([a[0, 0], b[1, 0], a[1, 0]]), atol=1e-7)


def _data(**kw):
    model = build_model("mathieu", {"c": 0.1, "eps": 0.4}, ("damping", "parametric"))
    base = dict(analysis="frequency_response", parameter="delta", parameters=dict(model.parameters),
                effects=tuple(model.effects),
                branches=({"id": 0, "nu": 1, "x": np.array([0.0, 0.2, 0.4]), "stable": [True, False, True],
                           "rows": [{"amp_x": 0.0}] * 3},),
                special=({"branch": 0, "kind": "pd", "x": 0.1}, {"branch": 0, "kind": "pd", "x": 0.35}))
    base.update(kw)
    return RunData(**base)


def test_with_damping_only_the_runs_intervals_are_drawn_with_a_note():
    ax = Figure().add_subplot()
    assert draw_stability_chart(ax, _data())
    assert any("closed-form" in t.get_text() for t in ax.texts)
    assert not ax.collections  # no shaded tongues
    assert ax.get_xlabel() == r"stiffness $\delta$" and ax.get_ylabel() == r"parametric amplitude $\varepsilon$"
    texts = ax.get_legend_handles_labels()[1]
    assert "stable (this run)" in texts and "unstable (this run)" in texts and "stability change: pd" in texts


@pytest.mark.parametrize("change", [{"analysis": "static"}, {"parameter": "c"}, {"effects": ("damping",)},
                                    {"branches": ()}])
def test_the_chart_is_left_out_where_it_does_not_apply(change):
    assert draw_stability_chart(Figure().add_subplot(), _data(**change)) is False
