"""Poincare classification of recorded responses, on signals with a known answer."""

import math

import numpy as np
import pytest

from contin.timedomain.poincare import classify, dominant_lines, spectrum, whirl_components
from contin.timedomain.simulation import SimulationResult

W = 2.0
T = 2 * math.pi / W
SPP = 64  # samples per revolution


def record(fn, revolutions=60, start=0.0):
    """A SimulationResult of the planar signal ``fn(t) -> (x, y)`` (two dofs), derivatives by differences."""
    t = start + np.arange(revolutions * SPP) * (T / SPP)
    ts = start + np.arange(revolutions + 1) * T
    eps = 1e-6

    def state(tt):
        x = np.array(fn(tt)).T
        v = (np.array(fn(tt + eps)).T - np.array(fn(tt - eps)).T) / (2 * eps)
        return x, v

    x, v = state(t)
    xs, vs = state(ts)
    section = np.concatenate([np.zeros((int(round(start / T)), 4)), np.concatenate([xs, vs], axis=1)])
    return SimulationResult(t=t, x=x, v=v, section=section, w=W, period=T, steps_per_period=SPP, h=T / SPP,
                            steps=len(section) * SPP, events=0, unresolved_events=0, extra_evaluations=0,
                            wall_time=0.0, compile_time=0.0, params={}, dof_names=("x", "y"),
                            final_state=np.zeros(4), final_mode=np.zeros(0, int))


def harmonic(t):
    return 0.8 * np.cos(W * t), 0.8 * np.sin(W * t) + 0.3


def test_period_one():
    c = classify(record(harmonic))
    assert c.label == "period-1" and c.period == 1 and c.settled
    assert c.spread < 1e-6
    np.testing.assert_allclose(abs(c.whirl["+w"]), 0.8, rtol=1e-10)
    assert abs(c.whirl["-w"]) < 1e-10 and abs(c.whirl["+w/2"]) < 1e-10
    assert c.lines[0][0] == pytest.approx(1.0) and c.lines[0][1] == pytest.approx(0.8, rel=1e-10)


def test_period_two_forward_and_backward_whirl_components():
    # z = 0.8 e^{i w t} + 0.5 e^{i w t/2} + 0.1 e^{-i w t/2}: forward and backward half-order whirl
    def sub(t):
        z = 0.8 * np.exp(1j * W * t) + 0.5 * np.exp(0.5j * W * t + 0.3j) + 0.1 * np.exp(-0.5j * W * t - 1.1j)
        return z.real, z.imag + 0.3

    c = classify(record(sub))
    assert c.label == "period-2" and c.period == 2
    np.testing.assert_allclose(c.whirl["+w/2"], 0.5 * np.exp(0.3j), atol=1e-10)
    np.testing.assert_allclose(c.whirl["-w/2"], 0.1 * np.exp(-1.1j), atol=1e-10)
    np.testing.assert_allclose(c.whirl["+w"], 0.8, atol=1e-10)
    assert c.pattern_ratio == pytest.approx(1.0, abs=1e-6) and c.subharmonic_dominance > 1e3
    freqs = [f for f, _ in c.lines[:3]]
    assert freqs == pytest.approx([1.0, 0.5, -0.5])


def test_period_three():
    def sub3(t):
        return 0.8 * np.cos(W * t) + 0.2 * np.cos(W * t / 3), 0.8 * np.sin(W * t) + 0.2 * np.sin(W * t / 3)

    c = classify(record(sub3))
    assert c.label == "period-3"


def test_decaying_alternation_is_not_period_two():
    # a transient through a multiplier -0.998 per revolution: the section alternates between two points
    # that approach each other slowly, so |P[i+2] - P[i]| is within the tolerance
    mu = 0.998
    rate = -math.log(mu) / T

    def transient(t):
        a = 0.3 * np.exp(-rate * t)
        return 0.8 * np.cos(W * t) + a * np.cos(W * t / 2), 0.8 * np.sin(W * t) + a * np.sin(W * t / 2)

    rec = record(transient, revolutions=80)
    c = classify(rec)
    assert c.mismatch[2] < 1e-3  # passes the section test alone
    assert c.label != "period-2"
    assert "decays" in c.note and c.pattern_ratio < 0.95
    # the same pattern without the decay is period-2
    def settled(t):
        return 0.8 * np.cos(W * t) + 0.3 * np.cos(W * t / 2), 0.8 * np.sin(W * t) + 0.3 * np.sin(W * t / 2)

    assert classify(record(settled, revolutions=80)).label == "period-2"


def test_quasi_periodic_self_excited_whirl_is_not_periodic():
    pf = 0.5 + 1 / (2 * math.pi)  # incommensurate with w

    def qp(t):
        return (0.8 * np.cos(W * t) + 0.3 * np.cos(pf * W * t), 0.8 * np.sin(W * t) + 0.3 * np.sin(pf * W * t))

    c = classify(record(qp, revolutions=100))
    assert c.label == "not periodic" and c.period is None
    f, a = c.lines[1]
    assert abs(f - pf) <= 0.01 and a == pytest.approx(0.3, rel=0.2)  # Hann scalloping off-bin
    assert "strongest non-harmonic line" in c.note


def test_section_period_two_with_foreign_lines_is_rejected_by_the_spectrum():
    # sin^2(w t/2) vanishes with its derivative at every t = m T: the section sees an exact period-2
    # motion, but the spectrum has lines at 0.3 w, 0.7 w, 1.3 w stronger than the w/2 line allows
    def foreign(t):
        s = np.sin(W * t / 2) ** 2 * 0.4 * np.cos(0.3 * W * t)
        return 0.8 * np.cos(W * t) + 0.1 * np.cos(W * t / 2) + s, 0.8 * np.sin(W * t) + 0.1 * np.sin(W * t / 2)

    c = classify(record(foreign, revolutions=100))
    assert c.mismatch[2] < 1e-6
    assert c.label == "not periodic" and "do not dominate" in c.note


def test_converging_period_one_is_flagged_not_settled():
    rate = -math.log(0.97) / T

    def conv(t):
        a = 2e-3 * np.exp(-rate * t)
        return 0.8 * np.cos(W * t) + a * np.cos(0.37 * W * t), 0.8 * np.sin(W * t) + a * np.sin(0.37 * W * t)

    c = classify(record(conv, revolutions=60))
    assert c.label == "period-1" and not c.settled and "converging" in c.note


def test_spectrum_amplitudes_on_bins_and_one_dof():
    t = np.arange(40 * SPP) * (T / SPP)
    x = 0.7 * np.cos(1.5 * W * t + 0.2) + 0.1
    f, a = spectrum(t, x, W)
    lines = dominant_lines(f, a)
    assert lines[0][0] == pytest.approx(1.5) and lines[0][1] == pytest.approx(0.7, rel=1e-12)
    z = whirl_components(t, x, np.zeros_like(x), W)
    assert abs(z["+w"]) < 1e-12
    with pytest.raises(ValueError):
        classify(record(harmonic, revolutions=2))
