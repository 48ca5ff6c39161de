"""``settled``: a simulated response is a steady state of the equations, not of the integrator or of a transient.

Truth from outside the code: closed forms of linear oscillators (the damped
one's amplitude ``F / |1 - w^2 + i c w|``; the undamped one forced at
resonance grows as ``F t / 2``; a negatively damped one grows as
``exp(-c t / 2)``), and the linearised stiffness of a saturating spring,
which fixes the small response a stable integration must find.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contin.scene.build import build_model
from contin.scene.parse import parse_scene
from contin.timedomain.poincare import classify, steady_state
from contin.timedomain.simulation import SimulationResult
from conftest import fuzz_examples

ONE_DOF = """
model:
  name: one_dof
  dofs: [x]
  parameters: {c: C, k1: K1, F: 0.5, w: 1.0}
  mass: [[1]]
  damping: [[c]]
  stiffness: [[1]]
  forces:
    - {dof: x, expr: "FORCE"}
  excitation:
    - {dof: x, amplitude: F, order: 1}
  frequency: w
analysis: {type: simulate, parameter: w, values: [1.0]}
"""


def one_dof(c, force="0*x", k1=0.0, F=0.5):
    text = ONE_DOF.replace("FORCE", force).replace("K1", repr(k1)).replace("C", repr(c)).replace("F: 0.5", f"F: {F}")
    return build_model(parse_scene(text))


def test_a_damped_linear_oscillator_is_settled_at_its_closed_form_amplitude():
    model = one_dof(0.1)
    w = 0.8
    res, cls = steady_state(model, {"w": w}, [0.0], [0.0], transient=150, record=20, steps_per_period=256,
                            samples_per_period=64, dofs=(0,))
    assert cls.label == "period-1" and cls.settled and cls.unsettled == ""
    # x = A cos(w t + phi): its components at +w and -w have modulus A/2 each
    amplitude = abs(cls.whirl["+w"]) + abs(cls.whirl["-w"])
    assert amplitude == pytest.approx(0.5 / abs(1 - w * w + 0.1j * w), rel=1e-7)
    assert cls.step_change < 1e-6 and cls.growth == pytest.approx(1.0, abs=1e-6)


def test_an_undamped_resonance_growing_without_bound_is_not_settled():
    # x'' + x = F cos t: x = F t sin(t) / 2; after 1500 revolutions each one adds 1/1550 of the record's
    # range, below the section tolerance: period-1 by its section, but its amplitude grows without bound
    model = one_dof(0.0)
    res, cls = steady_state(model, {"w": 1.0}, [0.0], [0.0], transient=1500, record=100, steps_per_period=64,
                            samples_per_period=16, dofs=(0,))
    assert np.abs(res.x).max() == pytest.approx(0.5 * res.t[-1] / 2, rel=2e-3)  # F t / 2 at the end
    assert not cls.settled
    assert cls.growth == pytest.approx((1600 - 12.5) / (1500 + 12.5), rel=5e-3)  # last quarter / first
    assert "amplitude grows over the record" in cls.unsettled


def test_negative_damping_is_never_settled():
    # unforced x'' - 0.02 x' + x = 0 from x = 0.01: x = 0.01 exp(0.01 t) cos(t), each quarter's peak near
    # its end (within one free period), 12 revolutions of T = 4 pi apart from the first quarter's to the last
    model = one_dof(-0.02, F=0.0)
    _, cls = steady_state(model, {"w": 0.5}, [0.01], [0.0], transient=10, record=16, steps_per_period=64,
                          samples_per_period=16, dofs=(0,))
    assert not cls.settled and "amplitude grows" in cls.unsettled
    assert cls.growth == pytest.approx(math.exp(0.01 * 12 * 4 * math.pi), rel=0.07)


def test_an_integrator_beyond_its_stability_limit_gives_a_step_dependent_answer_not_a_settled_one():
    # a spring k1*tanh(x) of small-amplitude stiffness 401 (w0 ~ 20): with 16 steps per period h*w0 ~ 7.9,
    # RK4 amplifies the fast mode until the spring saturates, a limit cycle of the integrator; the check
    # before the run sees only the linear stiffness 1. The true response is the linear one: F/|401 - 1 + 0.1 i|
    model = one_dof(0.1, "k1*tanh(x)", 400.0)
    res, cls = steady_state(model, {"w": 1.0}, [0.01], [0.0], transient=200, record=40, steps_per_period=16,
                            samples_per_period=8, dofs=(0,))
    assert np.ptp(res.x) / 2 > 100 * 0.5 / abs(400 + 0.1j)  # the integrator's answer
    assert not cls.settled and cls.step_change > 1.0
    assert cls.unsettled.startswith("the result depends on the step") and "raise steps_per_period" in cls.unsettled
    # with a step within RK4's limit it is settled, at the linear amplitude
    res, cls = steady_state(model, {"w": 1.0}, [0.01], [0.0], transient=200, record=40, steps_per_period=256,
                            samples_per_period=8, dofs=(0,))
    assert cls.settled and np.ptp(res.x) / 2 == pytest.approx(0.5 / abs(400 + 0.1j), rel=1e-3)


def test_a_stiff_stop_written_as_an_expression_blows_up_and_is_not_settled():
    # kc (x - 0.5)_+ with kc = 1e4: h * sqrt(kc) = 4.9 with 128 steps per period; the energy grows over
    # the record by tens of orders of magnitude, yet the run stays finite
    model = one_dof(0.1, "k1*max(x - 0.5, 0)", 1e4)
    res, cls = steady_state(model, {"w": 1.0}, [0.01], [0.0], transient=200, record=40, steps_per_period=128,
                            samples_per_period=8, dofs=(0,))
    assert np.ptp(res.x) > 1e10
    assert not cls.settled and cls.growth > 10.0 and cls.step_change > 0.1
    assert "amplitude grows over the record" in cls.unsettled and "depends on the step" in cls.unsettled


W, T, SPP = 2.0, math.pi, 32


def record(fn, revolutions=60):
    t = np.arange(revolutions * SPP) * (T / SPP)
    ts = np.arange(revolutions + 1) * T
    x, v = fn(t)
    xs, vs = fn(ts)
    return SimulationResult(t=t, x=x[:, None], v=v[:, None], section=np.stack([xs, vs], axis=1), w=W, period=T,
                            steps_per_period=SPP, h=T / SPP, steps=revolutions * SPP, events=0, unresolved_events=0,
                            extra_evaluations=0, wall_time=0.0, compile_time=0.0, params={}, dof_names=("x",),
                            final_state=np.zeros(2), final_mode=np.zeros(0, int))


@settings(max_examples=fuzz_examples(60), deadline=None, derandomize=True, database=None)
@given(rate=st.floats(3e-4, 0.5), amp=st.floats(1e-6, 1e6), phase=st.floats(0, 2 * math.pi),
       linear=st.booleans())
def test_a_record_whose_amplitude_grows_is_never_settled(rate, amp, phase, linear):
    # a periodic motion whose amplitude grows, exponentially or linearly, by `rate` per revolution at its start
    def grow_exact(t):
        g = 1.0 + rate * t / T if linear else np.exp(rate * t / T)
        dg = (rate / T) * (np.ones_like(t) if linear else g)
        return amp * g * np.cos(W * t + phase), amp * (dg * np.cos(W * t + phase) - g * W * np.sin(W * t + phase))

    cls = classify(record(grow_exact), dofs=(0,))
    assert not cls.settled and "grows" in cls.unsettled


@settings(max_examples=fuzz_examples(60), deadline=None, derandomize=True, database=None)
@given(amp=st.floats(1e-6, 1e6), offset=st.floats(-10, 10), a3=st.floats(0, 0.5), phase=st.floats(0, 2 * math.pi))
def test_a_bounded_periodic_record_is_settled(amp, offset, a3, phase):
    def periodic(t):
        x = offset * amp + amp * (np.cos(W * t + phase) + a3 * np.cos(3 * W * t))
        v = -amp * W * (np.sin(W * t + phase) + 3 * a3 * np.sin(3 * W * t))
        return x, v

    from contin.timedomain.poincare import amplitude_growth

    cls = classify(record(periodic), dofs=(0,))
    assert cls.label == "period-1" and cls.settled
    ratio, _ = amplitude_growth(record(periodic))
    assert ratio == pytest.approx(1.0, abs=1e-2)
