"""The bifurcation_curve analysis held in memory: no file written, the same tables as the result directory's."""

from pathlib import Path

import numpy as np
import pytest

from contin.app.cli import main
from contin.scene.parse import load_scene
from memory_runs import run_both_ways

ROOT = Path(__file__).resolve().parents[2]

#: the Mathieu scene made small: period-doubling curves, one overlaid run, a shooting reference at one value
MATHIEU = ["analysis.harmonics=4", "analysis.overlay=[0.6]", "analysis.shooting=[0.5]", "analysis.shooting_points=3",
           "analysis.shooting_options={steps_per_period: 64}", "analysis.continuation={ds: 0.02, ds_max: 0.1}",
           "analysis.curve_continuation={ds: 0.02, ds_max: 0.1}"]
TABLES = {"branches.csv", "special_points.csv", "curves.csv", "curve_points.csv", "one_parameter_points.csv",
          "shooting_points.csv"}


def test_a_run_in_memory_writes_nothing_and_holds_the_tables_the_directory_holds(tmp_path, monkeypatch):
    scene = load_scene(ROOT / "scenes" / "mathieu_pd_curve.yaml", MATHIEU)
    on_disk, held = run_both_ways(scene, tmp_path, monkeypatch)
    monkeypatch.undo()
    assert held.status == on_disk.status == "complete"
    assert set(held.tables) == set(on_disk.tables) == TABLES
    # the study itself: two period-doubling curves (the tongues of delta = 1/4 and 1), a shooting row
    assert set(held.tables["curves.csv"]["kind"]) == {"pd"} and len(held.analysis["curves"]) == 2
    assert len(held.tables["shooting_points.csv"]["eps"]) > 0
    assert held.analysis == on_disk.analysis
    # the one-parameter runs' solutions, as the result directory's state gives them
    assert np.array_equal(held.data["coefficients"], on_disk.data["coefficients"])
    assert held.data["parameter"] == "delta" and not (tmp_path / "bifurcation_curves.png").exists()


def test_check_prints_the_plan(capsys):
    assert main(["check", str(ROOT / "scenes" / "duffing_fold_curve.yaml")]) == 0
    out = capsys.readouterr().out.splitlines()
    start = out.index("analysis: bifurcation_curve")
    assert out[start + 1:] == [
        "  one-parameter run in w over [0.5, 3] at F=0.5, harmonics H=1, subharmonic nu=1, samples N=5",
        "  unknowns: 3 = 1 dof x (2H+1); curve systems: 4 (coefficients and w)",
        "  curves: fold in (w, F), F over [0, 0.5]",
        "  overlaid one-parameter runs at F = 0.2, 0.35",
        "  period doublings of the integrated flow (shooting) at F = none",
    ]


@pytest.mark.parametrize("override,key,length", [
    ("analysis.continuation={unknown_scale: [1, 1]}", "analysis.continuation.unknown_scale", 3),
    ("analysis.curve_continuation={unknown_scale: [1, 1, 1]}", "analysis.curve_continuation.unknown_scale", 4),
])
def test_a_scale_of_the_wrong_length_names_its_key_and_the_unknowns(override, key, length, tmp_path, capsys):
    code = main(["run", str(ROOT / "scenes/duffing_fold_curve.yaml"), "-o", str(tmp_path / "x"), "-q",
                 "--set", override])
    err = " ".join(capsys.readouterr().err.split())
    assert code == 2 and key in err and f"a list of {length} (one per unknown" in err, err
