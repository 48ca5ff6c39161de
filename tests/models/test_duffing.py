"""Forced Duffing oscillator x'' + 0.1 x' + x + x^3 = F cos(w t) against its closed forms."""

import numpy as np
import pytest
from scipy.optimize import brentq

from contin.engine.branch import BranchStatus, SpecialKind
from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.harmonics import harmonic_amplitudes

C, F = 0.1, 0.5
W_RANGE = (0.5, 3.0)


def amplitude_equation(A, w):
    """[(1 - w^2 + 3/4 A^2)^2 + (c w)^2] A^2 - F^2 (Nayfeh & Mook 1979, eq. 4.1.20)."""
    return ((1 - w**2 + 0.75 * A**2) ** 2 + (C * w) ** 2) * A**2 - F**2


def closed_form_folds():
    """Folds of the amplitude equation in w.

    In rho = A^2 the equation is the cubic (9/16) rho^3 + (3/2)(1 - w^2) rho^2
    + ((1 - w^2)^2 + (c w)^2) rho - F^2 = 0; a fold in w is a double root,
    where the cubic's discriminant vanishes.
    """

    def discriminant(w):
        a3, a2, a1, a0 = 9 / 16, 1.5 * (1 - w**2), (1 - w**2) ** 2 + (C * w) ** 2, -(F**2)
        return (18 * a3 * a2 * a1 * a0 - 4 * a2**3 * a0 + a2**2 * a1**2 - 4 * a3 * a1**3 - 27 * a3**2 * a0**2)

    return [brentq(discriminant, 1.2, 1.7, xtol=1e-15), brentq(discriminant, 1.9, 2.5, xtol=1e-15)]


@pytest.fixture(scope="module")
def branch_h1():
    hb = HarmonicBalance(build_model("duffing", {"F": F, "c": C}), "w", HBOptions(harmonics=1))
    return hb, continuation(hb, hb.linear_solution(W_RANGE[0]), W_RANGE[0], W_RANGE, parameter_name="w")


def test_h1_points_satisfy_the_amplitude_equation(branch_h1):
    hb, br = branch_h1
    assert br.status == BranchStatus.RANGE_END
    assert br.parameter[0] == W_RANGE[0] and br.parameter[-1] == W_RANGE[1]
    A = np.hypot(br.unknowns[:, 1], br.unknowns[:, 2])
    np.testing.assert_allclose(amplitude_equation(A, br.parameter), 0.0, atol=1e-10)
    np.testing.assert_allclose(br.unknowns[:, 0], 0.0, atol=1e-12)
    assert np.all(np.isfinite(br.unknowns))


def test_h1_folds_match_closed_form(branch_h1):
    _, br = branch_h1
    folds = sorted(sp.parameter for sp in br.special_points if sp.kind == SpecialKind.FOLD)
    ref = closed_form_folds()
    assert len(folds) == 2
    for got, want in zip(folds, ref):
        assert abs(got - want) <= 1e-8 * want
    for sp in br.special_points:
        if sp.kind == SpecialKind.FOLD:
            # a fold is a local extremum of w: it lies beyond both bracketing points, close to them
            lo, hi = sorted(sp.interval)
            assert min(abs(sp.parameter - lo), abs(sp.parameter - hi)) < 0.05
            assert br.parameter[sp.index] in sp.interval
            assert sp.located


def test_h9_passes_both_folds_with_small_residual():
    hb = HarmonicBalance(build_model("duffing", {"F": F, "c": C}), "w", HBOptions(harmonics=9))
    opts = ContinuationOptions(newton_tol=1e-10)
    br = continuation(hb, hb.linear_solution(W_RANGE[0]), W_RANGE[0], W_RANGE, opts, parameter_name="w")
    assert br.status == BranchStatus.RANGE_END
    folds = [sp for sp in br.special_points if sp.kind == SpecialKind.FOLD]
    assert len(folds) == 2
    for u, w in zip(br.unknowns, br.parameter):
        assert np.abs(hb.residual(u, w)).max() <= opts.newton_tol
    # the branch really goes back in w between the folds
    assert np.any(np.diff(br.parameter) < 0)
    # higher harmonics are small but present: the third harmonic of a cubic
    amp = np.array([harmonic_amplitudes(u, 1)[:, 0] for u in br.unknowns])
    assert amp[:, 3].max() > 1e-3 and np.all(amp[:, 2] < 1e-12)
    # folds of the H = 9 branch are close to the H = 1 ones (the third harmonic shifts them slightly)
    ref = closed_form_folds()
    got = sorted(sp.parameter for sp in folds)
    assert all(abs(g - r) < 0.02 * r for g, r in zip(got, ref))
