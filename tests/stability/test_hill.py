"""Hill's method: exact exponents of linear systems, the selection near -1, Mathieu tongues."""

import numpy as np
import pytest
from conftest import check_mathieu_tongues

from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.models.polynomial import polynomial_model
from contin.engine.newton import solve_at_parameter
from contin.stability import (
    StabilityMonitor,
    StabilityOptions,
    floquet_multipliers,
    hill_spectrum,
    monodromy_rk4,
    multiplier_distance,
    stability_events,
)
from contin.stability.hill import companion_eigen, harmonic_centroids, select_exponents


def linear_oscillator(c=0.1, k=1.0):
    return polynomial_model(["x"], {"c": c, "k": k, "F": 1.0, "w": 1.0}, mass=[[1.0]], damping=[["c"]],
                            stiffness=[["k"]], forcing=[{"dof": "x", "amplitude": "F"}])


@pytest.mark.parametrize("w", [0.7, 2.0 * np.sqrt(1 - 0.01 / 4), 2.02, 3.1])
def test_linear_oscillator_exponents_are_exact(w):
    """x'' + c x' + x: exponents -c/2 +- i sqrt(1 - c^2/4) (mod i w), whatever w.

    ``w = 2 w_d`` puts both multipliers at ``-exp(-c T/2)`` (real, negative):
    there the two candidates of each class have ``Im s = +-w/2``, equally
    small, and selecting by the smallest ``|Im s|`` alone cannot tell
    them apart; the centroid criterion must keep one per class.
    """
    c = 0.1
    hb = HarmonicBalance(linear_oscillator(c), "w", HBOptions(harmonics=6))
    u = hb.linear_solution(w)
    spec = hill_spectrum(hb, u, w)
    T = 2 * np.pi / w
    s_true = np.array([-c / 2 + 1j * np.sqrt(1 - c * c / 4), -c / 2 - 1j * np.sqrt(1 - c * c / 4)])
    assert multiplier_distance(spec.multipliers, np.exp(s_true * T)) < 1e-10
    # the selected exponents are members of the right classes: s_true + i k w
    for s in spec.exponents:
        k = (s - s_true) / (1j * w)
        assert np.min(np.abs(k - np.round(k.real))) < 1e-9
    assert spec.quality == 1.0
    assert np.all(np.abs(spec.centroids[spec.selected]) <= 0.5 + 1e-9)


def test_shift_structure_of_the_centroid():
    """Eigenvector of s + i k Omega = eigenvector of s shifted by -k harmonics: centroid moves by -k."""
    hb = HarmonicBalance(linear_oscillator(0.1), "w", HBOptions(harmonics=6))
    w = 1.3
    D0, D1, D2 = hb.hill_matrices(hb.linear_solution(w), w)
    s, Q = companion_eigen(D0, D1, D2)
    c = harmonic_centroids(Q, 1)
    # linear oscillator: every eigenvector is a single complex harmonic l, and s = s0 - i l w
    s0 = -0.05 + 1j * np.sqrt(1 - 0.0025)
    for sj, cj in zip(s, c):
        for base in (s0, np.conj(s0)):
            l = (base - sj) / (1j * w)
            if abs(l - round(l.real)) < 1e-8:
                assert abs(cj - round(l.real)) < 1e-10
                break
        else:
            raise AssertionError(f"eigenvalue {sj} is not a shift of the exact exponents")


def test_select_exponents_handles_a_degenerate_pair_at_minus_one():
    """Two classes with the same exponent i*Omega/2 (double multiplier -1): both kept, shifts dropped."""
    Om = 1.0
    s = np.array([0.5j, -0.5j, 0.5j, -0.5j, 1.5j, -1.5j])
    c = np.array([-0.5, 0.5, -0.5, 0.5, -1.5, 1.5])
    sel, quality = select_exponents(s, c, Om, 2)
    assert len(sel) == 2
    mult = np.exp(s[sel] * 2 * np.pi / Om)
    np.testing.assert_allclose(mult, [-1, -1], atol=1e-12)
    assert quality == 1.0


@pytest.mark.parametrize("eps, rmax, hi", [(0.2, 2, 1.3), (0.5, 3, 2.45)])
def test_undamped_mathieu_tongues_with_hill(eps, rmax, hi):
    """Stability changes of x = 0 along delta lie on the Mathieu curves to 1e-6.

    The undamped multipliers sit on the unit circle in the stable regions; the
    margin ``tolerance = 1e-6`` on ``|mu|`` moves a boundary only by
    O(tolerance^2) because ``|mu| - 1`` grows like the square root of the
    distance to the boundary (the multipliers are double at a boundary).
    """
    hb, _, found = check_mathieu_tongues(eps, rmax, hi, 8, StabilityOptions(method="hill"))
    for p in found:
        assert p.data["eigenvector"].shape == (hb.size,)


def test_critical_eigenvector_solves_hills_problem():
    """The stored eigenvector and exponent satisfy (D0 + s D1 + s^2 D2) q = 0 and the 4pi-periodicity at a PD."""
    eps = 0.3
    model = build_model("mathieu", {"c": 0.05, "g": 0.0, "eps": eps}, effects=["parametric", "damping"])
    hb = HarmonicBalance(model, "delta", HBOptions(harmonics=8))
    mon = StabilityMonitor(hb, StabilityOptions(method="hill"))
    br = continuation(hb, np.zeros(hb.size), 0.0, (0.0, 0.5), ContinuationOptions(ds=0.01, ds_max=0.02),
                      parameter_name="delta", events=stability_events(mon), monitors=[mon])
    pds = br.points_of_kind("pd")
    assert len(pds) == 2
    for p in pds:
        q, s = p.data["eigenvector"], p.data["exponent"]
        D0, D1, D2 = hb.hill_matrices(p.unknowns, p.parameter)
        res = (D0 + s * D1 + s * s * D2) @ q
        assert np.linalg.norm(res) < 1e-8 * np.linalg.norm(D0, 2)
        # multiplier -1: Im s = +-Omega/2 (mod Omega), Re s ~ 0
        assert abs(abs(np.imag(s)) % 1.0 - 0.5) < 1e-6 and abs(np.real(s)) < 1e-6


def test_duffing_hill_quality_and_ambiguity():
    """Selection is clear with enough harmonics; with H = 1 on a strongly nonlinear
    orbit it is not, and method 'both' then confirms with the monodromy."""
    model = build_model("duffing", {"F": 0.5})
    hb9 = HarmonicBalance(model, "w", HBOptions(harmonics=9))
    hb1 = HarmonicBalance(model, "w", HBOptions(harmonics=1))
    br = continuation(hb9, hb9.linear_solution(0.5), 0.5, (0.5, 2.0), ContinuationOptions())
    qualities = [hill_spectrum(hb9, *br.point(i)).quality for i in range(0, len(br), 3)]
    assert min(qualities) > 0.9
    u, w = br.point(len(br) - 1)  # large amplitude, upper branch
    u1 = solve_at_parameter(hb1, u[:3], w).x
    opts = StabilityOptions(method="both", ambiguity_threshold=0.9)
    q1 = hill_spectrum(hb1, u1, w).quality
    res = floquet_multipliers(hb1, u1, w, opts, previous=(0, 0, 0))
    assert res.ambiguous == (q1 < 0.9)
    if res.ambiguous:
        assert res.confirmed and res.monodromy_multipliers is not None


def test_hill_against_monodromy_on_the_mathieu_equation():
    """Hill (H = 8) and RK4 (S = 1024) agree to 1e-8 inside and outside the tongues.

    Hill's truncation error decays like q^(2H)/(H!)^2 here (Mathieu coefficients
    decay factorially) and RK4's like (w_max h)^4 T/120 ~ 1e-10.
    """
    model = build_model("mathieu", {"c": 0.1, "g": 0.0, "eps": 0.5}, effects=["parametric", "damping"])
    hb = HarmonicBalance(model, "delta", HBOptions(harmonics=8))
    u = np.zeros(hb.size)
    for delta in (-0.2, 0.1, 0.25, 0.6, 1.0, 1.5, 2.26):
        h = hill_spectrum(hb, u, delta).multipliers
        m = monodromy_rk4(hb, u, delta, 1024).multipliers
        assert multiplier_distance(h, m) < 1e-8, delta
