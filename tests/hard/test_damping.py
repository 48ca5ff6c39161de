"""Near-zero damping: sharp peaks followed without skipping, undamped limits.

- linear oscillator ``x'' + 2 zeta x' + x = cos(w t)``, ``zeta = 1e-6``: the FRF
  in closed form, a peak 5e5 high and 2e-6 wide;
- Duffing ``x'' + 2 zeta x' + x + x^3 = F cos(w t)``, ``zeta = 1e-6``: the ``H = 1``
  amplitude equation and its folds, and the undamped backbone
  ``w^2 = 1 + 3/4 A^2`` which the response hugs within ``F / A``;
- the undamped timing belt: no damping, so the forced response is
  time-reversible (``x(-t) = x(t)``, all sine coefficients zero) and its
  jump-up fold is the limit of the damped folds.
"""

import numpy as np
import pytest
from hardcases import duffing_folds

from contin.engine.branch import BranchStatus, SpecialKind
from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, connection_report, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.models.polynomial import polynomial_model

pytestmark = pytest.mark.hard
ZETA = 1e-6


def folds_of(br):
    return sorted(sp.parameter for sp in br.special_points if sp.kind == SpecialKind.FOLD)


def test_linear_peak_of_height_5e5_is_followed():
    m = polynomial_model(["x"], {"w": 0.5, "c": 2 * ZETA}, [[1]], [["c"]], [[1]], forcing=[{"dof": "x", "amplitude": 1.0}])
    hb = HarmonicBalance(m, "w", HBOptions(harmonics=1))
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 1.5), parameter_name="w")
    assert br.status == BranchStatus.RANGE_END
    w = br.parameter
    X = 1.0 / (1 - w**2 + 2j * ZETA * w)  # x = Re(X e^{i w t}) = a1 cos + b1 sin, a1 = Re X, b1 = -Im X
    # to the Newton tolerance: |R| <= 1e-10 allows |dX| <= |Z^-1| 1e-10 (measured 1.2e-7 relative at worst
    # where a chord step with the previous point's LU ends the corrector)
    np.testing.assert_allclose(br.unknowns[:, 1], X.real, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(br.unknowns[:, 2], -X.imag, rtol=1e-6, atol=1e-9)
    A = np.abs(X)
    peak = 1 / (2 * ZETA * np.sqrt(1 - ZETA**2))
    # the peak is resolved, not skipped: points inside the half-power band on both sides of it
    band = A >= peak / np.sqrt(2)
    assert np.any(band & (w < 1)) and np.any(band & (w > 1))
    assert A.max() > 0.99 * peak
    assert np.all(np.diff(w) > 0)  # a graph over w: no back-and-forth
    assert connection_report(hb, br)["ok"]


def duffing(F, **opts):
    hb = HarmonicBalance(build_model("duffing", {"F": F, "c": 2 * ZETA}), "w", HBOptions(harmonics=1))
    opts.setdefault("newton_tol", 1e-14)  # the forcing is 1e-5: an absolute 1e-10 would be a loose tolerance
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), ContinuationOptions(max_points=4000, **opts),
                      parameter_name="w")
    A = np.hypot(br.unknowns[:, 1], br.unknowns[:, 2])
    return hb, br, A


def test_duffing_sharp_resonance_folds_and_backbone():
    F = 1e-5
    hb, br, A = duffing(F)
    assert br.status == BranchStatus.RANGE_END, br.message
    w, c = br.parameter, 2 * ZETA
    # every point on the H = 1 amplitude equation, relative to the forcing
    G = ((1 - w**2 + 0.75 * A**2) ** 2 + (c * w) ** 2) * A**2
    np.testing.assert_allclose(G, F**2, rtol=1e-6)
    # both folds: the peak (w = 2.2043, A = F/(c w) = 2.27) and the lower one near w = 1.0004
    want = duffing_folds(F, c)
    assert len(want) == 2
    np.testing.assert_allclose(folds_of(br), want, rtol=1e-9)
    assert A.max() == pytest.approx(F / (c * want[1]), rel=1e-3)
    # the response hugs the undamped backbone: |w^2 - (1 + 3/4 A^2)| = F / A up to damping
    big = A > 0.1
    np.testing.assert_array_less(np.abs(w[big] ** 2 - 1 - 0.75 * A[big] ** 2), F / A[big] * (1 + 1e-3) + c * w[big])
    # and passes the peak without skipping to the other side of the backbone
    assert connection_report(hb, br)["ok"]


def test_duffing_tiny_forcing_passes_or_stops_with_a_diagnostic():
    """With ``F = 2e-6`` the two response sheets beside the backbone near ``w = 1``
    are closer than one step; either the branch resolves them or it stops
    saying that it retraces itself, never looping silently to ``max_points``."""
    F = 2e-6
    _, br, A = duffing(F)
    want = duffing_folds(F, 2 * ZETA)
    np.testing.assert_allclose(folds_of(br)[:2], want, rtol=1e-9)
    if br.status != BranchStatus.RANGE_END:  # a shortfall, said as such
        assert br.status == BranchStatus.RETRACED and not br.status.as_asked
        assert "retraces itself" in br.message and "lower ds_max" in br.message


def test_undamped_duffing_large_forcing_follows_the_backbone_to_the_range_end():
    F = 1e-3
    _, br, A = duffing(F)
    assert br.status == BranchStatus.RANGE_END and not folds_of(br)
    w = br.parameter
    big = A > 0.5
    dev = np.abs(w[big] ** 2 - 1 - 0.75 * A[big] ** 2)
    np.testing.assert_array_less(dev, F / A[big] * (1 + 1e-3) + 2 * ZETA * w[big])
    assert dev[-1] < 1e-3 * (w[-1] ** 2 - 1)  # asymptotically the backbone


BELT = {"alpha": 0.005, "beta": 0.2, "xi1": 0.4, "terms": 5, "xi_obs": 0.6, "p_d": 2}


def belt_branch(zeta, lo=2.5, max_points=600):
    effects = ("rotor_mass", "stretching", "periodic_load") + (("damping",) if zeta > 0 else ())
    m = build_model("timing_belt", dict(BELT, zeta=zeta), effects=effects)
    hb = HarmonicBalance(m, "w", HBOptions(harmonics=5))
    br = continuation(hb, hb.linear_solution(3.6), 3.6, (lo, 3.6),
                      ContinuationOptions(direction=-1, ds=0.01, ds_max=0.05, max_points=max_points), parameter_name="w")
    return hb, br


def test_undamped_belt_is_time_reversible_and_its_fold_is_the_damped_limit():
    hb, br = belt_branch(0.0)
    # set out towards w = 2.5, the branch turns back at its fold (w ~ 3.006) and ends where it started
    assert br.status is BranchStatus.TURNED_BACK and br.parameter[-1] == 3.6
    assert br.info["uncovered"][0] == 2.5 and 3.0 < br.info["uncovered"][1] < 3.01
    n, H = hb.model.n_dof, hb.H
    U = br.unknowns
    cos = np.concatenate([U[:, n * (2 * k - 1):n * 2 * k] for k in range(1, H + 1)], axis=1)
    sin = np.concatenate([U[:, n * 2 * k:n * (2 * k + 1)] for k in range(1, H + 1)], axis=1)
    assert np.abs(sin).max() <= 1e-6 * np.abs(cos).max()  # measured 5e-8: the Newton tolerance, not a phase
    (f0,) = [f for f in folds_of(br) if f < 3.5]
    assert connection_report(hb, br)["ok"]
    # the damped folds tend to the undamped one as zeta -> 0 (a regular limit: error ~ zeta^2)
    err = []
    for zeta in (1e-4, 1e-5):
        _, b = belt_branch(zeta, lo=2.98, max_points=80)
        err.append(min(abs(f - f0) for f in folds_of(b)))
    assert err[0] < 1e-4 and err[1] < 0.05 * err[0]
