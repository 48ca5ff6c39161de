"""A run is `complete` only when every branch ended as its scene asked; otherwise it says so and exits 1."""

import json
from pathlib import Path

import numpy as np
import pytest

from contin import ContinWarning
from contin.scene.registry import shortfalls
from contin.app.cli import main
from contin.output.results import read_csv
from contin.app.sweep import SweepOptions, run_sweep
from contin.app.sweep_grid import parse_grid

ROOT = Path(__file__).resolve().parents[3]
CUSTOM = str(ROOT / "scenes/custom_duffing.yaml")
FAST = ["-q", "--set", "analysis.harmonics=3", "--set", "output.plots=false"]
# k/k: no solution at all where k = 0 (the residual is not finite), the Duffing curve elsewhere
OVER_K = ["--set", 'model.forces=[{dof: x, expr: "g*x**3*k/k"}]']


def test_a_branch_that_never_started_makes_the_run_incomplete_with_exit_1(tmp_path, capsys):
    # before: exit 0 and `complete`, so that a sweep never ran the point again
    out = tmp_path / "run"
    code = main(["run", CUSTOM, "-o", str(out), *FAST, *OVER_K, "--set", "model.parameters.k=0"])
    err = capsys.readouterr().err
    assert code == 1
    assert "fell short" in err and "start_failed" in err and "not covered" in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "incomplete"
    assert len(summary["shortfalls"]) == 1 and "branch 0 (nu=1) ended start_failed" in summary["shortfalls"][0]
    assert summary["message"] == summary["shortfalls"][0]
    assert summary["analysis"]["branches"][0]["uncovered"] == [0.5, 3.0]


def test_a_branch_ending_as_asked_keeps_the_run_complete(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", CUSTOM, "-o", str(out), *FAST, *OVER_K]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "complete" and summary["shortfalls"] == []
    assert summary["analysis"]["branches"][0]["uncovered"] is None
    rows = read_csv(out / "branches.csv")
    assert rows["w"][-1] == 3.0 and np.all(np.isfinite(rows["amp_x"]))


def test_shortfalls_name_every_branch_that_gave_up_and_every_switch_without_a_branch():
    info = [{"branch": 0, "nu": 1, "points": 40, "status": "range_end", "message": "", "uncovered": None},
            {"branch": 1, "nu": 2, "points": 7, "status": "step_too_small", "message": "ds fell",
             "uncovered": [2.1, 2.6]},
            {"branch": 2, "nu": 2, "points": 9, "status": "turned_back", "message": "turned", "uncovered": [2.2, 2.6]},
            {"branch": 3, "nu": 2, "points": 5, "status": "boundary", "message": "grazing", "uncovered": None},
            # a torus that locked and goes on as its orbits' branches; one that locked with none
            {"branch": 4, "nu": 1, "points": 4, "status": "boundary", "message": "locks", "uncovered": [2.14, 2.6],
             "end": "locking"},
            {"branch": 5, "nu": 1, "points": 4, "status": "boundary", "message": "locks", "uncovered": [2.15, 2.6],
             "method": "shooting"},
            # a torus that collapsed onto its periodic orbit at the Neimark-Sacker point it is born at
            {"branch": 6, "nu": 1, "points": 30, "status": "boundary", "message": "collapses",
             "uncovered": [1.85, 2.6], "end": "collapse"}]
    failed = [{"parent": 0, "kind": "pd", "parameter": 2.2, "side": -1, "message": "no first point"}]
    out = shortfalls(info, "w", failed)
    assert out == ["branch 1 (nu=2) ended step_too_small after 7 points: ds fell; w in [2.1, 2.6] not covered",
                   "branch 5 (nu=1) stopped at a point it cannot pass (locks); w in [2.15, 2.6] not covered",
                   "no branch switched from branch 0 at its pd point w=2.2 (side -1): no first point"]


def test_a_sweep_records_an_incomplete_point_and_runs_it_again(tmp_path):
    grid = (parse_grid("model.parameters.k=0,1"),)
    opts = SweepOptions(CUSTOM, grid, str(tmp_path / "s"), serial=True, progress=False, map_plot=False,
                        overrides=("analysis.harmonics=3", "output.plots=false", OVER_K[1]))
    first = run_sweep(opts)
    by_name = {r["point"]: r for r in first.records}
    assert by_name["k=1"]["status"] == "complete"
    assert by_name["k=0"]["status"] == "incomplete" and "start_failed" in by_name["k=0"]["message"]
    assert [r["point"] for r in first.failed] == ["k=0"]
    index = read_csv(tmp_path / "s" / "sweep.csv")
    assert sorted(index["status"]) == ["complete", "incomplete"]
    again = {r["point"]: r for r in run_sweep(opts).records}
    assert again["k=1"]["reused"] and not again["k=0"]["reused"]  # before: skipped as complete


STIFF = """
model:
  name: stiff_duffing  # a light mass on a stiff spring: a 100.5 rad/s mode beside the Duffing resonance
  dofs: [x, y]
  parameters: {c: 0.1, F: 0.5, w: 1.0, k: 100.0, m: 0.01, cy: 0.1}
  mass: [[1, 0], [0, m]]
  damping: [[c, 0], [0, cy]]
  stiffness: [["1 + k", "-k"], ["-k", k]]
  forces: [{dof: x, expr: "x**3"}]
  excitation: [{dof: x, expr: "F*cos(tau)"}]
  frequency: w
analysis:
  type: frequency_response
  parameter: w
  range: [1.0, 2.0]
  harmonics: 5
  stability: floquet
  stability_options: {steps_per_period: 16, max_steps_per_period: 160}
output: {measure: amp_x}
"""


def test_points_without_a_stability_verdict_keep_the_branch_and_get_empty_cells(tmp_path, capsys, monkeypatch):
    # before: the monodromy's advice ended the branch (`newton_failed`, "a monitor failed"); now a point where
    # no verdict can be made (here: more steps than max_steps_per_period, no adaptive integration) is kept
    import contin.stability.floquet as floquet

    monkeypatch.setattr(floquet, "IVP_FALLBACK_EVALUATIONS", 0)
    scene = tmp_path / "stiff.yaml"
    scene.write_text(STIFF)
    out = tmp_path / "run"
    with pytest.warns(ContinWarning, match="no stability verdict at w=1 .*max_steps_per_period"):
        assert main(["run", str(scene), "-o", str(out), "-q"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    (b,) = summary["analysis"]["branches"]
    assert summary["status"] == "complete" and b["status"] == "range_end"
    assert b["stability"]["unevaluated"] > 0 and "no stability verdict at" in b["message"]
    rows = read_csv(out / "branches.csv")
    empty = rows["stable"] == ""
    assert empty.any() and not empty.all()
    assert np.all(rows["w"][empty] < 1.6) and np.all(np.isnan(rows["max_multiplier"][empty]))
    assert set(rows["stable"][~empty]) <= {"true", "false"}
    assert (out / "bifurcation_diagram.png").stat().st_size > 10_000


def test_a_branch_handed_over_to_shooting_says_which_branch_goes_on(tmp_path, capsys):
    # the impact oscillator's harmonic branch grazes at w = 0.8439 and is handed to shooting (method auto)
    out = tmp_path / "impact"
    code = main(["run", str(ROOT / "scenes/impact_oscillator.yaml"), "-o", str(out), "--set", "output.plots=false"])
    lines = capsys.readouterr().out.splitlines()
    assert code == 0
    (handed,) = [ln for ln in lines if ln.startswith("branch 0 ")]
    assert ", boundary, continued by shooting as branch 1: the branch cannot pass the grazing point" in handed
    (b0, b1) = json.loads((out / "summary.json").read_text())["analysis"]["branches"]
    assert (b0["status"], b0["end"], b0["handed_over_to"], b1["handed_over_from"]) == ("boundary", "handover", 1, 0)
