"""The shortfalls of a bifurcation_curve run: a default cap on curves that the scene did not set is one."""

from types import SimpleNamespace

from contin.analyses.curve_files import curve_shortfalls


def _ctx(analysis_data):
    return SimpleNamespace(scene=SimpleNamespace(data={"analysis": analysis_data}, analysis={"max_curves": 8}))


def test_points_left_by_the_default_cap_on_curves_are_a_shortfall_and_a_cap_the_scene_set_is_not():
    skipped = [{"kind": "fold", "w": 2.1, "reason": "max_curves"}, {"kind": "pd", "w": 2.2, "on_curve": 0}]
    (msg,) = curve_shortfalls(_ctx({}), [], skipped, "w", "f0")
    assert "1 located point(s) started no curve (w = 2.1)" in msg and "analysis.max_curves = 8" in msg
    assert curve_shortfalls(_ctx({"max_curves": 8}), [], skipped, "w", "f0") == []
    assert curve_shortfalls(_ctx({}), [], skipped[1:], "w", "f0") == []
