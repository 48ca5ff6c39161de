"""Many harmonics and bad scaling.

Two uncoupled Duffing oscillators ``X'' + 0.1 X' + X + X^3 = 0.5 cos(w t)`` and
``Z'' + 0.1 Z' + Z + Z^3 = 0.3 cos(w t)``, written in badly scaled unknowns
``y = 1e-6 X`` and ``z = 1e3 Z``: coefficients from 1e-6 to 1e12 and harmonic
coefficients spanning about 1e-7 to 1e3. The folds are those of the two
closed-form amplitude equations (``H = 1``), and the same as those of the
well-scaled system with ``H = 60`` (the discretisation cannot depend on the units).
"""

import json

import numpy as np
import pytest
import yaml
from hardcases import duffing_folds

from contin.engine.branch import BranchStatus, SpecialKind
from contin.app.cli import main
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.models.polynomial import polynomial_model
from contin.output.results import read_csv

pytestmark = pytest.mark.hard
A, B = 1e-6, 1e3
FX, FZ = 0.5, 0.3


def model(a, b):
    return polynomial_model(
        ["y", "z"], {"w": 0.5}, [[1, 0], [0, 1]], [[0.1, 0], [0, 0.1]], [[1, 0], [0, 1]],
        nonlinear=[{"dof": "y", "coef": 1 / a**2, "x": {"y": 3}}, {"dof": "z", "coef": 1 / b**2, "x": {"z": 3}}],
        forcing=[{"dof": "y", "amplitude": a * FX}, {"dof": "z", "amplitude": b * FZ}])


def folds_of(br):
    return sorted(sp.parameter for sp in br.special_points if sp.kind == SpecialKind.FOLD)


def test_badly_scaled_h1_folds_match_both_closed_forms():
    hb = HarmonicBalance(model(A, B), "w", HBOptions(harmonics=1))
    u0 = hb.linear_solution(0.5)
    assert np.abs(u0).max() / np.abs(u0[np.abs(u0) > 0]).min() > 1e8  # unknowns spanning 1e-7 .. 1e3
    br = continuation(hb, u0, 0.5, (0.5, 3.0), parameter_name="w")
    assert br.status == BranchStatus.RANGE_END
    want = sorted(duffing_folds(FX, 0.1) + duffing_folds(FZ, 0.1))
    np.testing.assert_allclose(folds_of(br), want, rtol=1e-8)
    assert br.residual_norms.max() <= 1e-10
    # the condition estimates are recorded for the report
    assert np.isfinite(br.info["max_condition"]) and br.info["max_condition"] >= br.info["last_condition"] > 1


def test_without_scaling_the_same_problem_does_not_get_through():
    hb = HarmonicBalance(model(A, B), "w", HBOptions(harmonics=1))
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), ContinuationOptions(scaling="none", max_points=300),
                      parameter_name="w")
    assert br.status != BranchStatus.RANGE_END
    assert len(folds_of(br)) < 4


def scene(a, b, H):
    return {
        "model": {
            "name": "scaled_duffings", "dofs": ["y", "z"], "parameters": {"w": 0.5},
            "mass": [[1, 0], [0, 1]], "damping": [[0.1, 0], [0, 0.1]], "stiffness": [[1, 0], [0, 1]],
            "forces": [{"dof": "y", "expr": f"{1 / a**2!r}*y**3"}, {"dof": "z", "expr": f"{1 / b**2!r}*z**3"}],
            "excitation": [{"dof": "y", "expr": f"{a * FX!r}*cos(tau)"}, {"dof": "z", "expr": f"{b * FZ!r}*cos(tau)"}],
            "frequency": "w",
        },
        "analysis": {"type": "frequency_response", "parameter": "w", "range": [0.5, 3.0], "harmonics": H,
                     "stability": "none"},
        "output": {"measure": "amp_y"},
    }


def run(tmp_path, name, data):
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / name
    assert main(["run", str(path), "-o", str(out), "-q"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    return summary, read_csv(out / "special_points.csv")


def test_h60_badly_scaled_equals_well_scaled_and_reports_condition_numbers(tmp_path):
    s_bad, sp_bad = run(tmp_path, "bad", scene(A, B, 60))
    s_good, sp_good = run(tmp_path, "good", scene(1.0, 1.0, 60))
    for s in (s_bad, s_good):
        (b,) = s["analysis"]["branches"]
        assert b["status"] == "range_end" and s["analysis"]["harmonics"] == 60
        cond = b["condition"]
        assert cond["max"] is not None and cond["last"] is not None and cond["max"] >= cond["last"] >= 1
        assert 0.5 <= cond["max_at"] <= 3.0
    f_bad = np.sort(sp_bad["w"][sp_bad["kind"] == "fold"])
    f_good = np.sort(sp_good["w"][sp_good["kind"] == "fold"])
    assert len(f_bad) == len(f_good) == 4
    np.testing.assert_allclose(f_bad, f_good, rtol=1e-8)
    # H = 60 against the one-harmonic closed form: the higher harmonics move the folds slightly
    want = sorted(duffing_folds(FX, 0.1) + duffing_folds(FZ, 0.1))
    np.testing.assert_allclose(f_good, want, rtol=2e-2)
    # with per-unknown magnitudes from 1e-6 to 1e3 the scaled Newton matrix stays as well conditioned
    # as the well-scaled problem's, to within the ratio of the unknowns' magnitudes it cannot remove
    ratio = s_bad["analysis"]["branches"][0]["condition"]["max"] / s_good["analysis"]["branches"][0]["condition"]["max"]
    assert ratio < 1e12
