"""The compiled products of an invariant circle's Lyapunov exponents (contin.stability.circle_products)."""

import math

import numpy as np
import pytest

from contin.stability.circle_products import fourier_rows, normal_products


def _evaluate(rows, theta):
    top = (len(rows) - 1) // 2
    k = np.arange(1, top + 1)
    return rows[0] + np.tensordot(np.cos(k * theta), rows[1::2], 1) + np.tensordot(np.sin(k * theta), rows[2::2], 1)


@pytest.mark.parametrize("K", [7, 8])
def test_the_rows_pass_through_the_samples_and_hold_a_trigonometric_polynomial(K):
    """Odd and even sample counts: the polynomial equals the samples at their angles, and a polynomial of
    degree below K / 2 sampled K times comes back everywhere."""
    theta = 2 * np.pi * np.arange(K) / K
    f = lambda t: np.array([1.0 + 0.5 * np.cos(t) - 0.25 * np.sin(3 * t), np.sin(2 * t)])  # noqa: E731
    rows = fourier_rows(np.array([f(t) for t in theta]))
    assert rows.shape == (2 * (K // 2) + 1, 2)
    for t in np.r_[theta, 0.3, 2.0, 5.9]:
        np.testing.assert_allclose(_evaluate(rows, t), f(t), atol=1e-14)
    noise = np.random.default_rng(0).normal(size=(K, 3))
    rows = fourier_rows(noise)
    np.testing.assert_allclose([_evaluate(rows, t) for t in theta], noise, atol=1e-12)


def test_a_constant_diagonal_map_gives_its_logarithms():
    """DP = diag(e^a) with the tangent along e1: the tangential sum is a1 a period, the normal ones a2, a3."""
    a = np.array([0.1, -0.2, 0.05])
    L = 500
    rows = fourier_rows(np.repeat(np.diag(np.exp(a))[None], 5, axis=0))
    theta = 2 * np.pi * ((np.arange(L + 1) * 0.381966) % 1.0)
    tangents = np.tile([1.0, 0.0, 0.0], (L + 1, 1))
    Q = np.array([[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]])  # the faster normal direction first
    sums = np.zeros(2)
    tangential = normal_products(rows, theta, tangents, Q, sums)
    assert tangential / L == pytest.approx(a[0], abs=1e-13)
    np.testing.assert_allclose(sums / L, [a[2], a[1]], atol=1e-13)


def test_the_compiled_loop_equals_numpys_qr_loop():
    """Random smooth Jacobians along a circle: the compiled products against the same steps written with
    numpy's QR (signs aside, R's diagonal is unique)."""
    rng = np.random.default_rng(3)
    m, K, L = 4, 9, 300
    J = np.eye(m) + 0.3 * rng.normal(size=(K, m, m))
    rows = fourier_rows(J)
    theta = 2 * np.pi * ((np.arange(L + 1) * 0.2718) % 1.0)
    tangents = rng.normal(size=(L + 1, m))
    tangents /= np.linalg.norm(tangents, axis=1)[:, None]
    Q0 = np.linalg.qr(np.c_[tangents[0], np.eye(m)])[0][:, 1:m]
    sums = np.zeros(m - 1)
    tangential = normal_products(rows, theta, tangents, Q0.copy(), sums)
    Q, ref, ref_t = Q0.copy(), np.zeros(m - 1), 0.0
    for i in range(L):
        P = _evaluate(rows, theta[i])
        ref_t += math.log(np.linalg.norm(P @ tangents[i]))
        A = P @ Q
        A -= np.outer(tangents[i + 1], tangents[i + 1] @ A)
        Q, R = np.linalg.qr(A)
        ref += np.log(np.abs(np.diag(R)))
    assert tangential == pytest.approx(ref_t, rel=1e-12)
    np.testing.assert_allclose(sums, ref, rtol=1e-10)
