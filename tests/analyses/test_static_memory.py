"""A ``static`` scene run in memory writes nothing and holds the tables a directory run writes; ``contin check``."""

import math

import numpy as np
import pytest
from memory_runs import FileCreated, run_both_ways

from contin.app.cli import main
from contin.scene.parse import parse_scene

#: x + (-g) x^3 = P, softening: limit loads at P = +-2/(3 sqrt 3) (d/dx (x - x^3) = 0 at x = 1/sqrt 3)
SCENE = """
model:
  dofs: [x]
  parameters: {k: 1.0, g: 1.0, P: 0.0, w: 1.0}
  mass: [[1]]
  stiffness: [[k]]
  forces: [{dof: x, expr: "-g*x**3"}]
  excitation: [{dof: x, expr: "P"}]
analysis:
  type: static
  parameter: P
  range: [-0.5, 0.5]
  start: 0.0
  both_ways: true
  continuation: {ds: 0.05, ds_max: 0.2}
output: {plots: false}
"""


def test_a_static_run_in_memory_writes_nothing_and_holds_the_tables_of_the_files(tmp_path, monkeypatch):
    on_disk, held = run_both_ways(parse_scene(SCENE), tmp_path, monkeypatch)
    assert held.status == "complete"
    with pytest.raises(FileCreated):  # the guard holds
        open(tmp_path / "probe", "w")
    assert held.analysis == on_disk.analysis
    assert held.summary["analysis"]["shortfalls"] == held.shortfalls == []
    folds = held.tables["special_points.csv"]["P"][held.tables["special_points.csv"]["kind"] == "fold"]
    np.testing.assert_allclose(np.sort(folds), [-2 / (3 * math.sqrt(3)), 2 / (3 * math.sqrt(3))], rtol=1e-8)


def test_check_prints_the_static_plan(tmp_path, capsys):
    path = tmp_path / "static.yaml"
    path.write_text(SCENE)
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[-2:] == ["analysis: static", "  equilibria (H = 0) in P over [-0.5, 0.5]; unknowns: 1 dof"]
