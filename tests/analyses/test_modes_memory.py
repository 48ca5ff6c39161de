"""A ``modes`` scene run in memory writes nothing and holds the tables a directory run writes; ``contin check``."""

import math

import numpy as np
from memory_runs import run_both_ways

from contin.app.cli import main
from contin.scene.parse import parse_scene

#: m x'' + c x' + k x + g x^3 = P + F cos(tau): about the root x_e of k x + g x^3 = P, w^2 = (k + 3 g x_e^2) / m
SCENE = """
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
  values: [0.0, 1.0, 5.0]
output: {plots: false}
"""


def test_a_modes_run_in_memory_writes_nothing_and_holds_the_tables_of_the_files(tmp_path, monkeypatch):
    on_disk, held = run_both_ways(parse_scene(SCENE), tmp_path, monkeypatch)
    assert held.status == "complete"
    assert sorted(held.tables) == ["damped_modes.csv", "modes.csv"]
    assert held.analysis == on_disk.analysis
    modes = held.tables["modes.csv"]
    for P, w in zip(modes["P"], modes["omega"]):
        r = np.roots([0.8, 0.0, 3.0, -P])
        xe = r[np.abs(r.imag) < 1e-12].real[0]
        assert math.isclose(w, math.sqrt((3.0 + 3 * 0.8 * xe**2) / 2.0), rel_tol=1e-10)


def test_check_prints_the_modes_plan(tmp_path, capsys):
    path = tmp_path / "modes.yaml"
    path.write_text(SCENE)
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[-2:] == ["analysis: modes",
                        "  natural frequencies and modes about the static equilibrium versus P; damped eigenvalues"]
    path.write_text(SCENE.replace("  parameter: P\n  values: [0.0, 1.0, 5.0]\n", "  damped: false\n"))
    assert main(["check", str(path)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == (
        "  natural frequencies and modes about the static equilibrium at the model's parameters")
