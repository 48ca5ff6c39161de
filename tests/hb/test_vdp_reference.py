"""The forced van der Pol references of ``vdp_reference`` against quadrature, closed forms and simulation.

x'' - mu (1 - x^2) x' + x = F cos(w t). The averaged equations are checked
against the exact average of the variation-of-parameters equations; the
entrainment boundaries against Adler's small-forcing limit and the closed-form
saddle-node and Hopf conditions; the slow limit cycle and the hard-excitation
amplitude against a direct simulation of the full equation (first-order
averaging: agreement to O(mu) relative).
"""

import math

import numpy as np
import pytest

from conftest import fd_jacobian
from contin.timedomain.spectral_lines import spectral_lines
from vdp_reference import (BoundaryKind, averaged_field, hard_excitation, locked_amplitudes, locking_boundaries,
                           scaled, simulated_lines, slow_jacobian, slow_limit_cycle, variation_of_parameters_rhs)


@pytest.mark.parametrize("mu,F,w", [(0.1, 0.05, 1.0), (0.3, 0.2, 0.9), (0.05, 1.0, 1.3)])
def test_averaged_field_is_the_exact_average_of_variation_of_parameters(mu, F, w):
    # g is a trigonometric polynomial of degree 4 in w t: the trapezoidal rule on 32 points is exact
    n = 32
    t = np.arange(n) * (2 * math.pi / w / n)
    rng = np.random.default_rng(7)
    for a, b in rng.uniform(-2.5, 2.5, size=(6, 2)):
        da, db = variation_of_parameters_rhs(a, b, t, mu, F, w)
        ea, eb = averaged_field(a, b, mu, F, w)
        assert abs(da.mean() - ea) < 1e-13 and abs(db.mean() - eb) < 1e-13


def test_equilibria_and_jacobian():
    mu, F = 0.1, 0.04
    for w in (0.995, 1.0, 1.004, 1.02):
        eqs = locked_amplitudes(mu, F, w)
        assert len(eqs) == (3 if abs(w - 1) < 0.009 else 1)
        for e in eqs:
            assert np.max(np.abs(averaged_field(e.a, e.b, mu, F, w))) < 1e-14
            J = slow_jacobian(e.a, e.b, mu, F, w)
            fd = fd_jacobian(lambda y: np.array(averaged_field(y[0], y[1], mu, F, w)), [e.a, e.b])
            assert np.allclose(J, fd, atol=1e-8)
        # inside the band: a stable node (large amplitude), a saddle and an unstable small response
        assert [e.stable for e in eqs] == ([False, False, True] if len(eqs) == 3 else [False])


def test_locking_band_small_forcing_is_adlers():
    """Gamma -> 0: the saddle-node boundary tends to |w^2 - 1| = F / 2, i.e. w = 1 +- F / 4."""
    mu = 0.1
    for F in (0.002, 0.004, 0.008):
        lb = locking_boundaries(mu, F)
        assert lb.low_kind is lb.high_kind is BoundaryKind.SADDLE_NODE
        for wb, side, gamma in ((lb.low, -1, lb.low_Gamma), (lb.high, 1, lb.high_Gamma)):
            assert abs(wb - (1 + side * F / 4)) < F * F / 16
            # next order of the closed-form fold: Omega = Gamma (1 + Gamma^2 / 8 + O(Gamma^4))
            ratio = abs(wb * wb - 1) / (F / 2)
            assert abs(ratio - 1 - gamma ** 2 / 8) < 0.2 * gamma ** 4


@pytest.mark.parametrize("F,kind", [(0.04, BoundaryKind.SADDLE_NODE), (0.2, BoundaryKind.HOPF)])
def test_locking_boundary_kind(F, kind):
    """Gamma^2 < 4/27: the stable node meets the saddle; Gamma^2 > 8/27: the stable focus loses stability."""
    mu, d = 0.1, 1e-6
    lb = locking_boundaries(mu, F)
    assert lb.low_kind is lb.high_kind is kind
    for wb, out in ((lb.low, -d), (lb.high, d)):
        Omega, Gamma = scaled(mu, F, wb)
        inside, outside = locked_amplitudes(mu, F, wb - out), locked_amplitudes(mu, F, wb + out)
        assert any(e.stable for e in inside) and not any(e.stable for e in outside)
        if kind is BoundaryKind.HOPF:
            assert Gamma ** 2 > 8 / 27
            assert abs(Omega ** 2 - (2 * Gamma ** 2 - 0.25)) < 1e-10
            (e,) = inside
            assert abs(e.amplitude ** 2 - 2) < 1e-3 and abs(e.eigenvalues.imag[0]) > 0.01
        else:
            assert Gamma ** 2 < 4 / 27
            assert len(inside) == 3 and len(outside) == 1
    if kind is BoundaryKind.HOPF:
        # supercritical: a slow limit cycle (a torus) grows as the square root of the distance
        side = [math.hypot(*[ln.amplitude for ln in slow_limit_cycle(mu, F, lb.high + d).lines if ln.order])
                for d in (1e-3, 4e-3)]
        assert side[0] < 0.5 and side[1] / side[0] == pytest.approx(2.0, rel=0.1)


def test_slow_cycle_period_small_forcing():
    """Adler's limit: 2 pi / T_s = (mu / 2) sqrt(Omega^2 - Gamma^2) up to O(Gamma^2) relative."""
    mu = 0.1
    for F, w in ((0.004, 1.01), (0.01, 0.98)):
        c = slow_limit_cycle(mu, F, w)
        Omega, Gamma = scaled(mu, F, w)
        adler = 2 * math.pi / (0.5 * mu * math.sqrt(Omega ** 2 - Gamma ** 2))
        assert abs(c.period / adler - 1) < 0.5 * Gamma ** 2
        assert c.orientation == (1 if w > 1 else -1)
        assert abs(c.free_frequency - 1) < abs(w - 1)  # the free line lies between w and 1


def test_slow_cycle_against_simulation():
    """Soft excitation outside the band, mu = 0.05: the quasi-periodic lines of the full equation."""
    mu, F, w = 0.05, 0.02, 1.05
    c = slow_limit_cycle(mu, F, w)
    periods = int(5 * c.period * w / (2 * math.pi))
    t, x = simulated_lines(mu, F, w, periods, transient=30, samples_per_period=16, initial=(2.0, 0.0))
    lines = spectral_lines(t, x, count=6, floor=1e-3)
    free = min(lines, key=lambda ln: abs(ln.frequency - c.free_frequency))
    slow = w - free.frequency  # the measured 2 pi / T_s
    assert abs(slow - (w - c.free_frequency)) < mu * abs(w - c.free_frequency)
    for pred in c.lines:
        if pred.amplitude < 1e-2:
            continue
        f = w + pred.order * slow
        got = min(lines, key=lambda ln: abs(ln.frequency - f))
        assert abs(got.frequency - f) < 1e-6
        assert abs(got.amplitude - pred.amplitude) < 2 * mu * pred.amplitude, pred


def test_hard_excitation_against_simulation():
    mu, F, w = 0.05, 1.5, 2.0
    h = hard_excitation(mu, F, w)
    assert h.forced_amplitude == pytest.approx(-0.5) and not h.quenched
    periods = int(120 * w / (2 * math.pi))
    t, x = simulated_lines(mu, F, w, periods, transient=int(100 * w / (2 * math.pi)), samples_per_period=16,
                           initial=(h.forced_amplitude + h.free_amplitude, 0.0))
    lines = spectral_lines(t, x, count=2, floor=1e-3)
    forced = min(lines, key=lambda ln: abs(ln.frequency - w))
    free = min(lines, key=lambda ln: abs(ln.frequency - h.free_frequency))
    assert abs(forced.frequency - w) < 1e-6
    assert abs(forced.amplitude - abs(h.forced_amplitude)) < mu * abs(h.forced_amplitude)
    assert abs(free.frequency - h.free_frequency) < mu
    assert abs(free.amplitude - h.free_amplitude) < mu * h.free_amplitude
    assert hard_excitation(mu, 6.0, w).quenched  # A^2 = 4 > 2
