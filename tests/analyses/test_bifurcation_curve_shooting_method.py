"""``bifurcation_curve`` with ``method: shooting``: a scene's Neimark-Sacker curves, its files and its refusals.

The forced van der Pol oscillator's periodic orbit loses stability at two
Neimark-Sacker points about w = 1 (F = 0.15); their curves in (w, F) end at
1:1 resonances on the fold curves of the entrainment region. The curves'
points are checked against scipy in tests/bifurcation/test_shooting_curve_system.py;
here the scene: the one-parameter runs (at F = 0.15 and the overlaid F = 0.2)
locate their points on the curves, the files hold what the run found, and
keys that make no sense with the method are refused by name.
"""

import csv
import json

import pytest

from contin.api import run
from contin.scene.parse import SceneError, scene_from_data
from contin.analyses.bifurcation_curve import BifurcationCurve
from contin.scene.build import build_model

MODEL = {"name": "van_der_pol", "dofs": ["x"], "parameters": {"mu": 0.1, "F": 0.15, "w": 1.0}, "mass": [[1]],
         "damping": [["-mu"]], "stiffness": [[1]], "forces": [{"dof": "x", "expr": "mu*x**2*x_dot"}],
         "excitation": [{"dof": "x", "expr": "F*cos(tau)"}], "frequency": "w"}
ANALYSIS = {"type": "bifurcation_curve", "method": "shooting", "parameter": "w", "range": [0.85, 1.15], "start": 1.0,
            "start_from": "simulation", "start_simulation": {"transient": 300, "steps_per_period": 512},
            "second_parameter": "F", "second_range": [0.05, 0.25], "curves": ["ns"], "overlay": [0.2],
            "shooting_options": {"steps_per_period": 512}, "curve_continuation": {"ds": 0.01, "ds_max": 0.02}}


def scene(**changes):
    return {"model": MODEL, "analysis": {**ANALYSIS, **changes}, "output": {"plots": False}}


def test_the_neimark_sacker_curves_of_van_der_pol_end_at_1_1_resonances_and_carry_the_overlaid_points(tmp_path):
    res = run(scene(), tmp_path)
    summary = json.loads((tmp_path / "summary.json").read_text())
    curves = summary["analysis"]["curves"]
    assert res.status == "complete", res.message
    assert [c["kind"] for c in curves] == ["ns", "ns"]
    # both curves end on the low-force side at a 1:1 resonance (the entrainment region's fold curves)
    assert [c["special_points"].get("r1") for c in curves] == [1, 1]
    points = list(csv.DictReader(open(tmp_path / "curve_points.csv")))
    r1 = sorted(float(p["w"]) for p in points if p["kind"] == "r1")
    assert r1[0] < 1.0 < r1[1]
    checks = list(csv.DictReader(open(tmp_path / "one_parameter_points.csv")))
    overlaid = [c for c in checks if float(c["F"]) == 0.2 and c["kind"] == "ns"]
    assert len(overlaid) == 2
    # located where |mu| = 1 + tolerance (1e-6) by the one-parameter run: within its bias of the curve
    assert max(float(c["distance"]) for c in overlaid) < 1e-4
    rows = list(csv.DictReader(open(tmp_path / "curves.csv")))
    assert {"angle", "amp_x"} <= set(rows[0])
    assert all(0.0 <= float(r["angle"]) <= 3.1416 for r in rows)


def test_curve_starts_picks_the_points_nearest_to_its_values_and_says_which_found_none(tmp_path):
    res = run(scene(curve_starts=[0.95, 1.1], overlay=[], second_range=[0.14, 0.16]), tmp_path)
    curves = json.loads((tmp_path / "summary.json").read_text())["analysis"]["curves"]
    assert len(curves) == 1 and abs(curves[0]["start"]["w"] - 0.95125) < 1e-3
    assert res.status == "incomplete" and "w=1.1 (analysis.curve_starts)" in res.message


@pytest.mark.parametrize("changes, key, words", [
    ({"method": "hb", "curves": ["ns"]}, "analysis.curves", "method: shooting"),
    ({"method": "hb", "curves": ["fold"], "switch": ["pd"]}, "analysis.switch", "method: shooting"),
    ({"method": "hb", "curves": ["fold"], "starts": [{"start": 1.0}]}, "analysis.starts", "method: shooting"),
    ({"shooting": [0.2]}, "analysis.shooting", "no reference values"),
    ({"curve_starts": "some"}, "analysis.curve_starts", "a list of numbers"),
])
def test_keys_that_do_not_fit_the_method_are_refused_by_name(changes, key, words):
    with pytest.raises(SceneError, match=key) as err:
        sc = scene_from_data(scene(**changes))
        BifurcationCurve().plan(sc, build_model(sc))
    assert words in str(err.value)
