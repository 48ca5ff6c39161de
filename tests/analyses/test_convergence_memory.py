"""The convergence analysis held in memory: its runs held in memory too, no file written, the same table."""

from pathlib import Path

import numpy as np
import pytest

from contin.app.cli import main
from contin.output.results import read_csv
from contin.scene.parse import load_scene, parse_scene
from contin.scene.schema import SceneError

from memory_runs import run_both_ways

ROOT = Path(__file__).resolve().parents[2]
C, K, B3, F = 0.1, 1.0, 0.75, 0.5


def fold_forces(w):
    """Forcing amplitudes of the two H = 1 folds of x'' + 0.1 x' + x + x^3 = F cos(w t) at frequency w."""
    s = K - w * w
    disc = s * s - 3 * (C * w) ** 2
    X = np.array([(-2 * s + sg * np.sqrt(disc)) / (3 * B3) for sg in (1, -1)])
    return np.sqrt(((s + B3 * X) ** 2 + (C * w) ** 2) * X)

#: the Duffing study made small: H = 1 against H = 3, one run each, no warm-up
DUFFING = ["analysis.vary={analysis.harmonics: [1]}", "analysis.reference={analysis.harmonics: 3}",
           "analysis.warmup=false", "analysis.repeat=1", "analysis.base.continuation={ds_max: 0.1}"]
#: the columns that differ between two runs of one study: its timings, and the directory of each run
UNEQUAL = ("wall_time", "cpu_time", "run")


def test_a_study_in_memory_runs_in_memory_and_holds_the_table_the_directory_holds(tmp_path, monkeypatch):
    scene = load_scene(ROOT / "scenes" / "convergence_duffing.yaml", DUFFING)
    outdir = tmp_path / "d"
    on_disk, held = run_both_ways(scene, tmp_path, monkeypatch, skip=UNEQUAL)
    monkeypatch.undo()
    assert held.status == on_disk.status == "complete" and set(held.tables) == {"convergence.csv"}
    disk = read_csv(outdir / "convergence.csv")
    mem = held.tables["convergence.csv"]
    # each run of the study in its own directory, or none when held in memory
    assert disk["run"].tolist() == ["runs/00_H_1", "runs/01_H_3"]
    assert all((outdir / r / "branches.csv").is_file() for r in disk["run"])
    assert np.isnan(mem["run"]).all() and (mem["wall_time"] > 0).all() and (mem["cpu_time"] > 0).all()
    # the quantities read from the runs held in memory: at H = 1 the folds of the closed-form amplitude equation
    assert mem["setting"].tolist() == ["H=1", "H=3"] and mem["reference"].tolist() == [False, True]
    for name in ("fold_up", "fold_down"):
        assert np.min(np.abs(fold_forces(mem[name][0]) - F)) < 1e-8
    assert mem["fold_up_error"][0] > 0 and mem["fold_up_error"][1] == 0
    assert held.analysis["settings"][0]["run"] is None and on_disk.analysis["settings"][0]["run"] == "runs/00_H_1"


def test_check_prints_the_plan(capsys):
    assert main(["check", str(ROOT / "scenes" / "convergence_duffing.yaml")]) == 0
    out = capsys.readouterr().out.splitlines()
    start = out.index("analysis: convergence")
    assert out[start + 1:] == [
        "  the frequency_response analysis of analysis.base run at 8 settings of analysis.harmonics (product); "
        "reference H=25",
        "  settings: H=1; H=3; H=5; H=7; H=9; H=11; H=13; H=25",
        "  quantities: fold, fold, peak",
    ]


BASE = """
model: {builtin: duffing}
analysis:
  type: convergence
  base: {type: frequency_response, parameter: w, range: [0.5, 3.0], starts: %s}
  vary: {analysis.harmonics: [1, 3]}
  quantities: [peak]
"""


@pytest.mark.parametrize("starts,match", [
    ("[{harmonicz: 3}]", r"analysis\.base\.starts\[0\]"),
    ("[{start: 1.0, range: [1, 2]}]", r"analysis\.base\.starts\[0\]"),
    ("[{start: -1.0}]", r"analysis\.base\.starts\[0\]\.start \(line 5\): expected values of w, each a number >= 0"),
])
def test_a_bad_further_start_of_the_base_names_its_key_under_base(starts, match):
    with pytest.raises(SceneError, match=match):
        parse_scene(BASE % starts)
