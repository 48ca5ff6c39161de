"""The ``convergence`` analysis: errors against the finest setting, their decay, the budget, bad input."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.optimize import brentq, minimize_scalar

from contin.analyses.convergence_errors import recommend
from contin.app.cli import main
from contin.output.results import read_csv
from contin.scene.parse import SceneError, parse_scene

ROOT = Path(__file__).resolve().parents[2]

DUFFING = """
model:
  builtin: duffing
  parameters: {m: 1, c: 0.1, k: 1, g: 1, F: 0.5}
  effects: [damping, cubic, forcing]
analysis:
  type: convergence
  base:
    type: frequency_response
    parameter: w
    range: [0.5, 3.0]
    stability: none
    continuation: {ds: 0.01, ds_max: 0.02, newton_tol: 1.0e-12}
  vary:
    analysis.harmonics: [1, 3, 5, 7]
  reference: {analysis.harmonics: 15}
  quantities:
    - {type: fold, index: 0, name: fold_up}
    - {type: peak, measure: amp_x}
"""

GAP = """
model:
  name: gap_oscillator
  dofs: [x]
  parameters: {m: 1, c: 0.05, k: 1, g: 1, kc: 20, F: 0.2, w: 0.5}
  mass: [[m]]
  damping: [[c]]
  stiffness: [[k]]
  forces:
    - {type: gap, dof: x, clearance: g, stiffness: kc, damping: 0, sides: both}
  excitation:
    - {dof: x, amplitude: F, order: 1}
  frequency: w
analysis:
  type: convergence
  base:
    type: frequency_response
    parameter: w
    range: [0.5, 2.0]
    samples: 4096
    stability: none
    # the value at the range end does not depend on the steps: the same errors to 1e-10 with ds_max = 0.05
    continuation: {ds: 0.01, ds_max: 0.2, newton_tol: 1.0e-12}
  vary:
    analysis.harmonics: [3, 5, 9, 17, 33]
  reference: {analysis.harmonics: 65}
  warmup: false
  quantities:
    - {type: value, measure: amp_x, at: 2.0}
"""


def write(tmp_path, text, name="scene.yaml", **changes):
    data = yaml.safe_load(text)
    for k, v in changes.items():
        node = data
        parts = k.split("__")
        for p in parts[:-1]:
            node = node[p]
        node[parts[-1]] = v
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def run(tmp_path, text, *args, **changes):
    path = write(tmp_path, text, **changes)
    out = tmp_path / "out"
    assert main(["check", str(path)]) == 0
    assert main(["run", str(path), "-o", str(out), "-q", *args]) == 0
    return read_csv(out / "convergence.csv"), json.loads((out / "summary.json").read_text()), out


@pytest.fixture(scope="module")
def duffing(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("duffing")
    return run(tmp, DUFFING, "--budget", "1e-5")


@pytest.mark.slow  # five runs of 125 points; by default the Mathieu and static-deflection studies check closed forms
def test_duffing_h1_peak_is_the_closed_form_amplitude_and_errors_decay_spectrally(duffing, capsys):
    rows, summary, out = duffing
    assert list(rows["analysis.harmonics"]) == [1, 3, 5, 7, 15]
    assert list(rows["reference"]) == [False] * 4 + [True]
    # one-harmonic balance of x'' + c x' + k x + g x^3 = F cos(w t): [(k - w^2 + 3/4 g A^2)^2 + (c w)^2] A^2 = F^2;
    # at the largest A, d/dw = 0 gives k - w^2 + 3/4 g A^2 = c^2/2, so (c^4/4 + c^2 w^2) A^2 = F^2 there
    c, k, g, F = 0.1, 1.0, 1.0, 0.5
    a1 = brentq(lambda A: A * A * (c**4 / 4 + c * c * (k + 0.75 * g * A * A - c * c / 2)) - F * F, 0.1, 10)
    assert rows["peak_amp_x"][0] == pytest.approx(a1, rel=1e-6)  # the peak between stored points, by a parabola
    # the jump-down fold of the one-harmonic amplitude equation, solved independently: the largest w on the
    # curve, w(A) taken on the side above the backbone w^2 = k + 3/4 g A^2
    def G(A, w):
        return ((k - w * w) * A + 0.75 * g * A**3) ** 2 + (c * w * A) ** 2 - F * F

    def w_of(A):
        return brentq(lambda w: G(A, w), math.sqrt(k + 0.75 * g * A * A) - 1e-9, 3.0)

    best = minimize_scalar(lambda A: -w_of(A), bounds=(1.5, a1 - 1e-9), method="bounded", options={"xatol": 1e-12})
    assert rows["fold_up"][0] == pytest.approx(-best.fun, rel=1e-10)
    # smooth (analytic) nonlinearity: log(error) falls linearly in H, by more than a decade per harmonic
    H = rows["analysis.harmonics"][:4]
    err = rows["fold_up_error"][:4]
    slope = np.polyfit(H, np.log10(err), 1)[0]
    assert slope < -1.0
    assert np.all(np.diff(np.log10(err)) < -1.0)
    assert err[-1] < 1e-9
    assert rows["wall_time"][0] > 0 and np.all(rows["cpu_time"] > 0)
    assert (out / "convergence.png").exists() and (out / "runs" / "warmup").is_dir()
    a = summary["analysis"]
    assert a["reference"] == "H=15" and "warm-up" in a["timing"]
    rec = a["recommendation"]
    passing = [i for i in range(4) if rows["max_error"][i] <= 1e-5]
    fastest = min(rows["wall_time"][i] for i in passing)
    cheapest = next(i for i in passing if rows["wall_time"][i] <= 1.05 * fastest)  # equal within 5 %: the first
    assert rec["setting"] == rows["setting"][cheapest]
    assert rec["max_error"] <= 1e-5
    capsys.readouterr()
    # the same recommendation from the finished run, and a stricter budget that nothing meets
    assert main(["budget", str(out), "1e-5"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0] == rec["message"] and printed[1] == f"plot: {out / 'convergence.png'}"
    assert main(["budget", str(out), "1e-30"]) == 0
    assert "no setting" in capsys.readouterr().out


@pytest.mark.slow  # the convergence analysis is checked on the Duffing oscillator by default
def test_clearance_contact_errors_decay_algebraically(tmp_path):
    rows, _, _ = run(tmp_path, GAP)
    H = rows["analysis.harmonics"][:-1]
    err = rows["amp_x_at_w_2_error"][:-1]
    assert np.all(np.isfinite(err)) and np.all(err > 0)
    # a kink in the contact force: the errors follow a power of H (slope of log error vs log H), not exp(-a H)
    p = np.polyfit(np.log(H), np.log(err), 1)[0]
    assert -6.0 < p < -2.0
    per_harmonic = np.polyfit(H[2:], np.log10(err[2:]), 1)[0]
    assert per_harmonic > -0.3  # far slower per harmonic than the cubic oscillator's > 1 decade
    assert err[2] > 1e-6  # H = 9 is still far from converged, where the Duffing fold is at 1e-10


def test_recommend_picks_the_cheapest_passing_row_and_says_when_none_passes():
    rows = [
        {"setting": "a", "reference": False, "status": "complete", "wall_time": 3.0, "q_error": 1e-8},
        {"setting": "b", "reference": False, "status": "complete", "wall_time": 1.0, "q_error": 1e-3},
        {"setting": "c", "reference": False, "status": "complete", "wall_time": 2.0, "q_error": 1e-6},
        {"setting": "d", "reference": False, "status": "complete", "wall_time": 0.5, "q_error": None},
        {"setting": "ref", "reference": True, "status": "complete", "wall_time": 0.1, "q_error": 0.0},
    ]
    r = recommend(rows, ["q"], 1e-5)
    assert r["setting"] == "c" and r["wall_time"] == 2.0
    rows[0]["wall_time"] = 2.05  # within 5 % of c: equal within timing noise, and listed first
    assert recommend(rows, ["q"], 1e-5)["setting"] == "a"
    rows[0]["wall_time"] = 3.0
    assert recommend(rows, ["q"], 1e-2)["setting"] == "b"
    none = recommend(rows, ["q"], 1e-12)
    assert none["setting"] is None
    assert "no setting" in none["message"] and "1.00e-08, at a" in none["message"]


def test_missing_quantity_is_reported_not_a_crash(tmp_path, capsys):
    text = DUFFING.replace("[1, 3, 5, 7]", "[1, 3]").replace("15}", "5}\n  warmup: false").replace(
        "- {type: peak, measure: amp_x}", "- {type: fold, index: 7, name: eighth_fold}").replace(
        "ds: 0.01, ds_max: 0.02", "ds: 0.05, ds_max: 0.2")  # the two folds alike in longer steps
    rows, summary, _ = run(tmp_path, text, "--budget", "1e-2")
    printed = capsys.readouterr().out
    assert "missing at H=1: eighth_fold: fold 7 asked, 2 found" in printed
    assert np.all(np.isnan(rows["eighth_fold"])) and np.all(np.isnan(rows["max_error"]))
    assert all("fold 7 asked, 2 found" in m for m in rows["missing"])
    assert summary["analysis"]["recommendation"]["setting"] is None
    assert "no setting has every quantity" in summary["analysis"]["recommendation"]["message"]


def test_static_deflection_against_galerkin_terms(tmp_path):
    text = """
model:
  builtin: timing_belt
  parameters: {alpha: 0.005, beta: 0.2, xi1: 0.4, terms: 5, xi_obs: 0.6}
  effects: [rotor_mass, stretching, static_load]
analysis:
  type: convergence
  base: {type: static, parameter: p_s, range: [0, 30], measure: w}
  vary: {model.parameters.terms: [3, 5]}
  reference: {model.parameters.terms: 9}
  warmup: false
  quantities: [{type: static_deflection, at: 30}]
"""
    rows, _, _ = run(tmp_path, text)
    assert round(rows["w_at_p_s_30"][1], 4) == 3.7643  # the belt paper's Table 1, n = 5
    assert list(rows["setting"]) == ["n=3", "n=5", "n=9"]
    assert rows["w_at_p_s_30_error"][-1] == 0


def test_stable_interval_of_the_mathieu_trivial_solution_against_scipy(tmp_path):
    from scipy.special import mathieu_a, mathieu_b

    text = """
model:
  builtin: mathieu
  parameters: {eps: 0.4, c: 0.0, g: 0.0, w: 1.0}
  effects: [parametric]
analysis:
  type: convergence
  base:
    type: frequency_response
    parameter: delta
    range: [-0.2, 0.4]
    stability: hill
    continuation: {ds_max: 0.05}
  vary: {analysis.harmonics: [2, 3]}
  reference: {analysis.harmonics: 10}
  warmup: false
  quantities: [{type: stable_interval, nu: 1, ends: [from, to, length]}]
"""
    rows, _, _ = run(tmp_path, text)
    # x'' + (delta + eps cos t) x = 0 is stable between the transition curves a_0(q)/4 and b_1(q)/4, q = 2 eps
    lo, hi = mathieu_a(0, 0.8) / 4, mathieu_b(1, 0.8) / 4
    assert rows["stable_nu1_from"][-1] == pytest.approx(lo, abs=1e-9)
    assert rows["stable_nu1_to"][-1] == pytest.approx(hi, abs=1e-9)
    assert rows["stable_nu1_length"][-1] == pytest.approx(hi - lo, abs=2e-9)
    assert rows["stable_nu1_to_error"][0] > 100 * rows["stable_nu1_to_error"][1] > 0


@pytest.mark.slow  # fourth order of the integrator: tests/test_simulation.py
def test_time_integration_steps_converge_at_fourth_order(tmp_path):
    text = """
model:
  builtin: duffing
  parameters: {m: 1, c: 0.1, k: 1, g: 1, F: 0.5}
  effects: [damping, cubic, forcing]
analysis:
  type: convergence
  base: {type: simulate, parameter: w, values: [1.2], transient: 100, record: 4, samples_per_period: 16}
  vary: {analysis.steps_per_period: [16, 32, 64, 128]}
  reference: {analysis.steps_per_period: 2048}
  quantities: [{type: value, measure: amp_x, at: 1.2}]
"""
    rows, _, _ = run(tmp_path, text)
    assert list(rows["setting"])[:2] == ["steps=16", "steps=32"]
    err = rows["amp_x_at_w_1_2_error"][:-1]
    # classical Runge-Kutta: the error falls like steps^-4
    assert np.polyfit(np.log(rows["analysis.steps_per_period"][:-1]), np.log(err), 1)[0] == pytest.approx(-4, abs=0.4)


BAD = [
    ({"analysis__vary": {"analysis.harmonix": [1, 3]}}, r"analysis\.vary\.analysis\.harmonix.*: expected a key of the "
                                                         r"frequency_response analysis.*did you mean 'harmonics'"),
    ({"analysis__vary": {"model.parameters.gg": [1, 2]}}, r"model\.parameters\.gg.*: expected a parameter of the "
                                                          r"built-in model 'duffing'"),
    ({"analysis__vary": {"output.title": ["a"]}}, r"analysis\.vary\.output\.title.*: expected a setting path starting"),
    ({"analysis__vary": {"analysis.continuation.newton_tl": [1e-9]}}, r"continuation option.*newton_tl"),
    ({"analysis__vary": {"analysis.harmonics": []}}, r"analysis\.vary.*: expected a non-empty mapping"),
    ({"analysis__vary": {"analysis.harmonics": [1, 0]}}, r"analysis\.vary.*: expected settings that each give a valid "
                                                         r"scene, found 'H=0'.*analysis\.harmonics"),
    ({"analysis__quantities": [{"type": "peek"}]}, r"analysis\.quantities\[0\]\.type.*: expected one of peak.*'peek'"),
    ({"analysis__quantities": [{"type": "fold", "indx": 1}]}, r"analysis\.quantities\[0\]\.indx"),
    ({"analysis__quantities": []}, r"analysis\.quantities.*: expected a non-empty list"),
    ({"analysis__base": {"type": "modes"}}, r"analysis\.base\.type.*: expected one of 'frequency_response'"),
    ({"analysis__base": {"type": "frequency_response"}}, r"analysis\.base\.range.*: expected .*required"),
    ({"analysis__reference": {"analysis.samples": 64}}, r"analysis\.reference\.analysis\.samples.*: expected a setting "
                                                        r"path of analysis\.vary"),
    ({"analysis__combine": "zip", "analysis__vary": {"analysis.harmonics": [1, 3], "analysis.samples": [64]}},
     r"lists of equal length"),
    ({"analysis__budget": -1}, r"analysis\.budget.*: expected a positive number"),
    ({"analysis__repeat": 0}, r"analysis\.repeat"),
    ({"analysis__tolerance": 1}, r"analysis\.tolerance.*: expected one of the keys"),
]


@pytest.mark.parametrize("changes, match", BAD)
def test_bad_input_names_the_key(tmp_path, changes, match):
    path = write(tmp_path, DUFFING, **changes)
    with pytest.raises(SceneError, match=match):
        parse_scene(path.read_text())


def test_bad_budget_and_unknown_column(tmp_path, capsys):
    path = write(tmp_path, DUFFING)
    assert main(["run", str(path), "-o", str(tmp_path / "o"), "-q", "--budget", "-1"]) == 2
    assert "--budget: expected a positive finite number" in capsys.readouterr().err
    other = ROOT / "scenes" / "duffing.yaml"
    assert main(["run", str(other), "-o", str(tmp_path / "o2"), "-q", "--budget", "1e-3"]) == 2
    assert "--budget: expected a convergence scene" in capsys.readouterr().err
    bad = write(tmp_path, DUFFING, "bad.yaml", analysis__vary={"analysis.harmonics": [1]},
                analysis__reference=None, analysis__warmup=False,
                analysis__quantities=[{"type": "peak", "measure": "amp_y"}])
    assert main(["run", str(bad), "-o", str(tmp_path / "o3"), "-q"]) == 2
    assert "measure 'amp_y' is not a column of branches.csv" in " ".join(capsys.readouterr().err.split())


def test_shipped_convergence_scenes_check():
    for path in sorted((ROOT / "scenes").glob("convergence_*.yaml")):
        assert main(["check", str(path)]) == 0, path
