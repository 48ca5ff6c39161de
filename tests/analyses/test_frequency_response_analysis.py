"""``analysis.type: frequency_response``: the scene's frequency goes to the problem, not into the model."""

import numpy as np

from contin.analyses.frequency_response import build_problem
from contin.app.runner import run_scene
from contin.output.results import read_csv
from contin.scene.build import build_model
from contin.scene.parse import parse_scene

SCENE = """
model:
  dofs: [x]
  parameters: {m: 1.0, c: 0.2, k: 2.0, F: 0.5, w: 3.0, W: 0.5}
  mass: [[m]]
  damping: [[c]]
  stiffness: [[k]]
  excitation: [{dof: x, expr: "F*cos(tau)"}]
analysis:
  type: frequency_response
  frequency: W
  range: [0.5, 2.5]
  harmonics: 1
  stability: none
"""


def test_the_frequency_named_by_the_analysis_is_the_problems_alone(tmp_path):
    scene = parse_scene(SCENE)
    model = build_model(scene)
    hb = build_problem(scene, model)
    assert (hb.parameter, hb.frequency, hb.frequency_moves) == ("W", "W", True)
    assert model.frequency == "w"  # the model keeps its declared frequency
    run_scene(scene, tmp_path / "out", progress=False)
    rows = read_csv(tmp_path / "out" / "branches.csv")
    W = rows["W"]
    # the linear oscillator forced at W: |X| = F / |k - W^2 m + i W c|
    np.testing.assert_allclose(rows["amp_x"], 0.5 / np.abs(2.0 - W**2 + 0.2j * W), rtol=1e-9)
