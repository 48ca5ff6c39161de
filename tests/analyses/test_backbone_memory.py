"""A ``backbone`` scene run in memory writes nothing and holds the tables a directory run writes; ``contin check``."""

import numpy as np
from memory_runs import run_both_ways
from scipy.special import ellipk

from contin.app.cli import main
from contin.scene.parse import parse_scene

#: x'' + k x + g x^3 = 0: the free oscillation of amplitude A has the frequency
#: w = pi sqrt(k + g A^2) / (2 K(m)), m = g A^2 / (2 (k + g A^2)) (Jacobi's cn solution)
SCENE = """
model:
  dofs: [x]
  parameters: {k: 1.0, g: 0.5, w: 1.0}
  mass: [[1]]
  stiffness: [[k]]
  forces: [{dof: x, expr: "g*x**3"}]
analysis:
  type: backbone
  dof: x
  range: [0.01, 1.0]
  harmonics: 5
  continuation: {ds: 0.05, ds_max: 0.3}
output: {plots: false}
"""


def test_a_backbone_run_in_memory_writes_nothing_and_holds_the_tables_of_the_files(tmp_path, monkeypatch):
    on_disk, held = run_both_ways(parse_scene(SCENE), tmp_path, monkeypatch)
    assert held.status == "complete"
    assert sorted(held.tables) == ["branches.csv", "special_points.csv"]
    assert held.analysis == on_disk.analysis
    rows = held.tables["branches.csv"]
    A = rows["amplitude"]
    m = 0.5 * A**2 / (2 * (1 + 0.5 * A**2))
    np.testing.assert_allclose(rows["frequency"], np.pi * np.sqrt(1 + 0.5 * A**2) / (2 * ellipk(m)), rtol=1e-6)


def test_check_prints_the_backbone_plan(tmp_path, capsys):
    path = tmp_path / "backbone.yaml"
    path.write_text(SCENE)
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[-2:] == ["analysis: backbone",
                        "  free periodic solutions of mode(s) 1, peak amplitude of x over [0.01, 1.0] (log spacing), "
                        "harmonics H=5; unknowns: 13 = 1 dof x (2H+1) + frequency + unfolding parameter"]
