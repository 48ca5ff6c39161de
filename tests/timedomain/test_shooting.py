"""Shooting on the integrated flow: closed forms, scipy's Mathieu curves, and the rotor's harmonic balance.

The shooting orbit and its monodromy come from the time integrator alone
(contin.timedomain.simulation); the references are a linear oscillator's closed-form
steady state and matrix exponential, the Mathieu transition curves of
scipy.special, and, for the rotor in permanent contact, the harmonic balance's
flip test, a different method on a different discretisation.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.special import mathieu_a, mathieu_b

from contin.bifurcation.curve_system import FlipTestEvent
from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.timedomain.shooting import (
    ShootingOptions,
    ShootingProblem,
    ShootingStability,
    flow_map,
    period_doubling_scan,
    period_doubling_start,
    periodic_orbit,
)
from contin.stability import orbit_state, stability_events
from mathieu_reference import damped_mathieu_pd


def test_linear_oscillator_orbit_and_monodromy_are_the_closed_forms():
    m, c, k, F, w = 1.0, 0.1, 1.0, 0.5, 1.3
    model = build_model("duffing", {"m": m, "c": c, "k": k, "g": 0.0, "F": F, "w": w})
    orb = periodic_orbit(model, {}, [0.0, 0.0], ShootingOptions(steps_per_period=2048))
    X = F / (k - m * w**2 + 1j * c * w)  # x = Re(X e^{i w t})
    assert orb.converged and orb.iterations <= 2  # linear: one step, a second for the differences' rounding
    np.testing.assert_allclose(orb.state, [X.real, -w * X.imag], atol=1e-10)
    A = np.array([[0.0, 1.0], [-k / m, -c / m]])
    np.testing.assert_allclose(orb.monodromy, expm(A * 2 * math.pi / w), atol=1e-9)
    assert orb.stable and orb.residual < 1e-12


@pytest.mark.parametrize("eps", [0.2, 0.5])
def test_mathieu_period_doublings_are_scipys_transition_curves(eps):
    """x'' + (delta + eps cos t) x = 0: multiplier -1 on delta = b_1(2 eps)/4 and a_1(2 eps)/4."""
    model = build_model("mathieu", {"eps": eps, "c": 0.0, "g": 0.0, "w": 1.0})
    sc = period_doubling_scan(model, {"eps": eps}, "delta", np.arange(-0.1, 0.6, 0.05), [0.0, 0.0],
                              ShootingOptions(steps_per_period=1024))
    assert sc.status == "complete" and all(sc.located)
    got = sorted(p.params["delta"] for p in sc.points)
    want = sorted([mathieu_b(1, 2 * eps) / 4, mathieu_a(1, 2 * eps) / 4])
    np.testing.assert_allclose(got, want, atol=1e-9)
    # inside the tongue the flip test is negative: a real multiplier beyond -1
    inside = (sc.values > want[0]) & (sc.values < want[1])
    assert np.all(sc.flip[inside] < 0) and np.all(sc.flip[~inside] > 0)


def test_a_pair_between_two_grid_values_is_found():
    """The whole tongue of eps = 0.2 lies between two grid values: no sign change, a minimum of the flip test."""
    model = build_model("mathieu", {"eps": 0.2, "c": 0.0, "g": 0.0, "w": 1.0})
    grid = [-0.1, 0.05, 0.4, 0.7]
    opt = ShootingOptions(steps_per_period=1024)
    sc = period_doubling_scan(model, {}, "delta", grid, [0.0, 0.0], opt)
    assert np.all(sc.flip > 0) and all(sc.located)
    np.testing.assert_allclose([p.params["delta"] for p in sc.points],
                               [mathieu_b(1, 0.4) / 4, mathieu_a(1, 0.4) / 4], atol=1e-9)
    assert not period_doubling_scan(model, {}, "delta", grid, [0.0, 0.0], opt, hidden_pairs=False).points


@pytest.mark.slow  # compiles the rotor's shooting integrator; by default rotor_subharmonic_shooting.py --quick shoots
def test_rotor_period_doublings_match_the_harmonic_balance_in_permanent_contact():
    """f0 = 0.5, paper's c2: the bearing stays on its casing, where H = 40 has converged.

    Shooting (RK4, 4096 steps, switches located) and the harmonic balance's flip test are
    independent; measured difference 5e-9 (the RK4 at 4096 and 8192 steps agree to 7e-10).
    """
    model = build_model("bearing_rotor", {"f0": 0.5})
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=1024, crossings="none"))
    u0 = model.start(hb, 2.12)
    br = continuation(hb, u0, 2.12, (2.12, 2.22), ContinuationOptions(ds=0.02, ds_max=0.05),
                      events=[FlipTestEvent(hb)])
    hb_pd = sorted(p.parameter for p in br.points_of_kind("pd"))
    # located to 1e-9 in w (1e-9 from the location to 1e-10), a tenth of the tolerance below
    sc = period_doubling_scan(model, {}, "w", np.arange(2.12, 2.2201, 0.02), orbit_state(hb, u0, 2.12, 0.0), xtol=1e-9)
    assert sc.status == "complete" and all(sc.located)
    got = sorted(p.params["w"] for p in sc.points)
    assert len(hb_pd) == 2 and len(got) == 2
    np.testing.assert_allclose(got, hb_pd, atol=1e-7)
    for p in sc.points:  # a multiplier -1 of the integrated flow, to the location's tolerance
        assert np.min(np.abs(p.multipliers + 1.0)) < 1e-6
        assert np.abs(flow_map(model, p.params, p.state) - p.state).max() < 1e-9


@pytest.mark.slow  # shooting against closed forms and the rotor's harmonic balance by default
def test_shooting_branch_passes_the_duffing_folds_of_the_converged_harmonic_balance():
    """The engine's pseudo-arclength steps on the flow map (ShootingProblem) against HB with H = 15."""
    model = build_model("duffing", {"c": 0.1, "g": 1.0, "F": 0.5})
    # folds at w = 1.4387 and 2.2119 (one orbit below the first, from rest); from w = 1 to 2.5 in steps of up to
    # 0.5 (scaled) the shooting branch has 39 points, 14 between the folds and 8 beyond (from 0.5 to 3 with
    # ds_max = 0.1: 205 points, the same folds to 1e-11)
    opts = ContinuationOptions(ds=0.05, ds_max=0.5)
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=15))
    br = continuation(hb, hb.linear_solution(1.0), 1.0, (1.0, 2.5), opts)
    hb_folds = sorted(p.parameter for p in br.points_of_kind("fold"))
    prob = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=1024))
    z0 = periodic_orbit(model, {"w": 1.0}, [0.0, 0.0], prob.options).state
    sb = continuation(prob, z0, 1.0, (1.0, 2.5), opts, monitors=[prob.monitor])
    assert sb.status.value == "range_end"
    folds = sorted(p.parameter for p in sb.points_of_kind("fold"))
    assert len(hb_folds) == 2 and len(folds) == 2
    np.testing.assert_allclose(folds, hb_folds, atol=1e-9)  # measured 1.4e-11
    # the middle branch, between the folds along the arc, is the unstable one (a real multiplier > 1)
    i, j = sorted(p.index for p in sb.points_of_kind("fold"))
    mu = np.asarray(sb.point_data["max_multiplier"])
    assert np.all(mu[i + 2:j - 1] > 1.0) and np.all(mu[:i - 1] < 1.0) and np.all(mu[j + 2:] < 1.0)
    for k in range(0, len(sb), 7):  # every stored point is a periodic orbit of the flow
        assert np.abs(prob.residual(sb.unknowns[k], sb.parameter[k])).max() < 1e-8


@pytest.fixture(scope="module")
def mathieu_duffing_shooting():
    """x'' + 0.1 x' + (delta + 0.4 cos t) x + x^3 = 0: the trivial orbit by shooting, continued in delta."""
    model = build_model("mathieu", {"c": 0.1, "g": 1.0, "eps": 0.4, "w": 1.0})
    prob = ShootingProblem(model, "delta", options=ShootingOptions(steps_per_period=512))
    mon = ShootingStability(prob)
    br = continuation(prob, np.zeros(2), -0.2, (-0.2, 0.7), ContinuationOptions(ds=0.02, ds_max=0.05),
                      monitors=[mon], events=stability_events(mon))
    return prob, br


def test_shooting_stability_locates_the_damped_mathieu_period_doublings(mathieu_duffing_shooting):
    """The flow's multipliers through -1 where scipy's monodromy of the linear equation says (RK4, 512 steps)."""
    _, br = mathieu_duffing_shooting
    assert br.status.value == "range_end"
    pds = br.points_of_kind("pd")
    want = [damped_mathieu_pd(0.0, 0.2), damped_mathieu_pd(0.3, 0.6)]
    np.testing.assert_allclose([p.parameter for p in pds], want, atol=1e-7)
    for p in pds:
        assert p.data["classification"] == "pd" and abs(p.data["multiplier"] + 1.0) < 1e-4
        assert "eigenvector" not in p.data  # no harmonic-balance problem: no Hill vector
    # unstable (one multiplier beyond -1) exactly between them
    d, n = br.parameter, np.asarray(br.point_data["n_minus"])
    inside = (d > want[0] + 1e-6) & (d < want[1] - 1e-6)
    assert np.all(n[inside] == 1) and np.all(n[(d < want[0] - 1e-6) | (d > want[1] + 1e-6)] == 0)
    assert np.all(np.asarray(br.point_data["flip_test"])[inside] < 0)


def test_switched_shooting_branch_is_a_period_two_orbit_of_scipys_integration(mathieu_duffing_shooting):
    """From the upper period doubling onto the 1/2 subharmonic; each orbit checked by DOP853 (not contin's RK4)."""
    prob, br = mathieu_duffing_shooting
    pd = br.points_of_kind("pd")[-1]
    doubled, u0, t0 = period_doubling_start(prob, pd.unknowns, pd.parameter)
    assert doubled.options.subharmonic == 2 and doubled.parameter == "delta"
    mon = ShootingStability(doubled)
    sub = continuation(doubled, u0, pd.parameter, (pd.parameter - 0.3, pd.parameter + 0.3),
                       ContinuationOptions(ds=0.02, ds_max=0.05, max_points=15), monitors=[mon], tangent=t0,
                       solve_start=False)
    assert len(sub) == 15
    assert abs(sub.parameter[0] - pd.parameter) < 1e-5  # the first point is next to the period doubling
    assert doubled.segments == 2  # the doubled problem: two segments of one period each
    for u, delta in zip(sub.unknowns[1:], sub.parameter[1:]):
        z = u[:2]  # the state at t = 0

        def rhs(t, y):
            return [y[1], -0.1 * y[1] - (delta + 0.4 * np.cos(t)) * y[0] - y[0] ** 3]

        y = solve_ivp(rhs, (0, 4 * np.pi), z, method="DOP853", rtol=1e-12, atol=1e-13, dense_output=True)
        assert np.abs(y.y[:, -1] - z).max() < 1e-7  # closes after two periods
        assert np.abs(y.sol(2 * np.pi) - z).max() > 1e-3  # not after one: a new branch, not the trivial one
    # supercritical at the upper boundary: the new branch is stable there and bends towards lower delta
    assert np.asarray(sub.point_data["stable"])[1:6].all() and sub.parameter[5] < pd.parameter


def test_period_doubling_start_refuses_an_orbit_without_a_multiplier_minus_one(mathieu_duffing_shooting):
    prob, _ = mathieu_duffing_shooting
    with pytest.raises(ValueError, match="no multiplier near -1 at delta = 0.1"):
        period_doubling_start(prob, np.zeros(2), 0.1)


# ------------------------------------------------------------------ failure paths
@pytest.mark.parametrize("kw,match", [
    ({"steps_per_period": 0}, "ShootingOptions.steps_per_period must be a positive integer"),
    ({"max_iter": 2.5}, "ShootingOptions.max_iter must be a positive integer"),
    ({"tol": 0.0}, r"ShootingOptions.tol must be a number in \(0, 0.01\]"),
    ({"fd_step": "1e-6"}, "ShootingOptions.fd_step must be a number"),
])
def test_options_are_validated_naming_the_field(kw, match):
    with pytest.raises(ValueError, match=match):
        ShootingOptions(**kw)


def test_unknown_option_is_named():
    with pytest.raises(ValueError, match="unknown option 'steps' of ShootingOptions"):
        ShootingOptions.from_dict({"steps": 10})


def test_bad_arguments_raise():
    model = build_model("duffing")
    with pytest.raises(ValueError, match=r"z0 must have shape \(2,\)"):
        periodic_orbit(model, {}, [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="unknown parameter 'omega'"):
        period_doubling_scan(model, {}, "omega", [1.0, 2.0], [0.0, 0.0])
    with pytest.raises(ValueError, match="monotonic"):
        period_doubling_scan(model, {}, "w", [1.0, 2.0, 1.5], [0.0, 0.0])


def test_newton_that_does_not_converge_keeps_its_iterate_and_says_why():
    model = build_model("duffing", {"g": 1.0, "F": 0.5, "w": 1.4})
    orb = periodic_orbit(model, {}, [3.0, 0.0], ShootingOptions(max_iter=1, steps_per_period=512))
    assert not orb.converged and "did not converge in 1 steps" in orb.message
    assert np.all(np.isfinite(orb.state)) and np.all(np.isfinite(orb.monodromy))


def test_an_iterate_without_a_forcing_period_is_a_failed_evaluation():
    """The engine retries with a smaller step when an evaluation raises ArithmeticError."""
    prob = ShootingProblem(build_model("duffing"), "w")
    with pytest.raises(ArithmeticError, match="the iterate has w = -0.5: no positive forcing period"):
        prob.linearize(np.zeros(2), -0.5)
    with pytest.raises(ValueError, match="unknown parameter 'omega'"):
        ShootingProblem(build_model("duffing"), "omega")


def test_a_lost_orbit_ends_the_scan_with_what_was_computed():
    model = build_model("duffing", {"g": 1.0, "F": 0.5})
    sc = period_doubling_scan(model, {}, "w", [0.5, 0.6, 0.7], [0.0, 0.0], ShootingOptions(max_iter=1))
    assert sc.status == "failed" and "the orbit was lost at w = 0.5" in sc.message
    assert sc.values.size == 0 and not sc.orbits
