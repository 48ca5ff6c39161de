"""An ``frf`` scene run in memory writes nothing and holds the table a directory run writes; ``contin check``."""

import numpy as np
from memory_runs import run_both_ways

from contin.app.cli import main
from contin.scene.parse import parse_scene

#: a main mass with a damped absorber, forced on the main mass: X = Z(w)^-1 F, Z = K - w^2 M + i w C
SCENE = """
model:
  dofs: [x1, x2]
  parameters: {m1: 1.0, m2: 0.1, k1: 1.0, k2: 0.08, c2: 0.02, F: 1.0, w: 1.0}
  mass: [[m1, 0], [0, m2]]
  damping: [[c2, -c2], [-c2, c2]]
  stiffness: [[k1 + k2, -k2], [-k2, k2]]
  excitation: [{dof: x1, expr: "F*cos(tau)"}]
analysis:
  type: frf
  range: [0.5, 1.5]
  points: 200
output: {plots: false}
"""


def test_an_frf_run_in_memory_writes_nothing_and_holds_the_table_of_the_file(tmp_path, monkeypatch):
    on_disk, held = run_both_ways(parse_scene(SCENE), tmp_path, monkeypatch)
    assert held.status == "complete"
    assert list(held.tables) == ["frf.csv"]
    assert held.analysis == on_disk.analysis
    assert len(held.analysis["peaks"]) == 4 and len(held.analysis["fixed_points"]) == 2
    rows = held.tables["frf.csv"]
    M, C, K = np.diag([1.0, 0.1]), 0.02 * np.array([[1, -1], [-1, 1]]), np.array([[1.08, -0.08], [-0.08, 0.08]])
    X = np.array([np.linalg.solve(K - w**2 * M + 1j * w * C, [1.0, 0.0]) for w in rows["w"]])
    np.testing.assert_allclose(rows["re_x1"] + 1j * rows["im_x1"], X[:, 0], rtol=1e-10)
    np.testing.assert_allclose(rows["re_x2"] + 1j * rows["im_x2"], X[:, 1], rtol=1e-10)


def test_check_prints_the_frf_plan(tmp_path, capsys):
    path = tmp_path / "frf.yaml"
    path.write_text(SCENE)
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[-2:] == ["analysis: frf",
                        "  impedance-matrix FRF over [0.5, 1.5] (200 points, linear), force: the model's excitation"]
    path.write_text(SCENE.replace("  points: 200\n", "  points: 20\n  spacing: log\n  force: [x1, x2]\n"))
    assert main(["check", str(path)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == (
        "  impedance-matrix FRF over [0.5, 1.5] (20 points, log), force: ['x1', 'x2']")
