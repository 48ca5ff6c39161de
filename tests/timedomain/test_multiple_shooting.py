"""Multiple shooting on the integrated flow: Jacobians, multipliers, branches through folds and grazing.

Truth from outside the code: central differences of the residual (the
Jacobians), scipy's DOP853 monodromy with its own event location
(contin.stability.monodromy_reference, the multipliers), harmonic balance with
H = 15 (the Duffing folds), the linear response's closed form and a plain
simulation's contact count (the grazing point), and DOP853 (the doubled orbit).
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Monomial
from contin.model.catalog import build_model
from contin.model.elements import GapForce
from contin.models.polynomial import polynomial_model
from contin.stability import stability_events
from contin.stability.monodromy_reference import monodromy_reference
from contin.timedomain.multiple_shooting import ShootingProblem
from contin.timedomain.shooting_options import ShootingOptions
from contin.timedomain.shooting_bifurcations import ShootingStability, period_doubling_start
from contin.timedomain.shooting import periodic_orbit
from contin.timedomain.shooting_events import ShootingGrazingEvent, shooting_events, start_graze
from contin.timedomain.simulation import simulate
from contin.util import workers
from conftest import fuzz_examples

C, F, G = 0.05, 0.2, 1.0  # the gap oscillator: x'' + C x' + x + 20 max(x - G, 0) = F cos(w t)


def gap_model():
    model = polynomial_model(["x"], {"c": C, "F": F, "w": 0.5}, mass=[[1.0]], damping=[["c"]], stiffness=[[1.0]],
                             forcing=[{"dof": "x", "amplitude": "F"}])
    model.forces.append(GapForce(0, Monomial(G), Monomial(20.0), sides="+"))
    return model


def duffing_model():
    return build_model("duffing", {"c": 0.1, "g": 1.0, "F": 0.5})


def linear_state(w):
    """(x, x') at t = 0 of the linear response F cos(w t) / (1 - w^2 + i C w) (closed form)."""
    X = F / (1 - w * w + 1j * C * w)
    return np.array([X.real, -w * X.imag])


def one_harmonic(model, z, w):
    """A one-harmonic balance problem and coefficients whose state at t = 0 is z (n = 1): the reference's start."""
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=1))
    return hb, np.array([0.0, z[0], z[1] / w])  # x = a1 cos(w t) + b1 sin(w t)


def central_jacobian(prob, u, lam, step=1e-6):
    m = u.size
    Ju = np.array([(prob.residual(u + step * e, lam) - prob.residual(u - step * e, lam)) / (2 * step)
                   for e in np.eye(m)]).T
    return Ju


def linearize_counted(prob, u, lam):
    """``prob.linearize(u, lam)`` and the number of plain flows it integrated (those of a dR/dlam by
    differences)."""
    plain = []
    run = prob._run
    prob._run = lambda *a, **k: plain.append(1) or run(*a, **k)
    try:
        return prob.linearize(u, lam), len(plain)
    finally:
        prob._run = run


# ------------------------------------------------------------------ Jacobians
@pytest.mark.parametrize("segments", [1, 4])
@pytest.mark.parametrize("case", ["duffing", "gap"])
def test_jacobians_are_the_central_differences_of_the_residual(case, segments):
    """The variational Jacobian (saltation at the stop for the gap) and dR/dw against finer differences."""
    if case == "duffing":
        model, w, z = duffing_model(), 1.2, np.array([0.8, 0.3])
    else:  # the orbit from x = 1.5 crosses the stop (x = 1) twice per period
        model, w, z = gap_model(), 1.0, np.array([1.5, 0.0])
    prob = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=512, segments=segments))
    u = prob.start_unknowns(z, w)
    if case == "gap":
        assert simulate(model, {"w": w}, z[:1], z[1:], periods=1, steps_per_period=512).events >= 2
    (R, Ju, Jlam), plain = linearize_counted(prob, u, w)
    assert not plain  # one integration a segment: dR/dw is the sensitivity integrated with Phi
    np.testing.assert_array_equal(R, prob.residual(u, w))
    want = central_jacobian(prob, u, w)
    assert np.abs(Ju - want).max() <= 1e-6 * np.abs(want).max()
    # the block structure: -I on the cyclic block super-diagonal
    m = 2
    for k in range(segments):
        j = (k + 1) % segments
        if segments > 1:
            np.testing.assert_array_equal(Ju[k * m:(k + 1) * m, j * m:(j + 1) * m], -np.eye(m))
    # dR/dw by the difference of the default step against one ten times finer, Richardson-free
    h = 1e-7 * w
    finer = (prob.residual(u, w + h) - prob.residual(u, w - h)) / (2 * h)
    assert np.abs(Jlam - finer).max() <= 1e-6 * np.abs(finer).max()


@pytest.mark.parametrize("parameter, value", [("F", 0.5), ("c", C), ("w", 1.0)])
def test_the_sensitivity_in_any_parameter_of_the_matrices_or_excitations(parameter, value):
    """dR/dlam integrated with the variational equations in the forcing amplitude, the damping and the
    frequency on an orbit through the stop (two switches a period), against central differences."""
    model = gap_model()
    prob = ShootingProblem(model, parameter, params={"w": 1.0, "F": F, "c": C},
                           options=ShootingOptions(steps_per_period=512, segments=2))
    u = prob.start_unknowns(np.array([1.5, 0.0]), value)
    (_, _, Jlam), plain = linearize_counted(prob, u, value)
    assert not plain  # integrated with Phi
    h = 1e-6 * max(1.0, abs(value))
    want = (prob.residual(u, value + h) - prob.residual(u, value - h)) / (2 * h)
    assert np.abs(Jlam - want).max() <= 1e-6 * np.abs(want).max()


EXPRESSION_FORCE = """\
model:
  name: damped_mathieu
  dofs: [x]
  parameters: {c: 0.1, delta: 0.2, eps: 0.4, w: 1.0}
  mass: [[1]]
  damping: [[c]]
  stiffness: [[0]]
  forces:
    - {dof: x, expr: "x**2*x_dot + (delta + eps*cos(tau))*x"}
  frequency: w
analysis: {type: frequency_response, parameter: delta, range: [0, 1]}
"""


def _stop_with_clearance():
    model = polynomial_model(["x"], {"c": C, "F": F, "w": 1.0, "g": G}, mass=[[1.0]], damping=[["c"]],
                             stiffness=[[1.0]], forcing=[{"dof": "x", "amplitude": "F"}])
    model.forces.append(GapForce(0, Monomial.parse("g", list(model.parameters)), Monomial(20.0), sides="+"))
    return model, "g", G, np.array([1.5, 0.0])


def _expression_force():
    from contin.scene.build import build_model as scene_model
    from contin.scene.parse import parse_scene

    return scene_model(parse_scene(EXPRESSION_FORCE)), "delta", 0.2, np.array([0.5, 0.1])


@pytest.mark.parametrize("make", [_stop_with_clearance, _expression_force])
def test_a_parameter_of_a_force_law_takes_dR_dlam_by_differences(make):
    """The stop's clearance (a constant of its law) and a parameter an expression force reads: no sensitivity
    is integrated for them (two plain flows a segment), and dR/dlam is the central difference."""
    model, name, value, z = make()
    prob = ShootingProblem(model, name, params={"w": 1.0}, options=ShootingOptions(steps_per_period=512))
    u = prob.start_unknowns(z, value)
    (_, _, Jlam), plain = linearize_counted(prob, u, value)
    assert plain == 2
    h = 1e-7
    want = (prob.residual(u, value + h) - prob.residual(u, value - h)) / (2 * h)
    assert np.abs(Jlam - want).max() <= 1e-6 * np.abs(want).max()


def test_variational_and_difference_jacobians_agree():
    model = gap_model()
    z, w = np.array([1.5, 0.0]), 1.0
    lin = [ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=512, segments=2, jacobian=j))
           for j in ("variational", "differences")]
    Ja, Jb = (p.linearize(p.start_unknowns(z, w), w)[1] for p in lin)
    assert np.abs(Ja - Jb).max() < 1e-6 * np.abs(Jb).max()


# ------------------------------------------------------------------ multipliers
@pytest.mark.parametrize("case", ["duffing", "gap"])
def test_multipliers_of_one_and_four_segments_are_scipys_monodromy(case):
    """At a periodic orbit: M = 1 and M = 4 agree to 1e-8, and both are DOP853's multipliers to 1e-6."""
    if case == "duffing":
        model, w, guess = duffing_model(), 1.2, [1.0, 0.5]
    else:
        model, w, guess = gap_model(), 1.0, [1.5, 0.0]
    orbit = periodic_orbit(model, {"w": w}, guess, ShootingOptions(steps_per_period=1024))
    assert orbit.converged
    mus = []
    for M in (1, 4):
        prob = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=1024, segments=M))
        u = prob.start_unknowns(orbit.state, w)
        assert np.abs(prob.residual(u, w)).max() < 1e-9
        mus.append(prob.multipliers(u, w))
    np.testing.assert_allclose(mus[0], mus[1], rtol=0, atol=1e-8)
    hb, c = one_harmonic(model, orbit.state, w)
    ref = monodromy_reference(hb, c, w)
    assert ref.orbit_error < 1e-8  # DOP853 from the RK4 orbit's state closes: the same orbit
    want = np.linalg.eigvals(ref.matrix)
    want = want[np.argsort(-np.abs(want))]
    np.testing.assert_allclose(mus[0], want, rtol=0, atol=1e-6)
    if case == "gap":
        assert len(ref.switches) == 2  # through the stop: saltation in both


def test_the_stability_monitor_costs_no_integration():
    prob = ShootingProblem(duffing_model(), "w", options=ShootingOptions(steps_per_period=256, segments=2))
    u = prob.start_unknowns(np.array([0.5, 0.2]), 1.1)
    _, Ju, Jlam = prob.linearize(u, 1.1)
    calls = []
    prob._segment = lambda *a: calls.append(a)  # any integration would call it
    prob.flows = lambda *a: calls.append(a)
    data = ShootingStability(prob)(u, 1.1, Ju, Jlam)
    assert not calls and set(data) >= {"stable", "max_multiplier", "flip_test", "n_minus"}
    assert "graze" not in data  # no contact element


# ------------------------------------------------------------------ branches
@pytest.fixture(scope="module")
def duffing_branch():
    model = duffing_model()
    opts = ContinuationOptions(ds=0.05, ds_max=0.5)
    prob = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=512))
    z0 = periodic_orbit(model, {"w": 1.0}, [0.0, 0.0], prob.options).state
    mon = ShootingStability(prob)
    br = continuation(prob, prob.start_unknowns(z0, 1.0), 1.0, (1.0, 2.5), opts, monitors=[mon],
                      events=stability_events(mon))
    return prob, br


def test_duffing_branch_passes_both_folds_of_the_harmonic_balance(duffing_branch):
    prob, br = duffing_branch
    assert br.status.value == "range_end"
    hb = HarmonicBalance(prob.model, "w", HBOptions(harmonics=15))
    hbr = continuation(hb, hb.linear_solution(1.0), 1.0, (1.0, 2.5), ContinuationOptions(ds=0.05, ds_max=0.5))
    want = sorted(p.parameter for p in hbr.points_of_kind("fold"))
    got = sorted(p.parameter for p in br.points_of_kind("fold"))
    assert len(want) == 2 and len(got) == 2
    np.testing.assert_allclose(got, want, atol=1e-6)  # measured 4.5e-10 (RK4 at 512 steps)
    # the middle branch (between the folds along the arc) has one real multiplier beyond +1
    i, j = sorted(p.index for p in br.points_of_kind("fold"))
    n_plus = np.asarray(br.point_data["n_plus"])
    assert np.all(n_plus[i + 1:j] == 1) and np.all(n_plus[:i] == 0) and np.all(n_plus[j + 1:] == 0)


@pytest.fixture(scope="module")
def gap_branch():
    model = gap_model()
    prob = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=1024, segments=2))
    mon = ShootingStability(prob)
    events = stability_events(mon) + shooting_events(prob)
    br = continuation(prob, prob.start_unknowns(linear_state(0.8), 0.8), 0.8, (0.8, 1.0),
                      ContinuationOptions(ds=0.05, ds_max=0.1), parameter_name="w", monitors=[mon], events=events)
    return prob, br


def contact_count(model, w, S=8192):
    """Located contact switches over one period of the plain simulation on the periodic orbit (its own Newton)."""
    orbit = periodic_orbit(model, {"w": w}, linear_state(w), ShootingOptions(steps_per_period=S))
    assert orbit.converged
    z = orbit.state
    return simulate(model, {"w": w}, z[:1], z[1:], periods=1, steps_per_period=S).events


def test_gap_branch_locates_grazing_and_goes_on(gap_branch):
    prob, br = gap_branch
    assert br.status.value == "range_end" and br.parameter[-1] == pytest.approx(1.0)
    (gz,) = br.points_of_kind("grazing")
    assert gz.located and abs(gz.data["graze"]) < 1e-9
    # bisection on the contact count of plain simulations (their own orbits, no event involved)
    lo, hi = 0.89, 0.9
    assert contact_count(prob.model, lo) == 0 and contact_count(prob.model, hi) == 2
    while hi - lo > 1e-7:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if contact_count(prob.model, mid) == 0 else (lo, mid)
    assert abs(gz.parameter - 0.5 * (lo + hi)) < 2e-7
    # and the closed form: the linear response reaches the stop (measured 1.5e-11)
    assert gz.parameter == pytest.approx(brentq(lambda w: F / np.hypot(1 - w * w, C * w) - G, 0.5, 0.99), abs=1e-9)
    # graze is monitored: negative before, positive after
    g, w = np.asarray(br.point_data["graze"]), br.parameter
    assert np.all(g[w < gz.parameter - 1e-6] < 0) and np.all(g[w > gz.parameter + 1e-6] > 0)


def test_contacts_without_linearisation_are_the_linearisations(gap_branch):
    """graze and switches of an orbit that is not linearised (the points solved while a grazing is located)
    come from the flow without its variational equations: bit for bit those of the linearisation."""
    prob, br = gap_branch
    for i in (0, len(br) // 2, len(br) - 1):
        u, lam = np.asarray(br.unknowns[i]) * (1 + 1e-9), float(br.parameter[i])  # an orbit not cached yet
        g, n = prob.graze(u, lam), prob.switches(u, lam)
        assert prob._cache.get((u.tobytes(), lam)) is None  # no variational integration was made
        prob.linearize(u, lam)
        lin = prob._cache[(u.tobytes(), lam)]
        np.testing.assert_array_equal(g, lin.graze)
        assert n == lin.switches
    assert br.points_of_kind("grazing")[0].data["graze"] == pytest.approx(0.0, abs=1e-9)


def test_grazing_event_is_a_plain_located_event():
    prob = ShootingProblem(gap_model(), "w")
    (ev,) = shooting_events(prob)
    assert isinstance(ev, ShootingGrazingEvent) and not ev.barrier and ev.kind.value == "grazing"
    assert not ev.needs_linearisation  # its location solves no variational equations
    assert shooting_events(ShootingProblem(duffing_model(), "w")) == []


def test_an_extremum_at_a_segment_start_is_seen():
    """The parabola through the first three samples: a vertex within a step of the start."""
    x = np.arange(3.0)[:, None]
    np.testing.assert_allclose(start_graze(0.3 - 2 * (x + 0.7) ** 2), [0.3])
    assert np.isinf(start_graze(0.3 - 2 * (x - 1.7) ** 2)).all()


# ------------------------------------------------------------------ period doubling
@pytest.fixture(scope="module")
def mathieu_duffing_pd():
    """x'' + 0.1 x' + (delta + 0.4 cos t) x + x^3 = 0, two segments: the upper period doubling of the rest state."""
    model = build_model("mathieu", {"c": 0.1, "g": 1.0, "eps": 0.4, "w": 1.0})
    prob = ShootingProblem(model, "delta", options=ShootingOptions(steps_per_period=512, segments=2))
    mon = ShootingStability(prob)
    br = continuation(prob, np.zeros(4), 0.3, (0.3, 0.7), ContinuationOptions(ds=0.02, ds_max=0.05),
                      monitors=[mon], events=stability_events(mon))
    (pd,) = br.points_of_kind("pd")
    return prob, pd


def test_period_doubling_start_with_two_segments_follows_a_period_two_orbit(mathieu_duffing_pd):
    prob, pd = mathieu_duffing_pd
    doubled, u0, t0 = period_doubling_start(prob, pd.unknowns, pd.parameter)
    assert doubled.options.subharmonic == 2 and doubled.segments == 4 and u0.size == 8
    assert abs(np.linalg.norm(t0) - 1.0) < 1e-12 and t0[-1] == 0.0
    mon = ShootingStability(doubled)
    sub = continuation(doubled, u0, pd.parameter, (pd.parameter - 0.3, pd.parameter + 0.3),
                       ContinuationOptions(ds=0.02, ds_max=0.05, max_points=6), monitors=[mon], tangent=t0,
                       solve_start=False)
    assert len(sub) == 6
    for u, delta in zip(sub.unknowns[1:], sub.parameter[1:]):
        z = u[:2]

        def rhs(t, y):
            return [y[1], -0.1 * y[1] - (delta + 0.4 * np.cos(t)) * y[0] - y[0] ** 3]

        y = solve_ivp(rhs, (0, 4 * np.pi), z, method="DOP853", rtol=1e-12, atol=1e-13, dense_output=True)
        assert np.abs(y.y[:, -1] - z).max() < 1e-7  # closes after two periods
        assert np.abs(y.sol(2 * np.pi) - z).max() > 1e-3  # not after one
        np.testing.assert_allclose(u.reshape(4, 2), y.sol(np.arange(4) * np.pi).T, atol=1e-7)  # the segment starts


@pytest.mark.slow  # the rotor (8 states, 4096 steps per revolution)
def test_rotor_period_doubling_switches_onto_the_half_subharmonic_with_two_segments():
    """Bearing rotor, f0 = 0.5: the harmonic branch's period doubling near w = 2.1473, two segments."""
    model = build_model("bearing_rotor", {"f0": 0.5})
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=1024, crossings="none"))
    prob = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=4096, segments=2))
    u0 = prob.from_coefficients(hb, model.start(hb, 2.14), 2.14)
    mon = ShootingStability(prob)
    br = continuation(prob, u0, 2.14, (2.14, 2.15), ContinuationOptions(ds=0.05, ds_max=0.2),
                      parameter_name="w", monitors=[mon], events=stability_events(mon))
    pd = br.points_of_kind("pd")[0]
    assert abs(pd.parameter - 2.1473) < 1e-4  # the period doubling of the flow (measured 2.1473308)
    assert np.min(np.abs(prob.multipliers(pd.unknowns, pd.parameter) + 1.0)) < 1e-4
    doubled, u, t0 = period_doubling_start(prob, pd.unknowns, pd.parameter)
    assert doubled.segments == 4 and doubled.nu == 2
    sub = continuation(doubled, u, pd.parameter, (2.1, 2.25), ContinuationOptions(ds=0.002, ds_max=0.005,
                       max_points=4), parameter_name="w", monitors=[ShootingStability(doubled)], tangent=t0,
                       solve_start=False)
    assert len(sub) == 4
    for u, w in zip(sub.unknowns[1:], sub.parameter[1:]):
        z = u[:8]
        run = simulate(model, {"w": float(w)}, z[:4], z[4:], periods=2, steps_per_period=4096, record_every=4096)
        assert np.abs(run.final_state - z).max() < 1e-8  # a period-2 orbit of the flow
        assert np.abs(run.section[1] - z).max() > 1e-4  # not a period-1 orbit


# ------------------------------------------------------------------ orbits, starts and failures
def test_orbit_and_starts_of_a_linear_oscillator_are_the_closed_form():
    model = build_model("duffing", {"m": 1.0, "c": 0.1, "k": 1.0, "g": 0.0, "F": 0.5, "w": 1.3})
    w = 1.3
    X = 0.5 / (1 - w * w + 0.1j * w)
    prob = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=1024, segments=4))
    assert prob.n == 1 and prob.nu == 1 and prob.full is prob and prob.dof_names == tuple(model.dof_names)
    T = prob.period_at(w)
    t = np.linspace(0.0, T, 37)
    exact = lambda tt: (np.real(X * np.exp(1j * w * tt)), np.real(1j * w * X * np.exp(1j * w * tt)))
    u = prob.start_unknowns([X.real, -w * X.imag], w)
    np.testing.assert_allclose(u.reshape(4, 2), np.array(exact(np.arange(4) * T / 4)).T, atol=1e-10)
    x, xd = prob.orbit(u, w, t)
    assert x.shape == (1, 37) and xd.shape == (1, 37)
    np.testing.assert_allclose(x[0], exact(t)[0], atol=1e-9)
    np.testing.assert_allclose(xd[0], exact(t)[1], atol=1e-9)
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=3))
    np.testing.assert_allclose(prob.from_coefficients(hb, hb.linear_solution(w), w), u, atol=1e-10)
    with pytest.raises(ValueError, match=r"the times must lie in \[0, "):
        prob.orbit(u, w, [-0.1])


@pytest.mark.parametrize("kw,match", [
    ({"segments": 3}, r"ShootingOptions.segments must divide steps_per_period \* subharmonic = 4096"),
    ({"segments": 0}, "ShootingOptions.segments must be a positive integer"),
    ({"jacobian": "exact"}, r"ShootingOptions.jacobian must be one of \['variational', 'differences'\]"),
])
def test_options_are_validated_naming_the_field(kw, match):
    with pytest.raises(ValueError, match=match):
        ShootingOptions(**kw)


@settings(max_examples=fuzz_examples(40), deadline=None)
@given(S=st.integers(4, 600), nu=st.integers(1, 4), M=st.integers(1, 40))
def test_segments_must_end_on_the_step_grid(S, nu, M):
    """Any segment count is accepted exactly when it divides the steps of the orbit's period."""
    if (S * nu) % M == 0:
        assert ShootingOptions(steps_per_period=S, subharmonic=nu, segments=M).segments == M
    else:
        with pytest.raises(ValueError, match=f"segments must divide steps_per_period \\* subharmonic = {S * nu} "):
            ShootingOptions(steps_per_period=S, subharmonic=nu, segments=M)


def test_bad_unknowns_are_refused_with_their_shape():
    prob = ShootingProblem(duffing_model(), "w", options=ShootingOptions(steps_per_period=64, segments=2))
    with pytest.raises(ValueError, match=r"the unknowns must have shape \(4,\) = 2 segment start"):
        prob.residual(np.zeros(2), 1.0)
    with pytest.raises(ValueError, match=r"z0 must have shape \(2,\)"):
        prob.start_unknowns(np.zeros(4), 1.0)
    with pytest.raises(ArithmeticError, match="no positive forcing period"):
        prob.linearize(np.zeros(4), -1.0)


def test_a_model_without_jacobian_lines_falls_back_to_differences_and_says_so(monkeypatch):
    from contin.timedomain.integrator import CompiledModel, SimulationError

    def refuse(self):
        raise SimulationError("the element kind(s) 'odd' have no Jacobian lines")

    monkeypatch.setattr(CompiledModel, "jacobian_source", refuse)
    prob = ShootingProblem(duffing_model(), "w", options=ShootingOptions(steps_per_period=256))
    assert prob.jacobian == "differences" and "'odd' have no Jacobian lines" in prob.notes[0]
    u = prob.start_unknowns(np.array([0.5, 0.2]), 1.1)
    _, Ju, _ = prob.linearize(u, 1.1)
    assert np.abs(Ju - central_jacobian(prob, u, 1.1)).max() < 1e-6 * np.abs(Ju).max()


def test_a_step_beyond_rk4_stability_fails_the_evaluation():
    """A stop stiffer than the step allows: the engine is told by ArithmeticError (it then retries smaller)."""
    model = gap_model()
    model.forces[-1] = GapForce(0, Monomial(G), Monomial(1e6), sides="+")
    prob = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=64))
    with pytest.raises(ArithmeticError, match="beyond RK4's stability"):
        prob.linearize(np.zeros(2), 1.0)
    assert math.isfinite(prob.period_at(1.0))


@pytest.mark.parametrize("segments", [1, 4])
def test_a_strongly_unstable_orbit_keeps_its_small_multipliers(segments):
    """x'' + c x' - a x = F cos(w t): multipliers exp(lambda_pm T), lambda_pm = (-c +- sqrt(c^2 + 4a)) / 2.

    With a = 4, c = 0.1 and T = 2 pi the large one is 2.0e5 and the small one 2.6e-6: eigenvalues of the
    multiplied-out monodromy lose the small one to rounding at about eps * 2e5 / 2.6e-6 = 2e-5 relative; the
    periodic Schur decomposition of the factors keeps it to 1e-8.
    """
    a, c = 4.0, 0.1
    model = polynomial_model(["x"], {"c": c, "a": a, "F": 0.3, "w": 1.0}, mass=[[1.0]], damping=[["c"]],
                             stiffness=[["-a"]], forcing=[{"dof": "x", "amplitude": "F"}])
    prob = ShootingProblem(model, "w", options=ShootingOptions(segments=segments, steps_per_period=4096))
    X = 0.3 / (-a - 1.0 + 1j * c)  # the forced orbit (closed form), exact start
    u = prob.start_unknowns(np.array([X.real, -X.imag]), 1.0)
    T = 2 * math.pi
    root = math.sqrt(c * c + 4 * a)
    exact = np.array([math.exp(0.5 * (-c + root) * T), math.exp(0.5 * (-c - root) * T)])
    mu = prob.multipliers(u, 1.0)
    assert abs(mu[0].imag) == 0.0 and abs(mu[1].imag) == 0.0
    got = np.sort(mu.real)[::-1]
    assert exact[0] > 1e4
    np.testing.assert_allclose(got, exact, rtol=1e-8)


def test_segments_and_batches_in_threads_give_the_serial_numbers_bit_for_bit():
    """Each segment's flow writes only its own arrays: threads change the time, never a digit."""
    model = gap_model()
    w = 1.2
    prob = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=512, segments=4))
    u0 = prob.start_unknowns(linear_state(w), w)
    U = np.stack([u0, 1.1 * u0, 0.9 * u0])
    before = workers.threads()
    got = {}
    try:
        for n in (1, 2):
            workers.set_threads(n)
            prob._cache.clear()
            prob._passes.clear()
            got[n] = (*prob.linearize(u0, w), prob.residual(u0, w), prob.flows_many(U, w),
                      *[a for lin in prob.linearize_many(U, w) for a in lin], *prob.flow_jacobians(U[:, :2], w),
                      prob.graze(u0, w), prob.step_states(u0, w))
    finally:
        workers.set_threads(before)
    assert len(got[1]) == len(got[2])
    for a, b in zip(got[1], got[2]):
        assert np.array_equal(a, b)
    # the batches are the single calls, row by row
    for u, (R, Ju, Jlam) in zip(U, prob.linearize_many(U, w)):
        for a, b in zip((R, Ju, Jlam), prob.linearize(u, w)):
            assert np.array_equal(a, b)
        assert np.array_equal(prob.flows_many(u[None], w)[0], prob.flows(u, w))
