"""Stability of an invariant circle by a simulation started off it (contin.timedomain.torus_check.check_circle):
the forced van der Pol oscillator's torus attracts, the same torus run backwards repels, as their Lyapunov
exponents say; the distance to a circle against points put at known distances."""

import math

import numpy as np
import pytest

from contin.bifurcation.circle_branch import CircleStabilityMonitor
from contin.engine.newton import solve_at_parameter
from contin.timedomain import invariant_circle
from contin.timedomain.invariant_circle import InvariantCircleProblem, shift_matrix
from contin.timedomain.torus_check import CIRCLE_GROWTH, check_circle, circle_distance
from van_der_pol_model import MU, vdp_circle_branch, vdp_model


@pytest.fixture(scope="module")
def circle():
    """The circle of 21 points at the branch's point nearest w = 0.93."""
    prob, br = vdp_circle_branch(0.92)
    i = int(np.argmin(np.abs(br.parameter - 0.93)))
    return prob, br.unknowns[i], float(br.parameter[i])


def test_the_distance_to_a_circle_of_points_put_off_it_along_its_normal(circle):
    prob, u, _ = circle
    theta = np.random.default_rng(1).uniform(0.0, 2.0 * math.pi, 25)
    P = prob.points_on_circle(u, theta)
    # the tangent of the interpolant at theta (d/drho of the shifted values over 2 pi), the normal in the plane
    U, _ = prob.blocks(u)
    T = np.stack([shift_matrix(prob.points, t / (2 * math.pi), derivative=True)[0] @ U for t in theta])
    normal = np.c_[-T[:, 1], T[:, 0]] / np.linalg.norm(T, axis=1)[:, None]
    assert np.max(circle_distance(prob, u, P)) < 1e-12 * np.abs(U).max()  # on the circle
    for delta in (1e-3, 1e-2):
        np.testing.assert_allclose(circle_distance(prob, u, P + delta * normal), delta, rtol=1e-10)


def test_the_van_der_pol_torus_attracts_and_its_reversal_repels(circle):
    prob, u, w = circle
    v = check_circle(prob, u, w)
    assert v.stable is True and v.distance[0] == pytest.approx(1.0) and v.distance[-1] < 1 / CIRCLE_GROWTH
    assert "off the circle is" in v.message and v.times[-1] == 400
    # the same circle of the inverse map (mu -> -mu, velocities reversed, rho -> -rho): normal exponent +0.53
    rev = InvariantCircleProblem(vdp_model(w=w, mu=-MU), "w", options=prob.options)
    U, rho = prob.blocks(u)
    U = U * np.array([1.0, -1.0])
    rev.set_anchor(U)
    r = solve_at_parameter(rev, rev.unknowns(U, -rho), w)
    assert r.converged
    back = check_circle(rev, r.x, w, periods=4, displacement=1e-4)
    assert back.stable is False and back.rate > 0.2 and back.distance[-1] > CIRCLE_GROWTH
    # further off it, the trajectory runs away to infinity (RK4 blows up): unstable too
    away = check_circle(rev, r.x, w, periods=40)
    assert away.stable is False and away.rate == math.inf and "ran away" in away.message
    with pytest.raises(ValueError, match="periods: expected an integer of at least 4"):
        check_circle(prob, u, w, periods=3)


def test_the_monitor_asks_the_simulation_only_where_the_exponents_give_no_verdict(circle, monkeypatch):
    prob, u, w = circle
    mon = CircleStabilityMonitor(prob, periods=4000)
    row = mon(u, w)
    assert row["evaluated"] and row["stable"] and not mon.simulated and not mon.undecided
    # with one period, from the first basis, the exponents' floor (1 / periods) hides the verdict: the
    # simulation gives it (after the transient one period's stretch alone may pass the floor)
    monkeypatch.setattr(invariant_circle, "TRANSIENT", 0)
    mon = CircleStabilityMonitor(prob, periods=1)
    row = mon(u, w)
    assert row["evaluated"] and row["stable"] and row["n_unstable"] == 0 and mon.simulated == [w]
    assert row["max_multiplier"] <= 1.0  # the simulation's rate, on the side of its verdict
    mon = CircleStabilityMonitor(prob, periods=1, simulation=0)
    assert not mon(u, w)["evaluated"] and mon.undecided == [w]
