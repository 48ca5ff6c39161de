"""``analysis.type: modes`` on built-in and custom models, against closed forms."""

import json
import math

import numpy as np
import pytest
import scipy.linalg

from contin.output.results import read_csv
from contin.app.runner import run_scene
from contin.analyses.base import RunError
from contin.scene.parse import SceneError, parse_scene

SEED002 = """
model:
  builtin: linear_chain
  parameters: {m1: 1.5, m2: 3.0, k1: 20, k2: 20, k3: 40, c1: 0.3, c2: 0.1, c3: 0.2}
  effects: [damping, forcing]
analysis:
  type: modes
"""


def run(text, tmp_path, name="out"):
    scene = parse_scene(text)
    summary = run_scene(scene, tmp_path / name, progress=False)
    out = tmp_path / name
    damped = read_csv(out / "damped_modes.csv") if (out / "damped_modes.csv").exists() else None
    return summary, read_csv(out / "modes.csv"), damped


def test_seed002_example_frequencies_ratios_and_damped_eigenvalues(tmp_path):
    summary, modes, damped = run(SEED002, tmp_path)
    m, k = 1.5, 20.0
    np.testing.assert_allclose(modes["omega"], [math.sqrt(k / m), math.sqrt(5 / 2) * math.sqrt(k / m)], rtol=1e-13)
    np.testing.assert_allclose(modes["ratio_x2"], [1.0, -0.5], atol=1e-13)  # r_i of seed 002
    np.testing.assert_allclose(modes["frequency_hz"], modes["omega"] / (2 * np.pi), rtol=1e-15)
    np.testing.assert_allclose(modes["static_x1"], 0.0)
    # mass-normalised shapes
    S = np.vstack([modes["shape_x1"], modes["shape_x2"]])
    np.testing.assert_allclose(S.T @ np.diag([m, 2 * m]) @ S, np.eye(2), atol=1e-13)
    # damped eigenvalues: those of the state matrix [[0, I], [-M^-1 K, -M^-1 C]]
    M = np.diag([m, 2 * m])
    C = np.array([[0.4, -0.1], [-0.1, 0.3]])
    K = np.array([[2 * k, -k], [-k, 3 * k]])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    ref = scipy.linalg.eigvals(A)
    got = damped["re"] + 1j * damped["im"]
    for r in ref:
        assert np.min(np.abs(got - r)) < 1e-10 * np.abs(r)
    assert len(got) == 4 and np.all(damped["re_x1"] == 1.0)
    assert summary["analysis"]["results"][0]["stable"] is True
    assert summary["analysis"]["results"][0]["proportional_damping"] is False
    assert summary["plots"] == ["mode_shapes.png"]


def test_versus_a_parameter_follows_the_frequency_equation(tmp_path):
    text = SEED002.replace("  type: modes", "  type: modes\n  parameter: k2\n  range: [1.0, 60.0]\n  points: 7")
    summary, modes, _ = run(text, tmp_path)
    m1, m2, k1, k3 = 1.5, 3.0, 20.0, 40.0
    k2 = modes["k2"]
    k11, k22, k12 = k1 + k2, k2 + k3, -k2
    b = (m1 * k22 + m2 * k11) / (m1 * m2)  # seed 002, sec. 2.2
    disc = np.sqrt(b**2 - 4 * (k11 * k22 - k12**2) / (m1 * m2))
    w = np.where(modes["mode"] == 1, np.sqrt(b / 2 - disc / 2), np.sqrt(b / 2 + disc / 2))
    np.testing.assert_allclose(modes["omega"], w, rtol=1e-12)
    assert sorted(set(modes["index"])) == list(range(7))
    assert set(summary["plots"]) == {"mode_shapes.png", "natural_frequencies.png"}


def test_nonlinear_model_is_linearised_about_its_static_equilibrium(tmp_path):
    """m x'' + c x' + k x + g x^3 = P: w^2 = (k + 3 g x_e^2)/m at the root of k x + g x^3 = P."""
    text = """
model:
  dofs: [x]
  parameters: {m: 2.0, c: 0.1, k: 3.0, g: 0.8, P: 1.0, F: 0.4, w: 1.0}
  mass: [[m]]
  damping: [[c]]
  stiffness: [[k]]
  forces: [{dof: x, expr: "g*x**3"}]
  excitation: [{dof: x, expr: "P + F*cos(tau)"}]
analysis:
  type: modes
  parameter: P
  values: [0.0, 1.0, 5.0, 20.0]
"""
    summary, modes, damped = run(text, tmp_path)
    for P, x, w in zip(modes["P"], modes["static_x"], modes["omega"]):
        r = np.roots([0.8, 0.0, 3.0, -P])
        xe = r[np.abs(r.imag) < 1e-12].real[0]
        assert x == pytest.approx(xe, abs=1e-12 * max(1, abs(xe)))
        assert w == pytest.approx(math.sqrt((3.0 + 3 * 0.8 * xe**2) / 2.0), rel=1e-10)
    assert summary["analysis"]["completed"] == 4


def test_a_fold_of_the_equilibrium_ends_the_run_with_what_was_computed(tmp_path):
    text = """
model:
  dofs: [x]
  parameters: {k: 1.0, g: 1.0, P: 0.0, w: 1.0}
  mass: [[1]]
  stiffness: [[k]]
  forces: [{dof: x, expr: "-g*x**3"}]
  excitation: [{dof: x, expr: "P"}]
analysis:
  type: modes
  parameter: P
  values: [0.0, 0.2, 0.3, 0.5]
"""
    summary, modes, _ = run(text, tmp_path)
    assert summary["status"] == "interrupted"
    assert summary["analysis"]["completed"] == 3
    assert "folds at P = 0.3849" in summary["analysis"]["failure"]  # 2/(3 sqrt 3)
    # a divergent mode is reported past the fold... here the softening makes w fall towards 0
    assert np.all(np.diff(modes["omega"]) < 0)


def test_no_equilibrium_at_the_first_value_is_a_run_error(tmp_path):
    text = """
model:
  dofs: [x]
  parameters: {k: 1.0, g: 1.0, P: 2.0, w: 1.0}
  mass: [[1]]
  stiffness: [[k]]
  forces: [{dof: x, expr: "-g*x**2"}]
  excitation: [{dof: x, expr: "P"}]
analysis: {type: modes}
"""
    with pytest.raises(RunError, match="no static equilibrium found at w = 1 from zero displacement"):
        run(text, tmp_path)


@pytest.mark.parametrize("change, key, match", [
    ("  frobnicate: 1", "analysis.frobnicate", "unknown key 'frobnicate'"),
    ("  values: [1, 2]", "analysis.parameter", "the parameter that analysis.values varies"),
    ("  parameter: k9", "analysis.parameter", "a parameter of the model"),
    ("  parameter: k2\n  values: [1]\n  range: [1, 2]", "analysis.values", "either values or range"),
    ("  reference: x7", "analysis.reference", r"one of the dofs \['x1', 'x2'\]"),
    ("  guess: [0.0]", "analysis.guess", "2 numbers"),
    ("  tolerance: -1", "analysis.tolerance", "a positive number"),
    ("  points: 1", "analysis.points", "an integer from 2"),
])
def test_bad_input_names_the_key(change, key, match, tmp_path):
    text = SEED002.replace("  type: modes", "  type: modes\n" + change)
    with pytest.raises(SceneError, match=match) as exc:
        run(text, tmp_path)
    assert str(exc.value).startswith(key)


def test_time_varying_force_is_refused_naming_the_model(tmp_path):
    text = "model: {builtin: mathieu}\nanalysis: {type: modes}\n"
    with pytest.raises(SceneError, match=r"^model: .*forces that vary in time"):
        run(text, tmp_path)


def test_summary_has_no_nan(tmp_path):
    summary, _, _ = run(SEED002, tmp_path)
    text = (tmp_path / "out" / "summary.json").read_text()
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text)["analysis"]["natural_frequencies"][1] == pytest.approx(math.sqrt(2.5 * 20 / 1.5))
