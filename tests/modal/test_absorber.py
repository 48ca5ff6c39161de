"""Den Hartog's absorber design against the closed forms of seeds 000 and 002.

The responses used as the reference here are solved from the impedance matrix of the
two-mass system (seed 000, sec. 7.3; seed 002, sec. 6.3), not from the dimensionless
formula the design module uses.
"""

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from contin.modal.absorber import (amplification, fixed_point_damping, fixed_points, optimal_damping,
                                   optimal_damping_absorber, optimal_tuning, peaks, response, true_peak,
                                   undamped_resonances)
from contin.modal.absorber_design import AbsorberProblem, design_absorber
from contin.modal.modes import chain_matrices, frf

BETAS = [0.01, 0.05, 0.1, 0.25, 1.0]


def X1_over_dst(m1, k1, m2, k2, c, w):
    """|X1|/delta_st from Z(w) of the two-mass system (force F = k1 on the main mass, so delta_st = 1)."""
    M, C, K = chain_matrices([m1, m2], [k1, k2, 0.0], [0.0, c, 0.0])
    return np.abs(frf(M, C, K, np.atleast_1d(w), [k1, 0.0])[:, 0])


@pytest.mark.parametrize("beta", BETAS)
def test_optimal_tuning_damping_and_fixed_point_height_are_den_hartogs(beta):
    m1, k1 = 3.0, 700.0
    d = design_absorber(m1, k1, beta * m1)
    assert d.mu == pytest.approx(1 / (1 + beta), rel=1e-15)
    assert d.k2 == pytest.approx(k1 * beta / (1 + beta) ** 2, rel=1e-14)
    assert d.zeta == pytest.approx(math.sqrt(3 * beta / (8 * (1 + beta) ** 3)), rel=1e-14)
    # the two conventions of seed 000: zeta = c/(2 m2 p), zeta_a = c/(2 sqrt(m2 k2)) = zeta/mu
    p = math.sqrt(k1 / m1)
    assert d.c / (2 * d.m2 * p) == pytest.approx(d.zeta, rel=1e-14)
    assert d.c / (2 * math.sqrt(d.m2 * d.k2)) == pytest.approx(d.zeta_a, rel=1e-14)
    assert d.zeta_a == pytest.approx(math.sqrt(3 * beta / (8 * (1 + beta))), rel=1e-14)
    assert optimal_damping(beta) == d.zeta and optimal_damping_absorber(beta) == pytest.approx(d.zeta_a, rel=1e-14)
    h = math.sqrt((2 + beta) / beta)
    assert d.fixed_point_height == pytest.approx(h, rel=1e-15)
    assert d.P.height == pytest.approx(h, rel=1e-12) and d.Q.height == pytest.approx(h, rel=1e-12)
    # Omega_{P,Q}^2 = (1 -+ sqrt(beta/(2+beta)))/(1+beta) for the optimal tuning
    s = math.sqrt(beta / (2 + beta))
    assert d.P.Omega**2 == pytest.approx((1 - s) / (1 + beta), rel=1e-12)
    assert d.Q.Omega**2 == pytest.approx((1 + s) / (1 + beta), rel=1e-12)
    # and the impedance-matrix response of the dimensional design passes through them
    for f in (d.P, d.Q):
        assert X1_over_dst(m1, k1, d.m2, d.k2, d.c, f.w)[0] == pytest.approx(h, rel=1e-10)


def test_seed000_exercise():
    """m1 = 100 kg, k1 = 5e5 N/m, m2 = 10 kg: k2 = k1 beta/(1+beta)^2, c = 2 m2 p zeta_opt."""
    d = design_absorber(100.0, 5e5, 10.0)
    assert d.k2 == pytest.approx(5e5 * 0.1 / 1.1**2, rel=1e-14) and abs(d.k2 - 41322.31) < 0.01
    assert d.c == pytest.approx(2 * 10 * math.sqrt(5e3) * math.sqrt(0.3 / (8 * 1.1**3)), rel=1e-14)
    assert abs(d.c - 237.379) < 1e-3
    assert d.fixed_point_height == pytest.approx(math.sqrt(21), rel=1e-15)


@pytest.mark.parametrize("beta, mu", [(0.05, 1.0), (0.1, 1 / 1.1), (0.2, 0.8), (1.0, 1.3)])
def test_fixed_points_are_independent_of_the_damping(beta, mu):
    m1, k1 = 100.0, 5e5
    m2 = beta * m1
    p = math.sqrt(k1 / m1)
    k2 = m2 * (mu * p) ** 2
    (OP, OQ), (hP, hQ) = fixed_points(beta, mu)
    # the quartic of seed 000: (2 + beta) O^4 - 2 {1 + mu^2 (1 + beta)} O^2 + 2 mu^2 = 0
    for O in (OP, OQ):
        assert abs((2 + beta) * O**4 - 2 * (1 + mu**2 * (1 + beta)) * O**2 + 2 * mu**2) < 1e-13
    for c in (0.0, 1.0, 37.0, 200.0, 1e3, 1e5):
        X = X1_over_dst(m1, k1, m2, k2, c, [OP * p, OQ * p])
        np.testing.assert_allclose(X, [hP, hQ], rtol=1e-10)
    # the rigid-joint limit passes there too: 1/|1 - (1 + beta) Omega^2|
    np.testing.assert_allclose(amplification(np.array([OP, OQ]), beta, mu, np.inf), [hP, hQ], rtol=1e-12)


def test_undamped_absorber_of_seed002():
    """mu = m2/m1 = 1/20, alpha = 1: resonances near lambda = 0.895 and 1.12, X1 = 0 at w = w_a,
    rigid-joint resonance at 1/sqrt(1 + mu) = 0.976 (seed 002, sec. 6.3.3; its mu is our beta)."""
    beta, mu = 1 / 20, 1.0
    l1, l2 = undamped_resonances(beta, mu)
    assert abs(l1 - 0.895) < 1e-3 and abs(l2 - 1.12) < 2.5e-3
    for l in (l1, l2):  # the frequency equation (1 - l^2)(alpha^2 - l^2) - mu alpha^2 l^2 = 0
        assert abs((1 - l**2) * (mu**2 - l**2) - beta * mu**2 * l**2) < 1e-14
    assert abs(1 / math.sqrt(1 + beta) - 0.976) < 1e-3
    m1, k1 = 20.0, 8e3
    m2, k2 = beta * m1, beta * m1 * (k1 / m1)  # w_a = w_n
    M, C, K = chain_matrices([m1, m2], [k1, k2, 0.0])
    wa = math.sqrt(k2 / m2)
    X = frf(M, C, K, [wa], [1.0, 0.0])[0]
    assert abs(X[0]) <= 1e-15 * abs(X[1])  # the main mass stands still exactly at w = w_a
    assert X[1].real == pytest.approx(-1.0 / k2, rel=1e-12)  # X2 = -F1/k2: the absorber spring balances the force
    d = design_absorber(m1, k1, m2)
    assert d.anti_resonance == pytest.approx(math.sqrt(d.k2 / m2), rel=1e-15)
    r1, r2 = d.resonances
    Mn, _, Kn = chain_matrices([m1, m2], [k1, d.k2, 0.0])
    from contin.modal.modes import natural_modes

    np.testing.assert_allclose([r1, r2], natural_modes(Mn, Kn).omega, rtol=1e-12)


@pytest.mark.parametrize("beta", BETAS)
def test_true_peak_lies_slightly_above_the_fixed_points(beta):
    m1, k1 = 1.0, 1.0
    d = design_absorber(m1, k1, beta * m1)
    tp = d.true_peak
    h = d.fixed_point_height
    assert h < tp.amplification < (1.0 + 0.02 * beta) * h  # 0.17 % for beta = 0.1, 1.3 % for beta = 1
    # an independent search on the impedance response: dense grid, then a bounded refinement per maximum
    w = np.linspace(0.2, 2.0, 36001)
    y = X1_over_dst(m1, k1, d.m2, d.k2, d.c, w)
    found = []
    for i in np.flatnonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:])) + 1:
        r = minimize_scalar(lambda x: -X1_over_dst(m1, k1, d.m2, d.k2, d.c, x)[0], bounds=(w[i - 1], w[i + 1]),
                            method="bounded", options={"xatol": 1e-12})
        found.append((r.x, -r.fun))
    assert len(found) == len(d.peaks) == 2
    for (wf, af), pk in zip(found, d.peaks):
        assert pk.w == pytest.approx(wf, rel=1e-6)  # a flat maximum: its location is ill-conditioned
        assert pk.amplification == pytest.approx(af, rel=1e-12)
    assert tp.amplification == pytest.approx(max(a for _, a in found), rel=1e-12)
    # the peaks sit next to P and Q: P below the rigid-joint resonance 1/sqrt(1+beta), Q above it
    split = 1 / math.sqrt(1 + beta)
    assert d.peaks[0].Omega < split < d.peaks[1].Omega
    assert abs(d.peaks[0].Omega / d.P.Omega - 1) < 0.1 and abs(d.peaks[1].Omega / d.Q.Omega - 1) < 0.1


@pytest.mark.parametrize("beta", [0.05, 0.25])
def test_fixed_point_dampings_give_a_horizontal_tangent_at_their_point(beta):
    """zeta_P^2 = beta (3 - sqrt(beta/(beta+2)))/(8 (1+beta)^3) makes P a maximum; likewise Q (seed 000, 7.4)."""
    mu = optimal_tuning(beta)
    (OP, OQ), (h, _) = fixed_points(beta, mu)
    zP, zQ = fixed_point_damping(beta)
    assert zP**2 == pytest.approx(beta * (3 - math.sqrt(beta / (beta + 2))) / (8 * (1 + beta) ** 3), rel=1e-14)
    assert (zP**2 + zQ**2) / 2 == pytest.approx(optimal_damping(beta) ** 2, rel=1e-14)
    for z, O in ((zP, OP), (zQ, OQ)):
        e = 1e-5
        d = (amplification(O + e, beta, mu, z) - amplification(O - e, beta, mu, z)) / (2 * e)
        assert abs(d) < 1e-7 * h
        assert any(abs(Op - O) < 1e-7 and abs(a - h) < 1e-10 * h for Op, a in peaks(beta, mu, z))


def test_dimensionless_response_matches_the_impedance_solve():
    beta, mu, zeta = 0.07, 0.93, 0.12
    m1, k1 = 4.0, 900.0
    p = math.sqrt(k1 / m1)
    m2 = beta * m1
    k2, c = m2 * (mu * p) ** 2, 2 * m2 * p * zeta
    Om = np.linspace(0.1, 2.0, 300)
    M, C, K = chain_matrices([m1, m2], [k1, k2, 0.0], [0.0, c, 0.0])
    X = frf(M, C, K, Om * p, [k1, 0.0])  # delta_st = 1
    X1, X2 = response(Om, beta, mu, zeta)
    np.testing.assert_allclose(X1, X[:, 0], rtol=1e-11)
    np.testing.assert_allclose(X2, X[:, 1], rtol=1e-11)
    np.testing.assert_allclose(amplification(Om, beta, mu, zeta), np.abs(X[:, 0]), rtol=1e-11)


@pytest.mark.parametrize("A", [3.0, 5.0, 10.0])
def test_sizing_from_a_maximum_amplification(A):
    d = design_absorber(50.0, 2e4, max_amplification=A)
    assert d.beta == pytest.approx(2 / (A**2 - 1), rel=1e-14)  # sqrt((2 + beta)/beta) = A
    assert d.fixed_point_height == pytest.approx(A, rel=1e-13)
    assert d.true_peak.amplification > A
    e = design_absorber(50.0, 2e4, max_amplification=A, sizing="peak")
    assert e.true_peak.amplification == pytest.approx(A, rel=1e-10)
    assert e.m2 > d.m2 and e.fixed_point_height < A
    assert true_peak(e.beta, e.mu, e.zeta)[1] == pytest.approx(A, rel=1e-10)


def test_absorber_problem_names_the_bad_field():
    with pytest.raises(ValueError, match="AbsorberProblem.m1 must be a positive finite number"):
        AbsorberProblem(-1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="AbsorberProblem.k1 must be a positive finite number"):
        AbsorberProblem(1.0, float("nan"), 1.0)
    with pytest.raises(ValueError, match="AbsorberProblem: give exactly one of m2"):
        AbsorberProblem(1.0, 1.0)
    with pytest.raises(ValueError, match="AbsorberProblem: give exactly one of m2"):
        AbsorberProblem(1.0, 1.0, 0.1, 5.0)
    with pytest.raises(ValueError, match="AbsorberProblem.m2 must be a positive finite number"):
        AbsorberProblem(1.0, 1.0, 0.0)
    with pytest.raises(ValueError, match="AbsorberProblem.max_amplification must exceed 1"):
        AbsorberProblem(1.0, 1.0, max_amplification=0.9)
    with pytest.raises(ValueError, match="AbsorberProblem.sizing must be one of"):
        AbsorberProblem(1.0, 1.0, max_amplification=3.0, sizing="exact")
    with pytest.raises(ValueError, match="unbounded for zeta = 0"):
        true_peak(0.1, 1.0, 0.0)


def test_design_report_names_both_damping_conventions(tmp_path):
    d = design_absorber(100.0, 5e5, 10.0)
    text = d.report()
    for piece in ("k2 = k1 beta/(1+beta)^2 = 41322.3", "c = 237.379", "zeta   = c/(2 m2 p)",
                  "zeta_a = c/(2 sqrt(m2 k2))", "referred to the main system", "the absorber's own ratio",
                  "true peak", "anti-resonance at w = p_a"):
        assert piece in text
    w = np.linspace(50, 90, 7)
    X = d.frf(w, F=2.0)
    np.testing.assert_allclose(np.abs(X[:, 0]) / (2.0 / d.k1), d.amplification(w), rtol=1e-11)
    from contin.modal.absorber_design import plot_design

    assert plot_design(d, tmp_path / "a.png", points=50).exists()
