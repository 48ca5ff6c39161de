"""The linear example scenes (seeds 000 and 002): check, run, compare with the closed forms."""

import json
import math
from pathlib import Path

import numpy as np

from contin.app.cli import main
from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[3]


def run(scene, tmp_path, capsys=None):
    out = tmp_path / Path(scene).stem
    assert main(["check", str(ROOT / "scenes" / scene)]) == 0
    assert main(["run", str(ROOT / "scenes" / scene), "-o", str(out), "-q"]) == 0
    return out


def test_two_dof_modes_scene(tmp_path, capsys):
    out = run("two_dof_modes.yaml", tmp_path)
    assert "natural frequencies and modes about the static equilibrium" in capsys.readouterr().out
    rows = read_csv(out / "modes.csv")
    np.testing.assert_allclose(rows["omega"], [1.0, math.sqrt(5 / 2)], rtol=1e-13)  # w2 = sqrt(5/2) sqrt(k/m)
    np.testing.assert_allclose(rows["ratio_x2"], [1.0, -0.5], atol=1e-13)
    assert (out / "mode_shapes.png").stat().st_size > 10_000


def test_two_dof_frf_scene(tmp_path):
    out = run("two_dof_frf.yaml", tmp_path)
    rows = read_csv(out / "frf.csv")
    w = rows["w"]
    den = 2 * w**4 - 7 * w**2 + 5
    np.testing.assert_allclose(rows["re_x1"], (3 - 2 * w**2) / den, rtol=1e-10)
    np.testing.assert_allclose(rows["re_x2"], 1 / den, rtol=1e-10)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "complete" and summary["plots"] == ["frf.png"]


def test_absorber_exercise_frf_scene(tmp_path):
    out = run("absorber_exercise_frf.yaml", tmp_path)
    summary = json.loads((out / "summary.json").read_text())
    top = max(p["amplitude"] for p in summary["analysis"]["peaks"] if p["dof"] == "x1")
    assert abs(top / 2e-6 - 4.59022) < 1e-5  # seed 000's exercise: the true peak, delta_st = F/k1 = 2e-6 m


def test_models_lists_the_linear_chain(capsys):
    assert main(["models"]) == 0
    out = capsys.readouterr().out
    assert "linear_chain:" in out and "options: n=2" in out and "static_load" in out
