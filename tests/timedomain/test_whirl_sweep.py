"""Whirl components of the disc along a speed sweep: the line classification and the rotor paper's verdicts."""

import math
from fractions import Fraction

import numpy as np
import pytest

from contin.model.catalog import build_model
from contin.timedomain.whirl_sweep import (CSV_COLUMNS, Component, Verdict, WhirlOptions, classify_whirl,
                                           component_sweep)

#: radius of the +w/2 forward whirl of the disc on the stable 1/2-subharmonic branch at w = 2.16, f0 = 0.5:
#: harmonic balance, nu = 2, H = 80 (the same to 1e-14 with H = 120), from
#: contin.bifurcation.start.simulation_start (docs/tutorials/rotor.md: radius 0.51)
HB_HALF_RADIUS_216 = 0.5089973


def _record(w, lines, revolutions=200, samples=32, mean=0.3 + 0.1j):
    """``z = mean + sum r exp(i f t)`` over whole revolutions; ``lines``: (frequency, radius) pairs."""
    t = np.arange(revolutions * samples) * (2.0 * math.pi / w) / samples
    z = np.full(t.size, mean, dtype=complex)
    for k, (f, r) in enumerate(lines):
        z += r * np.exp(1j * (f * t + 0.7 * k))
    return t, z


def _kinds(state):
    return {c: [ln.frequency for ln, k in state.lines if k is c] for c in Component}


def test_classification_of_synthetic_whirls():
    w = 1.9
    pf = (math.sqrt(2.0) - 0.85) * w  # not a rational multiple of w
    # quasi-periodic: forced whirl, self-excited forward whirl, the combination backward at pf - w and its
    # forward mirror w - pf (an "other" line); the mean (the static deflection) is not a line
    s = classify_whirl(*_record(w, [(w, 0.78), (pf, 0.36), (pf - w, 0.06), (w - pf, 0.017)]), w)
    assert s.verdict is Verdict.QUASI_PERIODIC and s.has_pf
    assert s.pf == pytest.approx(pf, rel=1e-9)
    assert (s.forced, s.self_excited, s.combination, s.other) == pytest.approx((0.78, 0.36, 0.06, 0.017), rel=1e-6)
    assert s.other_frequency == pytest.approx(w - pf, rel=1e-9) and s.subharmonic == 0.0
    # entrained: +w/2 forward and a weak backward -w/2 (other), all at multiples of w/2
    s = classify_whirl(*_record(w, [(w, 0.72), (w / 2, 0.51), (-w / 2, 0.024)]), w)
    assert s.verdict is Verdict.ENTRAINED and not s.has_pf and s.pf == 0.0
    assert (s.forced, s.subharmonic, s.self_excited, s.combination) == pytest.approx((0.72, 0.51, 0.0, 0.0), rel=1e-6)
    assert _kinds(s)[Component.OTHER] == [pytest.approx(-w / 2)]
    # harmonic: lines at multiples of w only; a line below 1 % of the strongest is not present
    s = classify_whirl(*_record(w, [(w, 0.8), (-w, 0.05), (2 * w, 0.02), (pf, 0.004)]), w)
    assert s.verdict is Verdict.HARMONIC and not s.has_pf and s.forced == pytest.approx(0.8, rel=1e-6)
    assert len(s.lines) == 3
    # locked at w/3 (not a self-excited whirl), and a backward self-excited whirl: other
    for extra in ((w / 3, 0.3), (-0.37 * w, 0.3)):
        s = classify_whirl(*_record(w, [(w, 0.8), extra]), w)
        assert s.verdict is Verdict.OTHER and not s.has_pf
        assert _kinds(s)[Component.OTHER] == [pytest.approx(extra[0])]
    # the tolerance of "at w/2" is a fraction of a bin: a line 1/1000 of a bin off w/2 is at w/2, 1/10 is not
    revs = 200
    for off, verdict in ((1e-3, Verdict.ENTRAINED), (0.1, Verdict.QUASI_PERIODIC)):
        f = w / 2 + off * w / revs
        s = classify_whirl(*_record(w, [(w, 0.72), (f, 0.51)], revolutions=revs), w)
        assert s.verdict is verdict, off


def test_options_are_checked():
    with pytest.raises(ValueError):
        WhirlOptions(presence=0.0)
    with pytest.raises(ValueError):
        WhirlOptions(dofs=(0,))
    with pytest.raises(ValueError):
        classify_whirl(np.arange(32.0), np.zeros(31, complex), 1.0)


@pytest.fixture(scope="module")
def rotor():
    return build_model("bearing_rotor", {"f0": 0.5})


@pytest.mark.slow  # 8 s: a rotor run to its entrained steady state (the verdict logic is tested below cheaply)
def test_entrained_into_the_half_order_forward_whirl(rotor):
    """f0 = 0.5, from rest at w = 2.16 and on to 2.18 (the stable subharmonic branch, 2.1498..2.1950):
    entrained, the +w/2 radius that of the harmonic balance; the sweep continues the entrained state."""
    sw = component_sweep(rotor, {"f0": 0.5}, [2.16, 2.18], transient_periods=800, record_periods=40,
                         steps_per_period=1024)
    assert list(sw.verdict) == [Verdict.ENTRAINED.value] * 2
    assert abs(sw.subharmonic[0] - HB_HALF_RADIUS_216) < 1e-3  # measured 8e-5 (RK4, 1024 steps, 800 revolutions)
    assert not sw.has_pf.any() and np.all(sw.pf == 0.0) and np.all(sw.combination == 0.0)
    assert np.all(sw.forced > 0.6) and sw.subharmonic[1] > 0.3
    assert list(sw.speeds_with("entrained (w/2)")) == [2.16, 2.18]
    rows = sw.to_rows()
    assert [tuple(r) for r in rows] == [CSV_COLUMNS] * 2
    assert all(r["pf"] is None and r["pf_over_w"] is None and r["has_pf"] is False for r in rows)
    assert sw.final_state.shape == (8,) and sw.record_periods == 40


def test_self_excited_forward_whirl_where_nothing_periodic_is_stable(rotor):
    """f0 = 0.5, w = 1.9: the harmonic solution is unstable (Neimark-Sacker points at 1.8508 and 1.9785)
    and there is no subharmonic: a self-excited forward whirl p_f, not locked to w, with its combination."""
    sw = component_sweep(rotor, {"f0": 0.5}, [1.9], transient_periods=300, record_periods=100,
                         steps_per_period=1024)
    assert sw.verdict[0] == Verdict.QUASI_PERIODIC.value and sw.has_pf[0]
    ratio = sw.pf[0] / 1.9
    assert 0.5 < ratio < 0.65  # forward, near p_f ~ 1.07
    near = Fraction(ratio).limit_denominator(8)
    assert abs(ratio - float(near)) > 1e-3, near  # not a rational multiple j/q of w, q <= 8
    assert sw.self_excited[0] > 0.1 and sw.combination[0] > 0.02 and sw.subharmonic[0] == 0.0
    row = sw.to_rows()[0]
    assert row["verdict"] == "quasi-periodic" and row["pf_over_w"] == pytest.approx(ratio)
