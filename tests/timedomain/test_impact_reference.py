"""The event-driven scipy reference (tests/timedomain/impact_reference.py) against closed forms.

The reference is the truth the grazing scenes are checked against
(tests/analyses/test_grazing_scenes.py), so it is checked here on its own,
without contin: where no stop is touched the orbit is that of a forced linear
(or, for the chain without its cubic spring, linear two-dof) oscillator; a
stop always in contact is another linear oscillator; the grazing frequency
of the one-dof oscillator is where the linear amplitude equals the gap; the
monodromy with saltation equals central differences of the event-driven flow.
"""

import math

import numpy as np
import pytest
from scipy.linalg import expm

from tests.timedomain import impact_reference as ref

ZETA, KS, G, F = 0.05, 500.0, 1.0, 0.3


def linear_matrix(M, C, K):
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    return np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])


@pytest.mark.parametrize("w", [0.5, 0.7, 0.84])
def test_orbit_below_the_stop_is_the_forced_linear_oscillator(w):
    """x'' + 2 zeta x' + x = F cos(w t): x = Re(F e^{i w t} / (1 - w^2 + 2 i zeta w)), to 1e-10."""
    system = ref.impact_oscillator(ZETA, KS, G, F)
    X = F / (1.0 - w * w + 2j * ZETA * w)
    exact = np.array([X.real, (1j * w * X).real])
    orbit = ref.periodic_orbit(system, w, exact + [0.05, -0.05])
    np.testing.assert_allclose(orbit.z, exact, rtol=0, atol=1e-10)
    assert ref.switches(system, orbit) == 0
    # its monodromy is the matrix exponential of the linear system over one period
    T = 2.0 * math.pi / w
    A = linear_matrix(np.eye(1), 2 * ZETA * np.eye(1), np.eye(1))
    np.testing.assert_allclose(orbit.monodromy, expm(A * T), rtol=0, atol=1e-10)
    # extremes and first harmonic of the dense output
    top, bottom = ref.extremes(system, orbit, 0)
    assert top == pytest.approx(abs(X), abs=1e-10) and bottom == pytest.approx(-abs(X), abs=1e-10)
    a1, b1 = ref.fourier(system, orbit, 0, 1)
    assert a1 == pytest.approx(X.real, abs=1e-10) and b1 == pytest.approx(-X.imag, abs=1e-10)
    assert ref.fourier(system, orbit, 0, 0)[0] == pytest.approx(0.0, abs=1e-10)


def test_a_stop_always_in_contact_is_another_linear_oscillator():
    """With the gap far below the orbit the law is x'' + 2 zeta x' + (1 + ks) x = F cos(w t) + ks g."""
    ks, g, w = 3.0, -10.0, 1.3
    system = ref.impact_oscillator(ZETA, ks, g, F)
    X = F / (1.0 + ks - w * w + 2j * ZETA * w)
    mean = ks * g / (1.0 + ks)
    exact = np.array([mean + X.real, (1j * w * X).real])
    orbit = ref.periodic_orbit(system, w, [mean, 0.0])
    np.testing.assert_allclose(orbit.z, exact, rtol=0, atol=1e-10)
    assert ref.fourier(system, orbit, 0, 0)[0] == pytest.approx(mean, abs=1e-10)


def test_chain_without_cubic_spring_below_its_stop_is_the_impedance_solution():
    """(K - w^2 M + i w C) X = F e_1: both masses' orbits, to 1e-10 (x2 stays below the gap)."""
    system = ref.chain_stop(a=0.0, F=0.05)
    w = 1.2
    exact = ref.linear_orbit_state(system, w)
    Z = system.K - w * w * system.M + 1j * w * system.C
    X = np.linalg.solve(Z, [0.05, 0.0])
    np.testing.assert_allclose(exact, np.concatenate([X.real, (1j * w * X).real]), atol=1e-14)
    orbit = ref.periodic_orbit(system, w, np.zeros(4))
    np.testing.assert_allclose(orbit.z, exact, rtol=0, atol=1e-10)
    assert ref.extremes(system, orbit, 1)[0] < 0.3
    np.testing.assert_allclose(orbit.monodromy, expm(linear_matrix(system.M, system.C, system.K) * 2 * math.pi / w),
                               rtol=0, atol=1e-10)


def test_grazing_frequency_is_where_the_linear_amplitude_equals_the_gap():
    """Brent on the orbit's max x - g against the root of (1 - w^2)^2 + (2 zeta w)^2 = (F / g)^2."""
    system = ref.impact_oscillator(ZETA, KS, G, F)
    w_lo, _ = ref.impact_grazing_closed_form(ZETA, G, F)
    assert F / abs(1 - w_lo ** 2 + 2j * ZETA * w_lo) == pytest.approx(G, rel=1e-14)
    w_g = ref.grazing_frequency(system, 0.8438, 0.844, ref.linear_orbit_state(system, 0.8438))
    assert w_g == pytest.approx(w_lo, abs=1e-10)
    # no switch just below it, a contact arc (two switches) just above it
    below = ref.periodic_orbit(system, w_g - 1e-4, ref.linear_orbit_state(system, w_g - 1e-4))
    above = ref.periodic_orbit(system, w_g + 1e-3, below.z)
    assert ref.switches(system, below) == 0 and ref.switches(system, above) == 2


def test_monodromy_with_saltation_equals_differences_of_the_event_driven_flow():
    """An orbit bouncing on the stop: variational equations + saltation against central differences (1e-6)."""
    system = ref.impact_oscillator(ZETA, KS, G, F)
    orbit = ref.periodic_orbit(system, 0.9, [0.92, 0.40])
    assert ref.switches(system, orbit) == 2
    T = 2.0 * math.pi / orbit.w
    h = 1e-6
    cols = [(ref.flow(system, orbit.z + e, orbit.w, 0.0, T, jacobian=False)[0]
             - ref.flow(system, orbit.z - e, orbit.w, 0.0, T, jacobian=False)[0]) / (2 * h) for e in np.eye(2) * h]
    np.testing.assert_allclose(orbit.monodromy, np.column_stack(cols), rtol=0,
                               atol=1e-6 * np.abs(orbit.monodromy).max())
    # Liouville: det = exp(trace A T) whatever the switches (the saltation matrix of a soft stop is I)
    assert np.linalg.det(orbit.monodromy) == pytest.approx(math.exp(-2 * ZETA * T), rel=1e-9)
