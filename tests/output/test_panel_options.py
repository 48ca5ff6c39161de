"""``output.panels`` and ``output.zoom``: refused with a message naming the key and the form expected, at the
scene's check (the form) or at the analysis's plan (the measures' names), and for analyses that draw one measure."""

import dataclasses
import math

import pytest
from conftest import fuzz_examples
from hypothesis import given, settings
from hypothesis import strategies as st

from contin.output.panel_options import MAX_PANELS, PanelError, ZoomWindow
from contin.scene.build import build_model
from contin.scene.parse import SceneError, parse_scene
from contin.scene.registry import check_scene
from linear_scene import LINEAR_OSCILLATOR

LINEAR = LINEAR_OSCILLATOR + """output:
"""


def _scene(output: str, base: str = LINEAR):
    return parse_scene(base + "".join(f"  {line}\n" for line in output.splitlines()))


def _plan(output: str, base: str = LINEAR):
    scene = _scene(output, base)
    return check_scene(scene, build_model(scene))


# ---------------------------------------------------------------- the form, at the scene's check
@pytest.mark.parametrize("value", ["amp_x", "[]", "[amp_x, amp_x]", "[amp_x, 3]", "['']",
                                   "[" + ", ".join(f"h{k}_x" for k in range(MAX_PANELS + 1)) + "]"])
def test_panels_not_a_short_list_of_distinct_names_is_refused(value):
    with pytest.raises(SceneError, match=r"output\.panels.*expected a list of 1 to 6 distinct measures"):
        _scene(f"panels: {value}")


@pytest.mark.parametrize("zoom, key, expected", [
    ("{range: [2.2, 2.1]}", r"output\.zoom\.range", "two increasing finite numbers"),
    ("{range: [1.0, 1.0]}", r"output\.zoom\.range", "two increasing finite numbers"),
    ("{range: [1.0, .inf]}", r"output\.zoom\.range", "two increasing finite numbers"),
    ("{range: [1.0]}", r"output\.zoom\.range", "two increasing finite numbers"),
    ("{range: [true, 2.0]}", r"output\.zoom\.range", "two increasing finite numbers"),
    ("{range: 'a'}", r"output\.zoom\.range", "two increasing finite numbers"),
    ("{measure_range: {amp_x: [0, 1]}}", r"output\.zoom\.range", r"required"),
    ("{range: [1, 2], window: [0, 1]}", r"output\.zoom\.window", "one of the keys range, measure_range"),
    ("{range: [1, 2], measure_range: [0, 1]}", r"output\.zoom\.measure_range", r"a mapping \{measure: \[lo, hi\]\}"),
    ("{range: [1, 2], measure_range: {amp_x: [1, 0]}}", r"output\.zoom\.measure_range\.amp_x",
     "two increasing finite numbers"),
    ("[1, 2]", r"output\.zoom", r"a mapping with range: \[lo, hi\]"),
])
def test_a_zoom_not_of_its_form_is_refused_naming_the_key(zoom, key, expected):
    with pytest.raises(SceneError, match=key + r" .*expected .*" + expected):
        _scene(f"zoom: {zoom}")


def test_a_zoom_of_its_form_is_kept_as_the_scene_gave_it():
    scene = _scene("zoom: {range: [1, 2], measure_range: {amp_x: [0, 0.5]}}\npanels: [amp_x, rms_x]")
    assert scene.output["zoom"] == {"range": [1, 2], "measure_range": {"amp_x": [0, 0.5]}}
    assert scene.output["panels"] == ["amp_x", "rms_x"]
    assert _scene("measure: amp_x").output["panels"] is None and _scene("").output["zoom"] is None


# ---------------------------------------------------------------- the names, at the analysis's plan
def test_a_panel_that_is_no_measure_is_refused_with_its_index_and_a_suggestion():
    with pytest.raises(SceneError, match=r"output\.panels\[1\] \(line \d+\): expected one of the measures amp_x.*found "
                                         r"'rms_z'.*did you mean 'rms_x'"):
        _plan("panels: [amp_x, rms_z]")


def test_a_measure_that_is_not_one_of_the_panels_is_refused():
    with pytest.raises(SceneError, match=r"output\.measure \(line \d+\): expected one of output\.panels \(amp_x, rms_x\)"):
        _plan("panels: [amp_x, rms_x]\nmeasure: max_x")


def test_a_measure_window_of_a_measure_not_drawn_is_refused():
    with pytest.raises(SceneError, match=r"output\.zoom\.measure_range\.max_x \(line \d+\): expected a measure the figure "
                                         r"draws: amp_x, rms_x"):
        _plan("panels: [amp_x, rms_x]\nzoom: {range: [1, 2], measure_range: {max_x: [0, 1]}}")
    with pytest.raises(SceneError, match=r"output\.zoom\.measure_range\.rms_x \(line \d+\): expected a measure the figure "
                                         r"draws: amp_x, found"):  # neither panels nor measure: the first measure
        _plan("zoom: {range: [1, 2], measure_range: {rms_x: [0, 1]}}")


def test_panels_and_a_zoom_of_measures_drawn_pass_the_plan():
    _plan("panels: [amp_x, rms_x]\nmeasure: rms_x\nzoom: {range: [1, 2], measure_range: {rms_x: [0, 1]}}")


STATIC = """
model:
  dofs: [x]
  parameters: {m: 1.0, c: 0.1, k: 1.0, k3: 1.0, P: 0.0, w: 1.0}
  mass: [[m]]
  damping: [[c]]
  stiffness: [[k]]
  forces: [{dof: x, expr: "-k3*x**3 + P"}]
analysis:
  type: static
  parameter: P
  range: [0.0, 1.0]
output:
"""


@pytest.mark.parametrize("key, value", [("panels", "[x]"), ("zoom", "{range: [0.2, 0.4]}")])
def test_an_analysis_that_draws_one_measure_refuses_panels_and_zoom(key, value):
    with pytest.raises(SceneError, match=rf"output\.{key} \(line \d+\): expected no {key}: the figure of analysis type "
                                         r"'static' draws one measure"):
        _plan(f"{key}: {value}", STATIC)


# ---------------------------------------------------------------- the dataclass
def test_the_zoom_window_is_frozen_and_names_its_field():
    z = ZoomWindow([1, 2], {"amp_x": [0, 3]})
    assert z.range == (1.0, 2.0) and z.limits("amp_x") == (0.0, 3.0) and z.limits("rms_x") is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        z.range = (0.0, 1.0)
    with pytest.raises(PanelError, match=r"^range: expected two increasing finite numbers"):
        ZoomWindow((2.0, 1.0))
    with pytest.raises(PanelError, match=r"^measure_range\.amp_x: expected two increasing finite numbers"):
        ZoomWindow((1.0, 2.0), {"amp_x": (float("nan"), 1.0)})


_reals = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**6, 10**6), st.booleans())


@settings(max_examples=fuzz_examples(200), deadline=None)
@given(lo=_reals, hi=_reals)
def test_a_window_is_accepted_exactly_when_it_is_two_increasing_finite_numbers(lo, hi):
    ok = all(not isinstance(v, bool) and math.isfinite(v) for v in (lo, hi)) and lo < hi
    if ok:
        assert ZoomWindow([lo, hi]).range == (float(lo), float(hi))
    else:
        with pytest.raises(PanelError, match=r"^range: expected"):
            ZoomWindow([lo, hi])
