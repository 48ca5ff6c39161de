"""Shooting at another section of the orbit (ShootingOptions.start_step) and the quiet section of a contact orbit.

Truth from outside the code: scipy's DOP853 with the stop's switches located as events (the orbit's state at the
section), central differences of the residual (the Jacobians), the orbit's positions against the stop's gap (where
its contact arc lies), and the period-doubled orbit integrated again by DOP853 from the section.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from contin.analyses.shooting_rows import stored_shooting_problem
from contin.bifurcation.shooting_branch import ReturnEvent
from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.problem import solve_at
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.catalog import build_model
from contin.stability import stability_events
from contin.timedomain.multiple_shooting import ShootingProblem
from contin.timedomain.shooting_bifurcations import ShootingStability, period_doubling_start
from contin.timedomain.shooting_options import ShootingOptions
from contin.timedomain.shooting_section import (at_quiet_section, quiet_step, resectioned, state_at_zero,
                                                unknowns_at)
from contin.timedomain.simulation import simulate
from tests.timedomain.test_multiple_shooting import C, F, G, central_jacobian, gap_model

W = 0.95  # the gap oscillator's orbit there touches the stop over 37 of 512 steps a period
S = 512


@pytest.fixture(scope="module")
def gap_orbit():
    model = gap_model()
    prob = ShootingProblem(model, "w", {}, ShootingOptions(steps_per_period=S, segments=2))
    z = simulate(model, {"w": W}, [0.0], [0.0], periods=300, steps_per_period=S, record_every=S).final_state
    u = solve_at(prob, prob.start_unknowns(z, W), W, tol=1e-12, max_iter=20, what="the gap oscillator's orbit")
    return prob, u


def dop853_state(z, t0, t1):
    """(x, x') at ``t1`` of the gap oscillator from ``z`` at ``t0``: DOP853, each switch located as an event."""
    def rhs(t, y, k):
        return [y[1], F * np.cos(W * t) - C * y[1] - y[0] - k * (y[0] - G)]

    def hit(t, y, k):
        return y[0] - G

    hit.terminal = True

    y, t = np.asarray(z, dtype=float), t0
    while t < t1:
        k = 20.0 if y[0] > G or (y[0] == G and y[1] > 0) else 0.0
        sol = solve_ivp(rhs, (t, t1), y, method="DOP853", rtol=1e-12, atol=1e-13, events=hit, args=(k,))
        if sol.status == 1 and sol.t_events[0].size and sol.t_events[0][0] > t:
            t, y = sol.t_events[0][0], sol.y_events[0][0]
            y = y + np.array([np.sign(y[1]) * 1e-14, 0.0])  # just across the stop's face
        else:
            t, y = t1, sol.y[:, -1]
    return y


def test_an_orbit_at_another_section_is_the_same_orbit(gap_orbit):
    prob, u = gap_orbit
    T = 2 * np.pi / W
    k0 = 148
    other = resectioned(prob, k0)
    v = unknowns_at(prob, u, W, k0)
    assert other.options.start_step == k0 and other.segments == 2
    assert np.abs(other.residual(v, W)).max() < 1e-12
    # its unknowns are the orbit's states at t0 = k0 T / S and t0 + T / 2, as DOP853 carries the state at t = 0
    np.testing.assert_allclose(v[:2], dop853_state(u[:2], 0.0, k0 * T / S), atol=1e-6)
    np.testing.assert_allclose(v[2:], dop853_state(u[:2], 0.0, k0 * T / S + T / 2), atol=1e-6)
    # what is read off the orbit does not depend on where it is cut
    np.testing.assert_allclose(state_at_zero(other, v, W), u[:2], atol=1e-12)
    np.testing.assert_allclose(other.step_states(v, W), prob.step_states(u, W), atol=1e-12)
    x0, _ = prob.orbit(u, W, np.linspace(0, T, 7))
    x1, _ = other.orbit(v, W, np.linspace(0, T, 7))
    np.testing.assert_allclose(x1, x0, atol=1e-12)
    np.testing.assert_allclose(other.multipliers(v, W), prob.multipliers(u, W), rtol=1e-10)
    np.testing.assert_allclose(other.graze(v, W), prob.graze(u, W), atol=1e-10)
    assert other.switches(v, W) == prob.switches(u, W)
    # from the state at t = 0, or from a harmonic-balance orbit, the unknowns are taken at the section
    np.testing.assert_allclose(other.start_unknowns(u[:2], W), v, atol=1e-12)
    hb = HarmonicBalance(prob.model, "w", HBOptions(harmonics=1))
    c = np.array([0.3, 0.8, -0.2])  # x = 0.3 + 0.8 cos(w t) - 0.2 sin(w t)
    t0 = k0 * T / S
    np.testing.assert_allclose(other.from_coefficients(hb, c, W)[:2],
                               [0.3 + 0.8 * np.cos(W * t0) - 0.2 * np.sin(W * t0),
                                -0.8 * W * np.sin(W * t0) - 0.2 * W * np.cos(W * t0)], atol=1e-12)


def test_the_jacobians_at_another_section_match_central_differences(gap_orbit):
    prob, u = gap_orbit
    other, v = resectioned(prob, 300, 1), unknowns_at(prob, u, W, 300, 1)
    R, Ju, Jlam = other.linearize(v, W)
    assert np.abs(R).max() < 1e-12
    assert np.abs(Ju - central_jacobian(other, v, W)).max() <= 1e-6 * np.abs(Ju).max()
    h = 1e-6
    fd = (other.residual(v, W + h) - other.residual(v, W - h)) / (2 * h)
    assert np.abs(Jlam - fd).max() <= 1e-6 * np.abs(Jlam).max()


def test_the_quiet_section_lies_farthest_from_the_contact_arc(gap_orbit):
    prob, u = gap_orbit
    x = prob.step_states(u, W)[:, 0]
    contact = x > G  # the stop is touched on one arc of the period
    assert 10 < contact.sum() < S // 2
    edges = np.flatnonzero(contact != np.roll(contact, 1))
    assert edges.size == 2  # where the arc opens and closes

    def distance(k):
        d = np.abs(k - edges)
        return np.minimum(d, S - d).min()

    # one segment: the middle of the flight
    k1 = quiet_step(prob, u, W, 1)
    assert not contact[k1] and distance(k1) == max(distance(k) for k in range(S))
    # two: the worse of the two starts as far as any pair allows
    k2 = quiet_step(prob, u, W)
    assert 0 <= k2 < S // 2
    assert min(distance(k2), distance(k2 + S // 2)) == max(min(distance(k), distance(k + S // 2))
                                                          for k in range(S // 2))
    other, v = at_quiet_section(prob, u, W, 1)
    assert other.segments == 1 and other.options.start_step == k1 and np.abs(other.residual(v, W)).max() < 1e-12
    # without switching functions there is nothing to keep away from: the section stays at t = 0
    smooth = ShootingProblem(_duffing(), "w", {}, ShootingOptions(steps_per_period=64))
    z = np.array([0.1, 0.0])
    assert quiet_step(smooth, z, 1.0) == 0 and at_quiet_section(smooth, z, 1.0)[0] is smooth


def _duffing():
    return build_model("duffing", {"c": 0.1, "g": 1.0, "F": 0.5})


def test_start_step_is_checked():
    for bad in (-1, S, True, 2.5):
        with pytest.raises(ValueError, match=r"ShootingOptions.start_step must be an integer in \[0, 512\)"):
            ShootingOptions(steps_per_period=S, start_step=bad)
    assert ShootingOptions(steps_per_period=S, subharmonic=2, start_step=S + 3).start_step == S + 3


def test_the_doubled_orbit_and_the_half_period_keep_the_section():
    """The period doubling of x'' + 0.1 x' + (delta + 0.4 cos t) x + x^3 = 0 at its rest state, shot from the
    section t0 = 100 (2 pi / 512): the doubled branch's states at t0 are those DOP853 carries round two forcing
    periods (and not one); the return test of an orbit of two periods uses the same section of one."""
    model = build_model("mathieu", {"c": 0.1, "g": 1.0, "eps": 0.4, "w": 1.0})
    k0 = 100
    prob = ShootingProblem(model, "delta", options=ShootingOptions(steps_per_period=S, start_step=k0))
    mon = ShootingStability(prob)
    br = continuation(prob, np.zeros(2), 0.3, (0.3, 0.7), ContinuationOptions(ds=0.02, ds_max=0.05),
                      monitors=[mon], events=stability_events(mon))
    (pd,) = br.points_of_kind("pd")
    doubled, u0, t0 = period_doubling_start(prob, pd.unknowns, pd.parameter)
    assert doubled.options.start_step == k0 and doubled.options.subharmonic == 2
    sub = continuation(doubled, u0, pd.parameter, (pd.parameter - 0.3, pd.parameter + 0.3),
                       ContinuationOptions(ds=0.02, ds_max=0.05, max_points=5), tangent=t0, solve_start=False)
    assert len(sub) == 5
    ts = k0 * 2 * np.pi / S
    for u, delta in zip(sub.unknowns[1:], sub.parameter[1:]):
        def rhs(t, y):
            return [y[1], -0.1 * y[1] - (delta + 0.4 * np.cos(t)) * y[0] - y[0] ** 3]

        z = u[:2]
        two = solve_ivp(rhs, (ts, ts + 4 * np.pi), z, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
        one = solve_ivp(rhs, (ts, ts + 2 * np.pi), z, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
        np.testing.assert_allclose(two, z, atol=1e-6)
        assert np.abs(one - z).max() > 1e-3
    ev = ReturnEvent(resectioned(doubled, S + k0))
    assert ev.half.options.start_step == k0 and ev.half.options.subharmonic == 1
    # the orbit of one period, seen over two: the half period's residual vanishes from its state at the section
    assert np.abs(ev.distance_vector(np.zeros(doubled.size), pd.parameter)).max() < 1e-14


def test_a_stored_branch_gets_its_section_back(gap_orbit):
    prob, _ = gap_orbit
    hb = HarmonicBalance(prob.model, "w", HBOptions(harmonics=3))
    header = {"nu": 2, "shooting": {"steps_per_period": S, "segments": 2, "start_step": 700}}
    made = stored_shooting_problem(hb, header)
    assert (made.options.start_step, made.segments, made.options.subharmonic) == (700, 2, 2)
    assert stored_shooting_problem(hb, {"nu": 1, "shooting": {"steps_per_period": S}}).options.start_step == 0
