"""``simulate``: a value whose response is not settled is a shortfall of the run, named with its parameter value.

Truth from outside the code: the damped linear oscillator's amplitude
``F / |1 - w^2 + i c w|`` (closed form); a stop of stiffness 1e4 written as an
expression, integrated with ``h sqrt(kc) = 4.9`` (beyond RK4's stability
limit 2.8), whose energy grows by tens of orders of magnitude over the record.
"""

import csv
import json

import pytest

from contin.app.cli import main
from contin.app.runner import run_scene
from contin.output.results import read_csv
from contin.scene.parse import parse_scene

SCENE = """
model:
  dofs: [x]
  parameters: {c: 0.1, kc: KC, g: 0.5, F: 0.5, w: 1.0}
  mass: [[1]]
  damping: [[c]]
  stiffness: [[1]]
  forces:
    - {dof: x, expr: "kc*max(x - g, 0)"}
  excitation:
    - {dof: x, amplitude: F, order: 1}
  frequency: w
analysis:
  type: simulate
  parameter: w
  values: VALUES
  steps_per_period: 128
  samples_per_period: 8
  transient: 200
  record: 40
  initial: [0.01, 0.0]
output: {plots: false}
"""


def test_a_simulation_that_blows_up_is_not_settled_and_the_run_is_incomplete(tmp_path):
    path = tmp_path / "stop.yaml"
    path.write_text(SCENE.replace("KC", "1.0e4").replace("VALUES", "[1.0]"))
    out = tmp_path / "out"
    assert main(["run", str(path), "-o", str(out), "-q"]) == 1
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "incomplete"
    (line,) = s["shortfalls"]
    assert line.startswith("simulation at w = 1 not settled: its amplitude grows over the record")
    assert "the result depends on the step" in line and "raise steps_per_period" in line
    rows = read_csv(out / "simulation.csv")
    assert list(rows["settled"]) == [False]
    assert rows["amp_x"][0] > 1e10 and rows["growth"][0] > 10 and rows["step_change"][0] > 0.1
    assert rows["unsettled"][0] == line.split("not settled: ", 1)[1]
    (r,) = s["analysis"]["results"]
    assert r["settled"] is False and r["unsettled"] == rows["unsettled"][0]


def test_a_settled_damped_linear_oscillator_keeps_the_run_complete(tmp_path):
    # the stop far out of reach (kc = 0): a damped linear oscillator at two speeds
    scene = parse_scene(SCENE.replace("KC", "0.0").replace("VALUES", "[0.8, 1.2]")
                        .replace("transient: 200", "transient: 150").replace("steps_per_period: 128",
                                                                             "steps_per_period: 256"))
    s = run_scene(scene, tmp_path / "out", progress=False)
    assert s["status"] == "complete" and s["shortfalls"] == []
    rows = read_csv(tmp_path / "out" / "simulation.csv")
    assert list(rows["settled"]) == [True, True]
    with open(tmp_path / "out" / "simulation.csv", newline="") as fh:
        assert [r["unsettled"] for r in csv.DictReader(fh)] == ["", ""]
    for w, fwd, bwd, change in zip(rows["w"], rows["whirl_fwd_1"], rows["whirl_bwd_1"], rows["step_change"]):
        # x = A cos(w t + phi): its components at +w and -w have modulus A/2 each
        assert fwd + bwd == pytest.approx(0.5 / abs(1 - w * w + 0.1j * w), rel=1e-7)
        assert change < 1e-6
