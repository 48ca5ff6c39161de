"""``analysis.type: frf`` against the closed forms of seeds 002 and 000."""

import math

import numpy as np
import pytest

from contin.output.results import read_csv
from contin.app.runner import run_scene
from contin.scene.parse import SceneError, parse_scene

SEED002 = """
model:
  builtin: linear_chain
  parameters: {m1: 1, m2: 2, k1: 1, k2: 1, k3: 2, F1: 1, F2: 0}
  effects: [forcing]
analysis:
  type: frf
  range: [0.05, 2.5]
  points: 300
"""


def run(text, tmp_path, name="out"):
    summary = run_scene(parse_scene(text), tmp_path / name, progress=False)
    return summary, read_csv(tmp_path / name / "frf.csv")


def test_seed002_example_x1_x2(tmp_path):
    """X1 = (3k - 2 w^2 m) F0/(2 m^2 w^4 - 7 m k w^2 + 5 k^2), X2 = k F0/(...) (seed 002, sec. 4.3)."""
    summary, rows = run(SEED002, tmp_path)
    w = rows["w"]
    den = 2 * w**4 - 7 * w**2 + 5
    np.testing.assert_allclose(rows["re_x1"], (3 - 2 * w**2) / den, rtol=1e-10)
    np.testing.assert_allclose(rows["re_x2"], 1 / den, rtol=1e-10)
    np.testing.assert_allclose(rows["amp_x1"], np.abs((3 - 2 * w**2) / den), rtol=1e-10)
    assert np.all(np.abs(rows["im_x1"]) <= 1e-14 * rows["amp_x1"])  # real up to rounding
    # undamped: in phase (0) below w1, in antiphase (+-180) between the resonances for x2
    assert np.all(np.abs(rows["phase_x2"][w < 1]) < 1e-9)
    assert np.all(np.abs(np.abs(rows["phase_x2"][(w > 1) & (w < math.sqrt(2.5))]) - 180) < 1e-9)
    np.testing.assert_allclose(summary["analysis"]["natural_frequencies"], [1.0, math.sqrt(2.5)], rtol=1e-13)
    assert summary["analysis"]["peaks"] == []  # undamped: unbounded at the resonances, no finite peak
    assert set(rows["case"]) == {"excitation"}


def test_force_on_each_dof_gives_the_receptance_columns(tmp_path):
    text = SEED002.replace("  points: 300", "  points: 50\n  force: [x1, x2]")
    _, rows = run(text, tmp_path)
    w = rows["w"][rows["case"] == "x2"]
    den = 2 * w**4 - 7 * w**2 + 5
    # a unit force on x2: X1 = -Z12/det = k/det, X2 = Z11/det = (2k - w^2 m)/det (seed 002, sec. 4.2)
    np.testing.assert_allclose(rows["re_x1"][rows["case"] == "x2"], 1 / den, rtol=1e-10)
    np.testing.assert_allclose(rows["re_x2"][rows["case"] == "x2"], (2 - w**2) / den, rtol=1e-10)
    # reciprocity: X1 for a force on x2 equals X2 for a force on x1
    np.testing.assert_allclose(rows["re_x1"][rows["case"] == "x2"], rows["re_x2"][rows["case"] == "x1"], rtol=1e-12)
    text = SEED002.replace("  points: 300", "  points: 20\n  force: {x1: 2.0, x2: -0.5}")
    _, rows = run(text, tmp_path, "mix")
    w = rows["w"]
    den = 2 * w**4 - 7 * w**2 + 5
    np.testing.assert_allclose(rows["re_x1"], (2 * (3 - 2 * w**2) - 0.5 * 1) / den, rtol=1e-10)
    assert set(rows["case"]) == {"2*x1+-0.5*x2"}


def test_absorber_exercise_peak_and_closed_form(tmp_path):
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    text = (root / "scenes" / "absorber_exercise_frf.yaml").read_text()
    summary, rows = run(text, tmp_path)
    m1, k1, m2, F = 100.0, 5e5, 10.0, 1.0
    beta, p = m2 / m1, math.sqrt(k1 / m1)
    mu, zeta = 1 / (1 + beta), math.sqrt(3 * beta / (8 * (1 + beta) ** 3))
    O = rows["w"] / p
    ref = np.sqrt(((mu**2 - O**2) ** 2 + 4 * zeta**2 * O**2)
                  / (((1 - O**2) * (mu**2 - O**2) - beta * mu**2 * O**2) ** 2
                     + 4 * zeta**2 * O**2 * (1 - (1 + beta) * O**2) ** 2))  # seed 000, sec. 7.3
    np.testing.assert_allclose(rows["amp_x1"] / (F / k1), ref, rtol=1e-11)
    pk = [q for q in summary["analysis"]["peaks"] if q["dof"] == "x1"]
    assert len(pk) == 2
    height = math.sqrt((2 + beta) / beta)
    top = max(q["amplitude"] for q in pk) / (F / k1)
    assert height < top < 1.002 * height  # the true peak, slightly above the fixed points
    from contin.modal.absorber_design import design_absorber

    assert top == pytest.approx(design_absorber(m1, k1, m2).true_peak.amplification, rel=1e-10)
    # normalise: static divides by delta_st = F/k1; the fixed points P, Q sit at sqrt((2+beta)/beta)
    assert summary["analysis"]["static_deflection"] == [pytest.approx(F / k1, rel=1e-12)]
    fixed = summary["analysis"]["fixed_points"]
    assert [f["name"] for f in fixed] == ["P", "Q"] and {f["dof"] for f in fixed} == {"x1"}
    assert [f["ratio"] for f in fixed] == [pytest.approx(height, rel=1e-9)] * 2
    assert summary["plots"] == ["frf.png"]


def test_fixed_points_are_where_the_undamped_and_the_locked_responses_cross():
    """P and Q of Den Hartog's absorber (seed 000, sec. 7.4) from the scene's linear model, not the formula."""
    from pathlib import Path
    from types import SimpleNamespace

    from contin.analyses.frf import ForceResponse, Frf, fixed_points
    from contin.modal.absorber import fixed_point_height, fixed_points as closed_form
    from contin.modal.absorber_design import design_absorber
    from contin.scene.build import build_model

    root = Path(__file__).resolve().parents[2]
    scene = parse_scene((root / "scenes" / "absorber_exercise_frf.yaml").read_text())
    model = build_model(scene)
    plan = Frf().plan(scene, model)
    resp = ForceResponse(model, plan.index, plan.parameters, plan.cases[0][1])
    found = fixed_points(resp, plan.grid, 0)
    m1, k1, m2 = 100.0, 5e5, 10.0
    beta, p = m2 / m1, math.sqrt(k1 / m1)
    (OP, OQ), _ = closed_form(beta, 1 / (1 + beta))
    np.testing.assert_allclose([w for w, _ in found], [OP * p, OQ * p], rtol=1e-10)
    np.testing.assert_allclose([a for _, a in found], [fixed_point_height(beta) / k1] * 2, rtol=1e-9)
    # the fixed points of the damping-free design and of its FRF agree (the absorber's own matrices)
    d = design_absorber(m1, k1, m2)
    alone = SimpleNamespace(MCK=d.matrices(), F=np.array([1.0, 0.0]))
    found = fixed_points(alone, np.linspace(0.5 * d.p, 1.5 * d.p, 101), 0)
    np.testing.assert_allclose(found, [(d.P.w, d.P.height / k1), (d.Q.w, d.Q.height / k1)], rtol=1e-9)
    # no damper, no fixed points: the crossings of an undamped response with itself are not sought
    assert fixed_points(SimpleNamespace(MCK=(d.matrices()[0], 0 * d.matrices()[1], d.matrices()[2]),
                                        F=np.array([1.0, 0.0])), np.linspace(40, 110, 71), 0) == []


def test_frequency_dependent_force_and_gyroscopic_matrices(tmp_path):
    """An unbalance-like force e w^2 and a gyroscopic w G term: each frequency uses its own Z and F."""
    text = """
model:
  dofs: [x, y]
  parameters: {m: 1.0, c: 0.05, k: 1.0, e: 0.1, g: 0.3, w: 1.0}
  mass: [[m, 0], [0, m]]
  damping: [[c, 0], [0, c]]
  stiffness: [[k, 0], [0, k]]
  gyroscopic: {matrix: [[0, g], ["-g", 0]], speed: w}
  excitation:
    - {dof: x, expr: "e*w**2*cos(tau)"}
    - {dof: y, expr: "e*w**2*sin(tau)"}
analysis:
  type: frf
  range: [0.2, 2.0]
  points: 40
"""
    _, rows = run(text, tmp_path)
    for w, rx, ix, ry, iy in zip(rows["w"], rows["re_x"], rows["im_x"], rows["re_y"], rows["im_y"]):
        Z = np.array([[1 - w**2 + 0.05j * w, 0.3j * w**2], [-0.3j * w**2, 1 - w**2 + 0.05j * w]])
        F = 0.1 * w**2 * np.array([1.0, -1j])  # e w^2 (cos, sin) = Re(e w^2 (1, -i) e^{iwt})
        X = np.linalg.solve(Z, F)
        np.testing.assert_allclose([rx + 1j * ix, ry + 1j * iy], X, rtol=1e-11)


def test_undamped_resonance_on_the_grid_is_left_out_not_nan(tmp_path):
    text = SEED002.replace("  range: [0.05, 2.5]\n  points: 300", "  range: [0.0, 2.0]\n  points: 21")
    summary, rows = run(text, tmp_path)
    assert summary["analysis"]["skipped_singular"] == [1.0]
    assert 1.0 not in rows["w"] and len(rows["w"]) == 20
    assert np.all(np.isfinite(rows["amp_x1"]))


@pytest.mark.parametrize("change, key, match", [
    ("  force: x9", "analysis.force", r"dof names among \['x1', 'x2'\]"),
    ("  force: 3", "analysis.force", "a dof name"),
    ("  spacing: log", "analysis.range", "a start above 0 for spacing: log"),
    ("  frequency: nope", "analysis.frequency", "a parameter of the model"),
    ("  pointz: 3", "analysis.pointz", "unknown key 'pointz'"),
    ("  scale: db", "analysis.scale", "one of 'log', 'linear'"),
])
def test_bad_input_names_the_key(change, key, match, tmp_path):
    text = SEED002.replace("  range: [0.05, 2.5]", "  range: [0.0, 2.5]") + change + "\n"
    with pytest.raises(SceneError, match=match) as exc:
        run(text, tmp_path)
    assert str(exc.value).startswith(key)


def test_range_must_be_increasing_and_the_model_linear(tmp_path):
    with pytest.raises(SceneError, match=r"^analysis.range \(line 8\): expected a list of two numbers \[start, end\]"):
        run(SEED002.replace("[0.05, 2.5]", "[2.5, 0.05]"), tmp_path)
    with pytest.raises(SceneError, match="^model: expected a linear model for analysis.type frf.*cubic"):
        run("model: {builtin: duffing}\nanalysis: {type: frf, range: [0.5, 2]}\n", tmp_path)
    with pytest.raises(SceneError, match="^analysis.force: .*the model has no excitation"):
        run(SEED002.replace("effects: [forcing]", "effects: []"), tmp_path)
    with pytest.raises(SceneError, match=r"^analysis.normalise \(line \d+\): expected a model with a static "
                                         "deflection under the force"):
        run(SEED002 + "  force: x1\n  normalise: static\n".replace("x1", "{x1: 0.0}"), tmp_path)


def test_the_frequency_named_by_the_analysis_is_used_and_the_model_keeps_its_own(tmp_path):
    """analysis.frequency: W forces at W (tau = W t) over the range of W; the model's frequency stays w."""
    from contin.analyses.frf import Frf
    from contin.scene.build import build_model

    text = """
model:
  dofs: [x]
  parameters: {m: 1.0, c: 0.1, k: 2.0, F: 0.5, w: 3.0, W: 1.0}
  mass: [[m]]
  damping: [[c]]
  stiffness: [[k]]
  excitation: [{dof: x, expr: "F*cos(tau)"}]
analysis:
  type: frf
  frequency: W
  range: [0.2, 3.0]
  points: 30
"""
    scene = parse_scene(text)
    model = build_model(scene)
    plan = Frf().plan(scene, model)
    assert plan.frequency == "W" and model.frequency == "w"
    _, rows = run(text, tmp_path)
    W = rows["W"]
    np.testing.assert_allclose(rows["re_x"] + 1j * rows["im_x"], 0.5 / (2.0 - W**2 + 0.1j * W), rtol=1e-12)
