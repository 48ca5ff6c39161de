"""Newton failure: a model that explodes and a step that cannot succeed end the branch
with a status naming where and why; everything before is kept (in memory and in the files)."""

import json
import math
import re

import numpy as np
import pytest
import yaml

from contin.engine.branch import BranchStatus
from contin.model.catalog import build_model
from contin.app.cli import main
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.output.results import read_csv

pytestmark = pytest.mark.hard

# m x'' + c x' + x + g x^3/(wx - w) = F cos(w t): the cubic coefficient is infinite at w = wx
EXPLODING = {
    "model": {
        "name": "exploding", "dofs": ["x"],
        "parameters": {"c": 0.1, "g": 1, "F": 0.5, "w": 0.5, "wx": 1.3},
        "mass": [[1]], "damping": [["c"]], "stiffness": [[1]],
        "forces": [{"dof": "x", "expr": "g*x**3/(wx - w)"}],
        "excitation": [{"dof": "x", "expr": "F*cos(tau)"}],
        "frequency": "w",
    },
    "analysis": {"type": "frequency_response", "parameter": "w", "range": [0.5, 3.0], "harmonics": 5,
                 "stability": "hill"},
    "output": {"measure": "amp_x"},
}


def test_exploding_model_stops_where_it_explodes_and_keeps_the_rest(tmp_path):
    scene = tmp_path / "exploding.yaml"
    scene.write_text(yaml.safe_dump(EXPLODING))
    out = tmp_path / "out"
    code = main(["run", str(scene), "-o", str(out), "-q"])
    summary = json.loads((out / "summary.json").read_text())
    (b,) = summary["analysis"]["branches"] if "analysis" in summary else summary["result"]["branches"]
    assert b["status"] == "step_too_small"
    # w beyond the singularity is not covered: the run says so (status incomplete, exit 1, the branch and the
    # uncovered interval named; before: `complete` and exit 0)
    assert code == 1 and summary["status"] == "incomplete"
    (short,) = summary["shortfalls"]
    assert "branch 0" in short and "step_too_small" in short and "not covered" in short
    # where (just below w = wx = 1.3) and why (the corrector's last failure)
    lam = float(re.findall(r"w=([-+0-9.eE]+)", b["message"])[-1])
    assert 1.299 < lam < 1.3
    assert "Newton did not converge" in b["message"] or "evaluation failed" in b["message"]
    # everything up to there is in the files, finite, and nothing beyond the singularity
    rows = read_csv(out / "branches.csv")
    assert len(rows["w"]) == b["points"] > 50
    assert rows["w"][0] == 0.5 and np.all(rows["w"] < 1.3) and rows["w"].max() > 1.299
    for name, col in rows.items():
        if col.dtype.kind == "f":
            assert np.all(np.isfinite(col)), name
    assert b["condition"]["last"] is not None and b["condition"]["max"] >= b["condition"]["last"]


class BlowUp:
    """``R = u + exp(40 lam) u^3 - 1``: a cubic stiffness that explodes with ``lam``.

    The solution shrinks like ``exp(-40 lam / 3)`` while the Jacobian
    ``1 + 3 exp(40 lam) u^2`` grows like ``exp(40 lam / 3)``, until ``exp``
    overflows (``lam > 17.7``)."""

    def linearize(self, u, lam):
        with np.errstate(over="ignore", invalid="ignore"):
            e = np.exp(40.0 * lam)
            return u + e * u**3 - 1, np.array([[1 + 3 * e * u[0] ** 2]]), 40.0 * e * u**3


def test_a_model_blowing_up_is_named_in_the_stop_message():
    br = continuation(BlowUp(), [1.0], 0.0, (0.0, 30.0), {"max_points": 5000})
    assert br.status == BranchStatus.STEP_TOO_SMALL, br.message
    lam = float(re.findall(r"lambda=([-+0-9.eE]+)", br.message)[-1])
    # it stops (crawling steps, or exp overflowing beyond lam = 17.7) with the growth named
    assert 1.0 < lam < 17.8 and lam == pytest.approx(br.parameter[-1], abs=1e-7)
    assert "grew" in br.message and "-fold since the start" in br.message
    assert np.all(np.isfinite(br.unknowns))
    u, e = br.unknowns[:, 0], np.exp(40.0 * br.parameter)
    np.testing.assert_allclose(u + e * u**3, 1.0, rtol=1e-9)


def test_an_impossible_step_ends_with_step_too_small_and_keeps_the_points():
    """A fixed step far longer than the resonance's radius of curvature, with three Newton iterations."""
    hb = HarmonicBalance(build_model("duffing", {"F": 0.5, "c": 0.1}), "w", HBOptions(harmonics=3))
    start = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), {"max_points": 1}, parameter_name="w")
    opts = ContinuationOptions(ds=0.2, ds_min=0.2, ds_max=0.2, newton_max_iter=3)
    br = continuation(hb, start.unknowns[0], 0.5, (0.5, 3.0), opts, parameter_name="w", solve_start=False)
    assert br.status == BranchStatus.STEP_TOO_SMALL
    assert "step size fell below ds_min=0.2" in br.message and "last failure" in br.message
    assert f"w={br.parameter[-1]:.10g}" in br.message
    # the start point is kept as it was
    assert len(br) == 1 and np.array_equal(br.unknowns[0], start.unknowns[0])
    assert br.info["last_failure"] and math.isfinite(br.info["max_condition"])
