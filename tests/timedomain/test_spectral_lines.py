"""Spectral lines of sampled signals, against signals with a closed-form answer."""

import math

import numpy as np
import pytest

from contin.timedomain.spectral_lines import Line, line_amplitude, refine_line, spectral_lines


def _wrap(angle):
    return (angle + math.pi) % (2 * math.pi) - math.pi


def _match(lines, frequency):
    return min(lines, key=lambda line: abs(line.frequency - frequency))


def _cosines(t, freqs, amps, phases, mean=0.0):
    return mean + sum(a * np.cos(f * t + p) for f, a, p in zip(freqs, amps, phases))


# four incommensurate lines, 1 to 1e-3; 0.93 and 0.9587 are six bins apart
FREQS = np.array([1.85, 0.93, math.sqrt(2), 0.9587])
AMPS = np.array([1.0, 0.1, 1e-2, 1e-3])
PHASES = np.random.default_rng(7).uniform(-math.pi, math.pi, 4)


@pytest.fixture(scope="module")
def four_lines():
    record = 200 * 2 * math.pi / FREQS.min()
    dt = 2 * math.pi / FREQS.max() / 20
    t = np.arange(0.0, record, dt)
    return t, _cosines(t, FREQS, AMPS, PHASES, mean=0.3)


def test_four_real_lines_to_rounding(four_lines):
    t, x = four_lines
    lines = spectral_lines(t, x)
    assert len(lines) == 4  # the residual below the weakest line is rounding: the floor stops the search
    assert [line.amplitude for line in lines] == sorted((line.amplitude for line in lines), reverse=True)
    for f, a, p in zip(FREQS, AMPS, PHASES):
        line = _match(lines, f)
        assert isinstance(line, Line)
        assert line.frequency == pytest.approx(f, rel=1e-7)
        assert line.amplitude == pytest.approx(a, rel=1e-6)
        assert abs(_wrap(line.phase - p)) < 1e-5


def test_mean_is_a_line_when_not_excluded(four_lines):
    t, x = four_lines
    lines = spectral_lines(t, x, count=2, exclude_zero=False)
    assert [line.frequency for line in lines] == [pytest.approx(1.85, rel=1e-7), 0.0]
    assert lines[1].amplitude == pytest.approx(0.3, rel=1e-9) and lines[1].phase == 0.0
    negative = spectral_lines(t, x - 0.6, count=2, exclude_zero=False)[1]
    assert negative.amplitude == pytest.approx(0.3, rel=1e-9) and negative.phase == pytest.approx(math.pi)


def test_count_and_floor(four_lines):
    t, x = four_lines
    assert [line.amplitude for line in spectral_lines(t, x, count=2)] == pytest.approx(AMPS[:2], rel=1e-6)
    assert len(spectral_lines(t, x, floor=5e-3)) == 3


def test_complex_whirl_forward_and_backward():
    """``z = x + i y``: a forward whirl at +1.3 and a backward one at -0.71, with a static offset."""
    t = np.arange(6000) * 0.21 + 3.0
    z = 0.8 * np.exp(1j * (1.3 * t + 0.2)) + 0.05 * np.exp(-1j * (0.71 * t - 1.0)) + (0.1 - 0.2j)
    lines = spectral_lines(t, z)
    assert len(lines) == 2
    forward, backward = lines
    assert forward.frequency == pytest.approx(1.3, rel=1e-9)
    assert forward.amplitude == pytest.approx(0.8, rel=1e-9)
    assert forward.phase == pytest.approx(0.2, abs=1e-8)
    assert backward.frequency == pytest.approx(-0.71, rel=1e-9)
    assert backward.amplitude == pytest.approx(0.05, rel=1e-9)
    assert backward.phase == pytest.approx(1.0, abs=1e-8)
    mean = _match(spectral_lines(t, z, exclude_zero=False), 0.0)
    assert mean.frequency == 0.0 and mean.amplitude * np.exp(1j * mean.phase) == pytest.approx(0.1 - 0.2j, abs=1e-10)
    # a known frequency, and a search from one bin off
    assert line_amplitude(t, z, -0.71).amplitude == pytest.approx(0.05, rel=1e-5)
    assert refine_line(t, z, -0.71 + 2 * math.pi / (t[-1] - t[0])).frequency == pytest.approx(-0.71, rel=1e-9)


def test_record_of_a_fractional_number_of_periods():
    """37.3 periods from t0 = 11.1: the FFT bin is off by 0.3 bin, the refined line is exact."""
    f, a, p = 0.77, 2.5, -1.1
    t = 11.1 + np.arange(0.0, 37.3 * 2 * math.pi / f, 0.05)
    x = _cosines(t, [f], [a], [p], mean=-0.4)
    spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(t.size)))
    coarse = np.argmax(spec) * 2 * math.pi / (t.size * 0.05)
    assert abs(coarse - f) > 0.2 * 2 * math.pi / (t[-1] - t[0])
    for line in (spectral_lines(t, x)[0], refine_line(t, x, coarse), line_amplitude(t, x, f),
                 line_amplitude(t, x, -f)):  # a real signal's line is at |f|
        assert line.frequency == pytest.approx(f, rel=1e-10)
        assert line.amplitude == pytest.approx(a, rel=1e-9)
        assert abs(_wrap(line.phase - p)) < 1e-8
    # the mean alone: the line's leakage into it is not fitted away
    assert line_amplitude(t, x, 0.0) == Line(0.0, pytest.approx(0.4, rel=1e-6), math.pi)


def test_line_in_noise_within_its_statistical_error():
    """White noise ``sigma``: errors within five standard deviations of the windowed estimator.

    For the window ``h`` and times ``tau`` from the middle of the record
    (here ``t = 0``), a real line ``A cos(f t + phase)`` has
    ``std A = sigma sqrt(2 sum h^2) / sum h``, ``std phase = std A / A`` and
    ``std f = sigma sqrt(sum h^2 tau^2 / 2) / (A / 2 sum h tau^2)``.
    """
    f, a, p, sigma = 1.2345, 1.0, 0.3, 1e-2
    n = 4001
    t = (np.arange(n) - (n - 1) / 2) * 0.1
    x = _cosines(t, [f], [a], [p]) + sigma * np.random.default_rng(11).standard_normal(n)
    h = np.sin(np.pi * np.arange(n) / (n - 1)) ** 4  # the module's window, squared Hann
    std_a = sigma * math.sqrt(2 * np.sum(h ** 2)) / h.sum()
    std_f = sigma * math.sqrt(np.sum(h ** 2 * t ** 2) / 2) / (a / 2 * np.sum(h * t ** 2))
    for line in (refine_line(t, x, 1.23), spectral_lines(t, x, floor=1e-2)[0]):
        assert abs(line.frequency - f) < 5 * std_f
        assert abs(line.amplitude - a) < 5 * std_a
        assert abs(_wrap(line.phase - p)) < 5 * std_a / a
    assert len(spectral_lines(t, x, floor=1e-2)) == 1  # noise peaks stay below one percent


def _pair(bins, weak=0.1):
    """Lines 1 and ``weak`` at 1 and ``1 + df``, recorded over ``bins`` beat periods ``2 pi / df``."""
    df = 0.01 * math.sqrt(2)
    t = np.arange(0.0, bins * 2 * math.pi / df, 0.25)
    return t, _cosines(t, [1.0, 1.0 + df], [1.0, weak], [0.4, -2.0]), 1.0 + df


def test_close_lines_need_the_joint_fit():
    """Two lines a few bins apart: the record length for 1e-3 on the weaker line.

    Measured on ``_pair`` (weaker line 1/10 or 1/100 of the other, worst
    over eight phase pairs and over separations in steps of a quarter bin):
    estimated alone by :func:`refine_line`, which maximises the windowed
    transform without subtracting the neighbour, the weaker line's amplitude
    is within 1e-3 from a record of 6.5 beat periods ``2 pi / df`` on (1/10
    pair; 10.5 for the 1/100 pair). Lines 5 bins apart, i.e. a record of 5
    beat periods, are off by up to 3e-3 (1/10) and 3e-2 (1/100): the window's
    transform vanishes at whole bins, so the error swings between near zero
    at 5.0 bins and its envelope at 5.5. :func:`spectral_lines` fits both
    lines together and is exact to rounding (about 1e-12) from 3.5 bins on,
    so 5 bins (a record of five beat periods) are enough for 1e-3 and far
    beyond.
    """
    t, x, f2 = _pair(5.5)
    joint = _match(spectral_lines(t, x, count=2), f2)
    alone = refine_line(t, x, f2, width=0.005)
    assert joint.amplitude == pytest.approx(0.1, rel=1e-9)
    assert joint.frequency == pytest.approx(f2, rel=1e-12)
    assert abs(alone.amplitude - 0.1) / 0.1 > 1e-3  # the neighbour's leakage
    t, x, f2 = _pair(10.5)
    assert refine_line(t, x, f2, width=0.005).amplitude == pytest.approx(0.1, rel=1e-3)


def test_refine_line_takes_the_nearest_peak():
    t = np.arange(3000) * 0.3
    bin_ = 2 * math.pi / (t.size * 0.3)
    x = _cosines(t, [1.0, 1.0 + 10 * bin_], [1.0, 0.5], [0.0, 1.0])
    assert refine_line(t, x, 1.0 + 9 * bin_, width=3 * bin_).amplitude == pytest.approx(0.5, rel=1e-5)
    assert refine_line(t, x, 1.0 + 2 * bin_, width=3 * bin_).frequency == pytest.approx(1.0, rel=1e-6)
    # a larger min_separation merges the pair into one line
    assert len(spectral_lines(t, x, min_separation=12 * bin_)) == 1


T16 = np.arange(64) * 0.1
X16 = np.cos(T16)


@pytest.mark.parametrize("call,match", [
    (lambda: spectral_lines(T16, X16[:-1]), "same length"),
    (lambda: spectral_lines(T16.reshape(8, 8), X16.reshape(8, 8)), "1-D"),
    (lambda: spectral_lines(T16[:10], X16[:10]), "at least 16 samples"),
    (lambda: spectral_lines(T16 ** 1.01, X16), "uniformly sampled"),
    (lambda: spectral_lines(T16[::-1], X16), "increase"),
    (lambda: spectral_lines(T16, np.where(T16 > 3, np.nan, X16)), "finite"),
    (lambda: spectral_lines(np.where(T16 > 3, np.inf, T16), X16), "finite"),
    (lambda: spectral_lines(T16, X16 > 0), "numeric"),
    (lambda: spectral_lines(T16, X16, count=0), "count"),
    (lambda: spectral_lines(T16, X16, floor=-1.0), "floor"),
    (lambda: spectral_lines(T16, X16, min_separation=0.0), "min_separation"),
    (lambda: refine_line(T16, X16, 1.0, width=-1.0), "width"),
    (lambda: refine_line(T16, X16, 40.0), "Nyquist"),
    (lambda: line_amplitude(T16, X16, math.nan), "finite"),
    (lambda: refine_line(np.arange(4000) * 0.1, np.cos(np.arange(4000) * 0.1), 1.004, width=0.001),
     "no spectral line"),
])
def test_bad_input_is_refused(call, match):
    with pytest.raises(ValueError, match=match):
        call()
