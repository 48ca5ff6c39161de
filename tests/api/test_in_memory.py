"""A call of the Python API runs in memory: nothing is written, no temporary directory is made, and the
branches are those of `contin run` on the same scene, bit for bit."""

import os
from pathlib import Path

import numpy as np
import pytest

import contin
import contin.api.calls  # noqa: F401 (imported before the file system is guarded: matplotlib makes its config dir)
from contin.app.cli import main
from contin.scene.parse import SceneError
from memory_runs import assert_tables_match, forbid_files

ROOT = Path(__file__).resolve().parents[2]
SETS = ["analysis.range=[0.5, 2.0]", "analysis.harmonics=5"]
#: a hardening spring on x2 of a 2-dof chain: x1 carries no nonlinear force and is condensed out
CONDENSED = """
model:
  dofs: [x1, x2]
  parameters: {k: 1, c: 0.05, g: 2, F: 0.1, w: 0.5}
  mass: [[1, 0], [0, 2]]
  damping: [[2*c, -c], [-c, c]]
  stiffness: [[2*k, -k], [-k, k]]
  forces: [{dof: x2, expr: "g*x2**3"}]
  excitation: [{dof: x1, expr: "F*cos(tau)"}]
analysis: {type: frequency_response, parameter: w, range: [0.3, 1.2], harmonics: 3, stability: hill, condense: true,
           continuation: {ds: 0.2, ds_max: 0.5}}
"""


@pytest.mark.parametrize("scene", ["duffing", "condensed"])
def test_a_call_writes_nothing_and_equals_contin_run(scene, tmp_path, monkeypatch):
    if scene == "condensed":  # a 2-dof chain whose linear dof is condensed out (expanded for the coefficients)
        path, sets = tmp_path / "condensed.yaml", []
        path.write_text(CONDENSED)
    else:
        path, sets = ROOT / "scenes" / "duffing.yaml", SETS
    text = path.read_text()
    out = tmp_path / "cli"  # first: it compiles the kernels (their cache is no file of the run held in memory)
    assert main(["run", str(path), "-o", str(out), "-q", *[x for s in sets for x in ("--set", s)]]) == 0
    forbid_files(monkeypatch)
    result = contin.run(text, overrides=sets + ["output.plots=false"])
    monkeypatch.undo()
    assert result.outdir is None and result.files == [] and result.status == "complete"
    assert_tables_match(result.outcome.tables, out)
    loaded = contin.load(out)
    assert [(b.id, b.nu, b.status, b.message, len(b)) for b in loaded.branches] == \
        [(b.id, b.nu, b.status, b.message, len(b)) for b in result.branches]
    np.testing.assert_array_equal(result.coefficients(), loaded.coefficients())
    assert result.summary["analysis"] == loaded.summary["analysis"]


def test_a_call_without_outdir_that_asks_for_figures_is_told_they_are_files():
    with pytest.raises(SceneError, match=r"output\.plots: expected false without outdir \(figures are files"):
        contin.frequency_response("duffing", range=[0.5, 1.0], output={"plots": True})


def test_a_result_held_in_memory_saves_the_files_contin_run_writes(tmp_path):
    result = contin.frequency_response("duffing", range=[0.5, 1.5], harmonics=3)
    out = result.save(tmp_path / "saved")
    assert {"branches.csv", "special_points.csv", "summary.json", "coefficients.csv"} <= set(os.listdir(out))
    assert_tables_match(result.outcome.tables, out)
    loaded = contin.load(out)
    np.testing.assert_array_equal(loaded.coefficients(), result.coefficients())
