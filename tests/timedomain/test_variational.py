"""The compiled variational flow (contin.timedomain.variational): its derivative against central differences of
the flow, its multipliers against scipy's DOP853 with saltation, its factors, its grazing measure, its refusals."""

import dataclasses
import math
import textwrap

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.catalog import build_model
from contin.model.elements.harmonic import HarmonicExcitation, HarmonicForm
from contin.model.elements.polynomial import PolynomialForce, PolynomialForm
from contin.model.elements.registry import CompiledForm
from contin.scene.build import build_model as build_scene_model
from contin.scene.parse import parse_scene
from contin.stability import monodromy_reference
from contin.timedomain.shooting import ShootingOptions, periodic_orbit
from contin.timedomain.simulation import SimulationError, simulate
from contin.timedomain.variational import VariationalFlow

# a one-dof oscillator on a one-sided stop with contact damping (the force jumps by cc x' at each crossing) and
# expression forces (their Jacobian lines are the symbolic derivatives)
GAP = """
model:
  dofs: [x]
  parameters: {c: 0.05, g: 1.0, kc: 20, cc: 0.3, F: 0.5, w: 1.0, a3: 0.1, a2: 0.02}
  mass: [[1]]
  damping: [[c]]
  stiffness: [[1]]
  forces:
    - {type: gap, dof: x, clearance: g, stiffness: kc, damping: cc, sides: "+", clip: CLIP}
    - {dof: x, expr: "a3*x**3 + a2*x**2*x_dot"}
  excitation:
    - {dof: x, amplitude: F}
  frequency: w
analysis: {type: simulate, parameter: w, values: [1.0]}
"""


def gap_model(clip: bool):
    return build_scene_model(parse_scene(textwrap.dedent(GAP.replace("CLIP", str(clip).lower()))))


def central_differences(flow, z, p, k0, k1, mode=None, rel=1e-6):
    """d z(k1) / d z(k0) by central differences of the flow's state-only runs (mode held at k0)."""
    e = rel * max(1.0, float(np.max(np.abs(z))))
    J = np.empty((z.size, z.size))
    for j in range(z.size):
        d = np.zeros(z.size)
        d[j] = e
        J[:, j] = (flow.run(z + d, p, k0, k1, jacobian=False, mode=mode).state
                   - flow.run(z - d, p, k0, k1, jacobian=False, mode=mode).state) / (2.0 * e)
    return J


def relative_max(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.fixture(scope="module")
def duffing():
    model = build_model("duffing", {"g": 1.0, "F": 0.5, "w": 1.4})
    return model, VariationalFlow(model, steps_per_period=256)


def test_duffing_jacobian_is_the_derivative_of_the_flow(duffing):
    model, flow = duffing
    p = model.parameter_vector()
    z = np.array([0.3, -0.2])
    run = flow.run(z, p, 0, 256, factors=4)
    # the state is the simulation's, to the bit (the same RK4 arithmetic)
    sim = simulate(model, {}, z[:1], z[1:], periods=1, steps_per_period=256)
    np.testing.assert_array_equal(run.state, sim.final_state)
    assert relative_max(run.jacobian, central_differences(flow, z, p, 0, 256)) < 1e-6
    # Liouville: det Phi = exp(-c T / m) for the damped Duffing, up to the RK4 error
    c, m, w = (model.parameter_vector()[model.parameter_index(q)] for q in ("c", "m", "w"))
    assert np.linalg.det(run.jacobian) == pytest.approx(math.exp(-c / m * 2 * math.pi / w), rel=1e-7)


def test_factors_multiply_to_the_jacobian_and_k_must_divide_the_steps(duffing):
    model, flow = duffing
    p = model.parameter_vector()
    z = np.array([-0.4, 0.7])
    one = flow.run(z, p, 32, 32 + 512, factors=1)
    assert one.factors.shape == (1, 2, 2)
    np.testing.assert_array_equal(one.factors[0], one.jacobian)
    for K in (4, 8):
        run = flow.run(z, p, 32, 32 + 512, factors=K)
        assert run.factors.shape == (K, 2, 2)
        prod = np.eye(2)
        for f in run.factors:
            prod = f @ prod
        np.testing.assert_array_equal(prod, run.jacobian)
        np.testing.assert_allclose(run.jacobian, one.jacobian, rtol=1e-12, atol=1e-12 * np.abs(one.jacobian).max())
        # each factor is the derivative over its share of the steps
        share = flow.run(z, p, 32, 32 + 512 // K, factors=1)
        np.testing.assert_allclose(run.factors[0], share.jacobian, rtol=1e-13, atol=1e-14)
    with pytest.raises(ValueError, match=r"factors K = 3 must be a positive divisor .* k1 - k0 = 512"):
        flow.run(z, p, 32, 32 + 512, factors=3)
    bare = flow.run(z, p, 32, 32 + 512, jacobian=False)
    assert bare.factors.shape == (0, 2, 2) and bare.jacobian is None
    np.testing.assert_array_equal(bare.state, one.state)


@settings(max_examples=25, deadline=None)
@given(steps=st.integers(1, 64), K=st.integers(-3, 70))
def test_factor_count_not_dividing_the_steps_is_refused_by_name(duffing, steps, K):
    model, flow = duffing
    p = model.parameter_vector()
    if K >= 1 and steps % K == 0:
        assert flow.run(np.zeros(2), p, 0, steps, factors=K).factors.shape == (K, 2, 2)
    else:
        with pytest.raises(ValueError, match=f"factors K = {K} must be a positive divisor"):
            flow.run(np.zeros(2), p, 0, steps, factors=K)


def test_hostile_arguments_are_refused_with_their_names(duffing):
    model, flow = duffing
    p = model.parameter_vector()
    with pytest.raises(ValueError, match=r"z must have shape \(2,\)"):
        flow.run(np.zeros(3), p, 0, 8)
    with pytest.raises(ValueError, match="the state z is not finite"):
        flow.run(np.array([np.nan, 0.0]), p, 0, 8)
    with pytest.raises(ValueError, match="p must have 6 entries"):
        flow.run(np.zeros(2), p[:3], 0, 8)
    with pytest.raises(ValueError, match="need 0 <= k0 < k1, got k0 = 8, k1 = 8"):
        flow.run(np.zeros(2), p, 8, 8)
    with pytest.raises(ValueError, match="k1 must be an integer"):
        flow.run(np.zeros(2), p, 0, 8.0)
    with pytest.raises(ValueError, match="mode must have 0 entries"):
        flow.run(np.zeros(2), p, 0, 8, mode=[1])
    with pytest.raises(ValueError, match="steps_per_period must be an integer >= 4"):
        VariationalFlow(model, steps_per_period=2)
    bad = p.copy()
    bad[model.parameter_index("w")] = -1.0
    with pytest.raises(ValueError, match="forcing frequency w must be positive"):
        flow.run(np.zeros(2), bad, 0, 8)


def test_a_flow_that_blows_up_raises_simulation_error(duffing):
    model, flow = duffing
    with pytest.raises(SimulationError, match="blew up: non-finite state or derivative at step 1"):
        flow.run(np.array([1e120, 0.0]), model.parameter_vector(), 0, 8)


class _NoJacobianForm(PolynomialForm):
    def jacobian_lines(self, tag, c, m):
        return None


class _NoJacobianForce(PolynomialForce):
    kind = "cubic_without_jacobian"

    def compiled_form(self):
        return _NoJacobianForm(self)


def _without_jacobian(duffing):
    """The Duffing model with its cubic in a form that has no Jacobian lines, and its flow."""
    model, _ = duffing
    el = model.forces[0]
    odd = _NoJacobianForce.__new__(_NoJacobianForce)
    odd.__dict__.update(el.__dict__)
    bad = dataclasses.replace(model, forces=[odd])
    return VariationalFlow(bad, steps_per_period=256)


def test_an_element_without_jacobian_lines_is_refused_by_name(duffing):
    flow = _without_jacobian(duffing)
    p = duffing[0].parameter_vector()
    z = np.array([0.3, -0.2])
    with pytest.raises(SimulationError, match=r"'cubic_without_jacobian' \(_NoJacobianForce\) have no Jacobian lines"):
        flow.run(z, p, 0, 256)


@pytest.mark.slow  # compiles a module of its own (~20 s without the kernel cache)
def test_an_element_without_jacobian_lines_still_has_its_state_integrated(duffing):
    flow = _without_jacobian(duffing)
    p = duffing[0].parameter_vector()
    z = np.array([0.3, -0.2])
    np.testing.assert_array_equal(flow.run(z, p, 0, 256, jacobian=False).state, duffing[1].run(z, p, 0, 256).state)


def _linear_orbit():
    """The gap oscillator whose stop (g = 1.6) is never reached: the model, its parameter vector, and the
    amplitude, frequency and phase of its steady state x = A cos(w t - phi) (closed form)."""
    model = gap_model(False)
    p = model.parameter_vector({"g": 1.6, "F": 0.5, "w": 0.8, "a3": 0.0, "a2": 0.0})
    c, w, F = 0.05, 0.8, 0.5
    return model, p, F / math.hypot(1 - w * w, c * w), w, math.atan2(c * w, 1 - w * w)


def test_graze_is_the_extremum_of_the_switching_function_of_a_linear_orbit():
    """A stop never reached: x = A cos(w t - phi), so the extremum of x - g is A - g (closed form)."""
    model, p, A, w, phi = _linear_orbit()
    z = np.array([A * math.cos(phi), A * w * math.sin(phi)])  # the steady state at t = 0
    S = 512
    flow = VariationalFlow(model, steps_per_period=S)
    run = flow.run(z, p, 0, 2 * S)
    assert run.switches == 0 and run.mode.tolist() == [0, 0]
    # parabola through step-end samples: error <= |s'''| h^3 / (9 sqrt 3), s''' = A w^3 here
    h = 2 * math.pi / w / S
    assert A - 1.6 < -0.2 and abs(run.graze[0] - (A - 1.6)) <= A * w ** 3 * h ** 3 / (9 * math.sqrt(3)) + 1e-12
    assert run.graze[1] == math.inf  # the absent side is a constant


@pytest.mark.parametrize("jacobian", [False, True])
@pytest.mark.parametrize("last", [0, 1, 5])
def test_graze_of_a_run_whose_extremum_lies_in_its_last_steps(jacobian, last):
    """A run of a few steps ending ``last`` steps after the one that holds the crest of x = A cos(w t - phi):
    the crest's turn is found there too (a step's turn is taken with the slopes at its end, which the next
    step's first stage gives, or, for the run's last step, one more evaluation)."""
    model, p, A, w, phi = _linear_orbit()
    S = 512
    h = 2 * math.pi / w / S
    k_crest = int(phi / w / h)  # the crest at t = phi / w lies in step k_crest
    k0 = k_crest - 6
    t0 = k0 * h
    z = np.array([A * math.cos(w * t0 - phi), -A * w * math.sin(w * t0 - phi)])
    run = VariationalFlow(model, steps_per_period=S).run(z, p, k0, k_crest + 1 + last, jacobian=jacobian)
    assert abs(run.graze[0] - (A - 1.6)) <= A * w ** 3 * h ** 3 / (9 * math.sqrt(3)) + 1e-12


def _hb_at(model, z, w, lam_name="w"):
    """A one-harmonic HB problem and coefficients whose state at t = 0 is z (its start for monodromy_reference)."""
    hb = HarmonicBalance(model, lam_name, HBOptions(harmonics=1, samples=16, crossings="none"))
    n = model.n_dof
    U = np.zeros((3, n))
    U[0] = z[:n]
    U[2] = z[n:] / w  # x'(0) = w b_1
    return hb, U.reshape(-1)


def test_duffing_multipliers_match_dop853_at_a_periodic_orbit():
    model = build_model("duffing", {"g": 1.0, "F": 0.5, "w": 1.4})
    S = 1024
    z0 = simulate(model, {}, [0.5], [0.0], periods=40, steps_per_period=S).final_state
    orbit = periodic_orbit(model, {}, z0, ShootingOptions(steps_per_period=S))
    assert orbit.converged
    run = VariationalFlow(model, steps_per_period=S).run(orbit.state, model.parameter_vector(), 0, S, factors=4)
    hb, u = _hb_at(model, orbit.state, 1.4)
    ref = monodromy_reference(hb, u, 1.4)
    assert ref.orbit_error < 1e-8
    mu = np.sort_complex(np.linalg.eigvals(run.jacobian))
    np.testing.assert_allclose(mu, np.sort_complex(ref.multipliers), atol=1e-6)


@pytest.mark.parametrize("clip", [False, True])
def test_gap_oscillator_jacobian_and_multipliers_with_saltation(clip):
    model = gap_model(clip)
    S = 1024
    p = model.parameter_vector()
    z0 = simulate(model, {}, [0.0], [0.0], periods=60, steps_per_period=S).final_state
    flow = VariationalFlow(model, steps_per_period=S)
    run = flow.run(z0, p, 0, S, factors=8)
    assert run.switches == 2 and run.undefined_saltations == 0  # into the stop and out, once a period
    assert run.graze[0] > 0.05 and run.graze[1] == math.inf
    assert relative_max(run.jacobian, central_differences(flow, z0, p, 0, S)) < 1e-6
    orbit = periodic_orbit(model, {}, z0, ShootingOptions(steps_per_period=S))
    assert orbit.converged
    run = flow.run(orbit.state, p, 0, S, factors=4)
    hb, u = _hb_at(model, orbit.state, 1.0)
    ref = monodromy_reference(hb, u, 1.0)
    assert len(ref.switches) == 2 and ref.orbit_error < 1e-8
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(run.jacobian)), np.sort_complex(ref.multipliers),
                               atol=1e-6)


@pytest.mark.slow  # the rotor's own module (~20 s to compile without the kernel cache), S = 4096, 17 runs
@pytest.mark.parametrize("clip", [False, True])
def test_bearing_rotor_jacobian_is_the_derivative_of_the_flow(clip):
    model = build_model("bearing_rotor", {"f0": 0.5, "w": 2.16}, clip=clip)
    S = 4096
    p = model.parameter_vector()
    sim = simulate(model, {}, periods=40, steps_per_period=S)
    flow = VariationalFlow(model, steps_per_period=S)
    k0 = 40 * S
    run = flow.run(sim.final_state, p, k0, k0 + 2 * S, factors=4, mode=sim.final_mode)
    assert relative_max(run.jacobian, central_differences(flow, sim.final_state, p, k0, k0 + 2 * S,
                                                          mode=sim.final_mode)) < 1e-6


@pytest.mark.slow  # the belt's own module (~20 s to compile without the kernel cache)
def test_galerkin_string_stretching_and_point_force_jacobians():
    """The timing belt: a rank-one cubic (string stretching) and a point polynomial (the magnet)."""
    model = build_model("timing_belt")
    S = 1024
    p = model.parameter_vector()
    z0 = simulate(model, {}, periods=5, steps_per_period=S).final_state
    flow = VariationalFlow(model, steps_per_period=S)
    run = flow.run(z0, p, 0, S)
    assert relative_max(run.jacobian, central_differences(flow, z0, p, 0, S)) < 1e-6


@pytest.mark.slow  # the rotor's own module; 4 x 17 runs
def test_a_slow_exit_from_a_stiff_contact_has_the_discrete_maps_derivative():
    """Bearing rotor, f0 = 0.2, w = 2.0: the bearing leaves its casing slowly (n^T f- small, h |lambda| near 1).

    There the discrete map's own derivative is 1.6e-2 off the flow's (the same interval at 16 S); the Jacobian
    is the discrete map's, against central differences with Richardson extrapolation (relative steps 4e-10
    and 2e-10: the map's curvature there makes plain differences at 1e-10 off by 2e-6), and over a period
    against plain ones (docs/validation/monodromy.md).
    """
    model = build_model("bearing_rotor", {"f0": 0.2, "w": 2.0})
    S = 4096
    p = model.parameter_vector()
    sim = simulate(model, {}, periods=60, steps_per_period=S)
    flow = VariationalFlow(model, steps_per_period=S)
    z, mode = sim.final_state, sim.final_mode
    lo, hi = 0, S  # the step of the first switch
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if flow.run(z, p, 0, mid, jacobian=False, mode=mode).switches:
            hi = mid
        else:
            lo = mid
    start = flow.run(z, p, 0, lo, jacobian=False, mode=mode)
    coarse = flow.run(start.state, p, lo, lo + 64, mode=start.mode)
    assert coarse.switches == 1 and coarse.undefined_saltations == 0
    d1, d2 = (central_differences(flow, start.state, p, lo, lo + 64, mode=start.mode, rel=r) for r in (4e-10, 2e-10))
    assert relative_max(coarse.jacobian, (4.0 * d2 - d1) / 3.0) < 1e-6
    fine_flow = VariationalFlow(model, steps_per_period=16 * S)
    fine_fd = central_differences(fine_flow, start.state, p, 16 * lo, 16 * (lo + 64), mode=start.mode, rel=1e-10)
    assert relative_max(coarse.jacobian, fine_fd) > 1e-3  # the discrete map's derivative, not the flow's
    period = flow.run(z, p, 0, S, mode=mode)
    assert period.switches >= 2
    assert relative_max(period.jacobian, central_differences(flow, z, p, 0, S, mode=mode, rel=1e-7)) < 1e-6


# a one-dof oscillator on a stiff stop (h |lambda| = 2.45 in contact at S = 256: RK4 resolves no bounce), an
# expression excitation and an expression force that depend on the phase tau (their d/dtau lines enter the
# derivative of a step in its start and end times)
STOP = """
model:
  dofs: [x]
  parameters: {c: 0.1, g: 1.0, kc: 2500, F: 1.0, F2: 0.2, e: 0.05, w: 0.5}
  mass: [[1]]
  damping: [[c]]
  stiffness: [[1]]
  forces:
    - {type: gap, dof: x, clearance: g, stiffness: kc, damping: 0, sides: "+"}
    - {dof: x, expr: "e*x*cos(tau)"}
  excitation:
    - {dof: x, expr: "F*cos(tau) + F2*sin(2*tau)"}
  frequency: w
analysis: {type: simulate, parameter: w, values: [0.5]}
"""


@pytest.fixture(scope="module")
def stop():
    model = build_scene_model(parse_scene(textwrap.dedent(STOP)))
    return model, VariationalFlow(model, steps_per_period=256)


def _rk4_step(flow, p, y, t0, t1, mode, om):
    """The compiled RK4 step of the state from time t0 to t1 (phase om t0), the loop's own arithmetic."""
    _, args = flow._arguments(p)
    n = flow.n
    out = np.zeros(2 * n)
    scratch = [np.zeros((1, n)), np.zeros((1, n)), np.zeros(1), np.zeros((1, n)), np.zeros((1, n, n)), np.zeros(n)]
    flow.module._step(y, om * t0, om * (t1 - t0), t1 - t0, p, *args, np.array([mode]), *scratch,
                      *[np.zeros(2 * n) for _ in range(5)], out)
    return out


@settings(max_examples=25, deadline=None)
@given(x=st.floats(0.5, 1.05), v=st.floats(-1.0, 1.0), tau0=st.floats(0.0, 2 * math.pi),
       hs=st.floats(1e-3, 0.049), mode=st.sampled_from([0, 1]))
def test_step_time_derivatives_match_central_differences_of_one_rk4_step(stop, x, v, tau0, hs, mode):
    """dR/dt0 and dR/dt1 of one RK4 step against central differences of the compiled step in t0 and t1."""
    model, flow = stop
    p = model.parameter_vector()
    om = 0.5
    y = np.array([x, v])
    ta, tb = np.zeros(2), np.zeros(2)
    flow.module.step_times(y, tau0, om * hs, hs, om, p, *flow._arguments(p)[1], np.array([mode]), ta, tb)
    t0, t1, e = tau0 / om, tau0 / om + hs, 1e-6
    fa = (_rk4_step(flow, p, y, t0 + e, t1, mode, om) - _rk4_step(flow, p, y, t0 - e, t1, mode, om)) / (2 * e)
    fb = (_rk4_step(flow, p, y, t0, t1 + e, mode, om) - _rk4_step(flow, p, y, t0, t1 - e, mode, om)) / (2 * e)
    scale = max(1.0, float(np.max(np.abs(tb))))
    np.testing.assert_allclose(ta, fa, rtol=0, atol=1e-7 * scale)
    np.testing.assert_allclose(tb, fb, rtol=0, atol=1e-7 * scale)


def test_the_phase_derivative_enters_the_step_time_derivatives(stop):
    """Free flight (mode 0) at tau0 = 0.3: dR/dt0 + dR/dt1 is the step's derivative in its phase, not zero."""
    model, flow = stop
    p = model.parameter_vector()
    om, hs, y = 0.5, 0.04, np.array([0.9, 0.2])
    ta, tb = np.zeros(2), np.zeros(2)
    flow.module.step_times(y, 0.3, om * hs, hs, om, p, *flow._arguments(p)[1], np.array([0]), ta, tb)
    t0 = 0.3 / om
    e = 1e-6
    shift = (_rk4_step(flow, p, y, t0 + e, t0 + hs + e, 0, om)
             - _rk4_step(flow, p, y, t0 - e, t0 + hs - e, 0, om)) / (2 * e)
    assert np.max(np.abs(shift)) > 5e-4
    np.testing.assert_allclose(ta + tb, shift, rtol=0, atol=1e-9)


def test_a_slow_exit_from_a_stiff_stop_has_the_discrete_maps_derivative(stop):
    """Over a period of the settled orbit (two contacts, the second a near-grazing one entered and left with
    |x'| < 0.01): the Jacobian is the derivative of the discrete map, located switches included (the
    continuous flow's saltation matrix left it 34 % off at this step size)."""
    model, flow = stop
    p = model.parameter_vector()
    S = 256
    z0 = simulate(model, {}, [0.0], [0.0], periods=30, steps_per_period=S).final_state
    run = flow.run(z0, p, 0, S, factors=4)
    assert run.switches == 4 and run.unresolved == 0 and run.undefined_saltations == 0
    y, m, slow = z0, None, 0
    for k in range(S):
        r = flow.run(y, p, k, k + 1, jacobian=False, mode=m)
        slow += r.switches > 0 and abs(r.state[1]) < 0.01
        y, m = r.state, r.mode
    assert slow == 1
    assert relative_max(run.jacobian, central_differences(flow, z0, p, 0, S, rel=1e-7)) < 1e-6


def test_two_switches_in_one_step_have_the_discrete_maps_derivative(stop):
    """A contact arc shorter than a step (into the stop and out within step 60) and the steps after it."""
    model, flow = stop
    p = model.parameter_vector()
    z = np.array([1.0 - 2e-4, 0.03])
    one = flow.run(z, p, 60, 61, jacobian=False)
    assert one.switches == 2 and one.unresolved == 0 and one.mode.tolist() == [0, 0]
    run = flow.run(z, p, 60, 64)
    assert run.switches == 2
    assert relative_max(run.jacobian, central_differences(flow, z, p, 60, 64, rel=1e-7)) < 1e-6


class _TimedPolynomial(PolynomialForce):
    kind = "polynomial"


def test_a_phase_dependent_kind_without_tau_derivative_lines_is_refused_by_name(duffing):
    """A polynomial term times cos(2 tau) has Jacobian lines but no tau-derivative lines: refused, named."""
    model, _ = duffing
    el = model.forces[0]
    timed = _TimedPolynomial.__new__(_TimedPolynomial)
    timed.__dict__.update(el.__dict__)
    timed.torder = np.full(len(el.coefs), 2.0)
    flow = VariationalFlow(dataclasses.replace(model, forces=[timed]), steps_per_period=256)
    with pytest.raises(SimulationError, match=r"'polynomial' \(_TimedPolynomial\) depend on the phase tau and have no "
                                              r"tau-derivative lines"):
        flow.run(np.array([0.3, -0.2]), model.parameter_vector(), 0, 256)


class _UntimedForm(CompiledForm):
    # the cosine line of HarmonicForm without its tau-derivative line
    constants = HarmonicForm.constants
    excitation_lines = HarmonicForm.excitation_lines


class _UntimedExcitation(HarmonicExcitation):
    kind = "untimed_forcing"

    def compiled_form(self):
        return _UntimedForm(self)


def test_an_excitation_without_tau_derivative_lines_is_refused_by_name(duffing):
    model, _ = duffing
    el = model.excitations[0]
    odd = _UntimedExcitation.__new__(_UntimedExcitation)
    odd.__dict__.update(el.__dict__)
    flow = VariationalFlow(dataclasses.replace(model, excitations=[odd]), steps_per_period=256)
    with pytest.raises(SimulationError, match=r"'untimed_forcing' \(_UntimedExcitation\) depend on the phase tau"):
        flow.run(np.array([0.3, -0.2]), model.parameter_vector(), 0, 256)


COUPLED = """
model:
  dofs: [x, y]
  parameters: {m: 1.0, mc: 0.2, c: 0.05, w: 1.0}
  mass: [[m, MC], [MC, m]]
  damping: [[c, 0], [0, c]]
  stiffness: [[2, -1], [-1, 2]]
  excitation:
    - {dof: x, amplitude: 0.1}
  frequency: w
analysis: {type: simulate, parameter: w, values: [1.0]}
"""


@pytest.mark.parametrize("coupling, diagonal", [("0", True), ("0.0", True), ("mc", False), ("0.1", False)])
def test_a_mass_diagonal_for_every_parameter_is_told_from_its_terms(coupling, diagonal):
    from contin.timedomain.integrator import compile_model

    model = build_scene_model(parse_scene(textwrap.dedent(COUPLED.replace("MC", coupling))))
    assert compile_model(model).diagonal_mass is diagonal
    assert compile_model(build_model("bearing_rotor")).diagonal_mass
    assert not compile_model(build_model("timing_belt")).diagonal_mass


@pytest.mark.slow  # a second module of the stop oscillator (its compilation)
def test_the_diagonal_mass_shortcut_gives_the_full_products_numbers_bit_for_bit(monkeypatch):
    import contin.timedomain.integrator as integrator

    model = gap_model(True)
    p = model.parameter_vector()
    z = np.array([1.3, 0.2])
    sens = (np.zeros((1, 1)), np.zeros((1, 1)), np.zeros(model_constants(model)), -1.0)
    runs = []
    for diagonal in (True, False):
        monkeypatch.setattr(integrator, "_structurally_diagonal", lambda mass, d=diagonal: d)
        flow = VariationalFlow(model, steps_per_period=256)
        assert flow.compiled.diagonal_mass is diagonal
        runs.append(flow.run(z, p, 0, 3 * 256, factors=3, sensitivity=sens))
    a, b = runs
    assert a.switches == b.switches > 0
    for x, y in ((a.state, b.state), (a.jacobian, b.jacobian), (a.sensitivity, b.sensitivity), (a.graze, b.graze)):
        assert np.array_equal(x, y)


def model_constants(model) -> int:
    from contin.timedomain.integrator import compile_model

    return compile_model(model).n_constants
