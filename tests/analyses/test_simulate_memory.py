"""A ``simulate`` scene run in memory writes nothing and holds what a directory run writes; ``contin check``."""

import numpy as np
from memory_runs import run_both_ways

from contin.app.cli import main
from contin.scene.parse import parse_scene

#: x'' + c x' + x = F cos(w t): the steady amplitude F / |1 - w^2 + i c w|
SCENE = """
model:
  dofs: [x]
  parameters: {c: 0.1, F: 0.5, w: 1.0}
  mass: [[1]]
  damping: [[c]]
  stiffness: [[1]]
  excitation:
    - {dof: x, amplitude: F, order: 1}
  frequency: w
analysis:
  type: simulate
  parameter: w
  values: [0.8, 1.3]
  steps_per_period: 64
  samples_per_period: 8
  transient: 60
  record: 8
  initial: previous
output: {plots: false}
"""

#: the wall-clock columns, which differ between two runs
TIMES = ("wall_time", "cost_per_period_us")


def test_a_simulate_run_in_memory_writes_nothing_and_holds_the_table_and_windows_of_the_files(tmp_path,
                                                                                              monkeypatch):
    on_disk, held = run_both_ways(parse_scene(SCENE), tmp_path, monkeypatch, skip=TIMES)
    assert held.status == "complete"
    assert on_disk.data is None  # the windows are the files simulation_<i>.npz
    rows = held.tables["simulation.csv"]
    w = rows["w"]
    # sampled 8 times a period, the half range lies between A cos(pi/8) and A
    A = 0.5 / np.abs(1 - w**2 + 0.1j * w)
    assert np.all((rows["amp_x"] >= A * np.cos(np.pi / 8)) & (rows["amp_x"] <= A * (1 + 1e-6)))
    # each value's recorded window, in memory, is the file's
    assert sorted(k for k in held.data if k.startswith("simulation_")) == ["simulation_0", "simulation_1"]
    for i in range(2):
        with np.load(tmp_path / "d" / f"simulation_{i}.npz") as f:
            window = held.data[f"simulation_{i}"]
            assert sorted(window) == sorted(f.files)
            for key in f.files:
                assert np.asarray(window[key]).tobytes() == f[key].tobytes(), key


def test_check_prints_no_plan_lines_for_simulate(tmp_path, capsys):
    path = tmp_path / "simulate.yaml"
    path.write_text(SCENE)
    assert main(["check", str(path)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == "analysis: simulate"
