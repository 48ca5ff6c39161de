"""Monodromy matrices: RK4 order, the nonlinear reference, Liouville, a clearance oscillator."""

import numpy as np
import pytest
from conftest import check_mathieu_tongues

from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, continuation
from contin.model.elements import GapForce
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Monomial
from contin.models.polynomial import polynomial_model
from contin.stability import (
    StabilityOptions,
    monodromy_orbit_ivp,
    monodromy_reference,
    monodromy_rk4,
    multiplier_distance,
    orbit_state,
)
from contin.stability.monodromy import state_matrices


@pytest.fixture(scope="module")
def duffing_points():
    """Points of the forced Duffing branch x'' + 0.1 x' + x + x^3 = 0.5 cos(w t), H = 9."""
    hb = HarmonicBalance(build_model("duffing", {"F": 0.5}), "w", HBOptions(harmonics=9))
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), ContinuationOptions())
    return hb, br


def test_rk4_is_fourth_order(duffing_points):
    """Error against the adaptive DOP853 integration of the same variational equations drops 16x per halving."""
    hb, br = duffing_points
    u, w = br.point(int(np.argmax(br.unknowns[:, 1] ** 2 + br.unknowns[:, 2] ** 2)))  # largest response
    ref = monodromy_orbit_ivp(hb, u, w, rtol=1e-12, atol=1e-13).matrix
    errs = [np.abs(monodromy_rk4(hb, u, w, S).matrix - ref).max() for S in (128, 256, 512)]
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 3.7), (errs, orders)
    assert errs[-1] < 1e-7


def test_liouville_determinant(duffing_points):
    """det Phi(T) = exp(int_0^T trace A) = exp(-c T) for M = 1, C = c, whatever the orbit.

    RK4 with S = 512 steps: relative error ~ (w_eff h)^4 T / 120 <= 1e-7 here
    (w_eff <= 2, h = T/512, T <= 4 pi).
    """
    hb, br = duffing_points
    for i in range(0, len(br), 7):
        u, w = br.point(i)
        M = monodromy_rk4(hb, u, w, 512)
        exact = np.exp(-0.1 * M.period)
        assert abs(np.linalg.det(M.matrix) - exact) < 1e-7 * exact


def test_reference_path_measures_the_hb_truncation(duffing_points):
    """Full nonlinear DOP853 from the HB state: returns to the start within the HB error,
    and its multipliers agree with the RK4 ones to the same order."""
    hb, br = duffing_points
    for i in (0, len(br) // 3, len(br) - 1):
        u, w = br.point(i)
        ref = monodromy_reference(hb, u, w)
        assert ref.orbit_error < 1e-5
        m = monodromy_rk4(hb, u, w, 1024).multipliers
        assert multiplier_distance(ref.multipliers, m) < 1e-5


def test_orbit_samples_match_the_hb_synthesis(duffing_points):
    """The sampled states used by the RK4 are the HB orbit (x, x')."""
    hb, br = duffing_points
    u, w = br.point(len(br) // 2)
    z = orbit_state(hb, u, w, np.linspace(0, 2 * np.pi / w, 9))
    x, xd, _ = hb.samples_of(u, w)
    np.testing.assert_allclose(z[0], [x[0, 0], xd[0, 0]], atol=1e-12)
    np.testing.assert_allclose(z[0], z[-1], atol=1e-12)
    A, T = state_matrices(hb, u, w, 64)
    assert A.shape == (64, 2, 2) and np.isclose(T, 2 * np.pi / w)
    np.testing.assert_allclose(A[:, 0, 1], 1.0)
    np.testing.assert_allclose(A[:, 1, 1], -0.1)


def test_clearance_oscillator_rk4_order_with_and_without_located_switches():
    """Piecewise-linear gap: the Jacobian jumps at contact, the force does not.

    x'' + 0.05 x' + x + 4 (x -+ 0.5)_+- = 0.3 cos(w t) (contact beyond |x| = 0.5).
    The force is continuous, so every saltation matrix is the identity. Fixed
    steps straight across the switches (``switches='ignore'``) are first order:
    the error at each switch is O(h) and the global error behaves like C h with
    C ~ 2 here (its phase-dependent fluctuations come from where the switch falls
    inside a step). With the switches located (the default) the steps end on
    them and RK4 is fourth order again (measured 3.9-4.0 per halving).
    """
    model = polynomial_model(["x"], {"c": 0.05, "F": 0.3, "w": 1.0}, mass=[[1.0]], damping=[["c"]],
                             stiffness=[[1.0]], forcing=[{"dof": "x", "amplitude": "F"}])
    model.forces.append(GapForce(0, Monomial(0.5), Monomial(4.0)))
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=20))
    br = continuation(hb, hb.linear_solution(0.9), 0.9, (0.9, 1.5), ContinuationOptions(max_points=200))
    u, w = br.point(int(np.argmin(np.abs(br.parameter - 1.33))))
    assert np.abs(u).max() > 0.6  # the orbit is in contact
    ref = monodromy_orbit_ivp(hb, u, w, rtol=1e-12, atol=1e-13)
    assert len(ref.switches) == 4 and all(np.array_equal(e.saltation, np.eye(2)) for e in ref.switches)
    # the adaptive integration straight across the switches agrees, at a higher cost
    across = monodromy_orbit_ivp(hb, u, w, rtol=1e-12, atol=1e-13, switches="ignore")
    assert np.abs(across.matrix - ref.matrix).max() < 1e-8
    T = ref.period
    errs, located = {}, {}
    for S in (200, 400, 800, 1600, 3200):
        errs[S] = np.abs(monodromy_rk4(hb, u, w, S, switches="ignore").matrix - ref.matrix).max()
        assert errs[S] <= 5.0 * T / S, (S, errs[S])
        located[S] = np.abs(monodromy_rk4(hb, u, w, S).matrix - ref.matrix).max()
    assert errs[3200] < errs[200] / 8  # 16x smaller step: at least first order overall
    assert errs[3200] > 1e-5  # but not better
    orders = np.log2([located[S] / located[2 * S] for S in (200, 400, 800, 1600)])
    assert np.all(orders > 3.7), (located, orders)
    assert located[3200] < 1e-10


@pytest.mark.parametrize("eps, rmax, hi", [(0.2, 2, 1.3), (0.5, 3, 2.45)])
def test_undamped_mathieu_tongues_with_monodromy(eps, rmax, hi):
    """Same check as with Hill, with the RK4 monodromy (S = 512) deciding.

    RK4 is not symplectic: in the stable regions it moves |mu| off the unit
    circle by ~(w h)^4 T / 120 < 1e-8 here, far inside the 1e-6 margin.
    """
    _, br, _ = check_mathieu_tongues(eps, rmax, hi, 4, StabilityOptions(method="floquet", steps_per_period=512))
    assert np.all(br.point_data["hill_quality"] == -1.0)  # Hill was not used
