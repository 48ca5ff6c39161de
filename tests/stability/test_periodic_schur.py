"""Eigenvalues of a product from its factors (periodic Schur) against spectra known from outside the code.

The factors are built as ``A_k = Z_{k+1} T_k Z_k^T`` with random orthogonal
``Z_k`` (``Z_K = Z_0``) and triangular or quasi-triangular ``T_k`` whose
product's spectrum is known in closed form; the damped oscillator's
multipliers are ``exp(lambda T)`` with ``lambda`` from its modal data.
"""

import numpy as np
import pytest
from conftest import fuzz_examples
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import expm
from scipy.optimize import linear_sum_assignment

import contin.stability.periodic_schur as ps
from contin.stability.periodic_schur import periodic_eigenvalues, periodic_schur


def _orthogonal(rng, m):
    q, r = np.linalg.qr(rng.standard_normal((m, m)))
    return q * np.sign(np.diag(r))


def _factors(rng, T):
    """``A_k = Z_{k+1} T_k Z_k^T``: the product is ``Z_0 T_{K-1} ... T_0 Z_0^T``."""
    K, m = len(T), T[0].shape[0]
    Z = [_orthogonal(rng, m) for _ in range(K)]
    return np.array([Z[(k + 1) % K] @ T[k] @ Z[k].T for k in range(K)])


def _product(A):
    P = np.eye(A.shape[1])
    for a in A:
        P = a @ P
    return P


def _relative_errors(computed, exact):
    """Relative error of each exact eigenvalue against its computed partner (the best one-to-one pairing)."""
    computed, exact = np.asarray(computed), np.asarray(exact)
    assert computed.shape == exact.shape
    D = np.abs(computed[:, None] - exact[None, :]) / np.abs(exact)[None, :]
    rows, cols = linear_sum_assignment(D)
    return D[rows, cols]


def _rotation(r, theta):
    return r * np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])


def _spread_factors(rng, K=8, m=8):
    """Triangular factors whose product has the real eigenvalues +-1e12 ... +-1e-12, in random order."""
    lam = np.array([(-1) ** j * 10.0 ** e for j, e in enumerate(np.linspace(12, -12, m))])
    order = rng.permutation(m)
    T = []
    for k in range(K):
        d = np.abs(lam[order]) ** (1 / K) * (np.sign(lam[order]) if k == 0 else 1)
        T.append(np.diag(d) + np.triu(0.5 * rng.standard_normal((m, m)), 1))
    return _factors(rng, T), lam


def _complex_factors(rng, K=6):
    """Quasi-triangular factors: three complex pairs of moduli 1e10, 1e-10, 1 (rotations) and 1e-6."""
    moduli, angles = (1e10, 1e-10, 1.0), (0.3, 2.0, 1.0)
    T = []
    for _ in range(K):
        t = np.triu(0.3 * rng.standard_normal((7, 7)), 1)
        for b in range(3):
            t[2 * b:2 * b + 2, 2 * b:2 * b + 2] = _rotation(moduli[b] ** (1 / K), angles[b] / K)
        t[6, 6] = 1e-6 ** (1 / K)
        T.append(t)
    exact = [m * np.exp(s * 1j * a) for m, a in zip(moduli, angles) for s in (1, -1)] + [1e-6]
    return _factors(rng, T), np.array(exact)


def _oscillator_factors(K, T=2 * np.pi, seed=5):
    """Monodromy factors ``expm(A T/K)`` of a 4-dof damped oscillator and its exact multipliers.

    ``M = I``, ``K = Phi diag(w^2) Phi^T``, ``C = Phi diag(2 zeta w) Phi^T`` with
    ``Phi`` orthogonal: ``lambda = -zeta w +- w sqrt(zeta^2 - 1)``. One mode
    negatively damped (multiplier 3.3e8), one strongly damped (1.9e-9).
    """
    rng = np.random.default_rng(seed)
    w, zeta = np.array([0.5, 1.3, 2.1, 4.0]), np.array([-3.2, 0.02, 0.3, 0.8])
    Phi = _orthogonal(rng, 4)
    stiffness, damping = Phi @ np.diag(w**2) @ Phi.T, Phi @ np.diag(2 * zeta * w) @ Phi.T
    A = np.block([[np.zeros((4, 4)), np.eye(4)], [-stiffness, -damping]])
    root = w * np.sqrt(zeta.astype(complex) ** 2 - 1)
    lam = np.concatenate([-zeta * w + root, -zeta * w - root])
    return np.array([expm(A * T / K)] * K), np.exp(lam * T)


def test_widely_spread_moduli_keep_their_relative_accuracy(rng):
    A, lam = _spread_factors(rng)
    computed = periodic_eigenvalues(A)
    assert np.abs(computed.imag).max() == 0.0
    assert _relative_errors(computed, lam).max() < 1e-10
    # why: the formed product resolves eigenvalues only to eps ||P|| ~ 1e-4, so the small ones are lost
    lost = _relative_errors(np.linalg.eigvals(_product(A)), lam)
    assert lost.max() > 1e-2


def test_complex_pairs_from_two_by_two_blocks(rng):
    A, exact = _complex_factors(rng)
    computed = periodic_eigenvalues(A)
    assert _relative_errors(computed, exact).max() < 1e-10
    assert np.sum(computed.imag != 0) == 6
    # conjugate pairs exactly, adjacent, positive imaginary part first
    pairs = np.flatnonzero(computed.imag > 0)
    assert np.array_equal(computed[pairs + 1], computed[pairs].conj())


def test_one_factor_equals_eigvals(rng):
    a = rng.standard_normal((1, 10, 10))
    ref = np.linalg.eigvals(a[0])
    assert _relative_errors(periodic_eigenvalues(a), ref).max() < 1e-12


def test_well_conditioned_factors_against_eigvals_of_the_product(rng):
    for K, m in [(2, 5), (5, 8), (8, 12)]:
        A = np.array([_orthogonal(rng, m) @ np.diag(rng.uniform(0.5, 2.0, m)) for _ in range(K)])
        ref = np.linalg.eigvals(_product(A))
        assert _relative_errors(periodic_eigenvalues(A), ref).max() < 1e-10, (K, m)


@pytest.mark.parametrize("K", [8, 16])
def test_damped_oscillator_monodromy_factors(K):
    factors, exact = _oscillator_factors(K)
    assert np.abs(exact).max() > 1e8 and np.abs(exact).min() < 1e-8
    assert _relative_errors(periodic_eigenvalues(factors), exact).max() < 1e-10
    # the product of the same factors loses the multipliers near 1e-9 (its error ~ eps * 3e8)
    assert _relative_errors(np.linalg.eigvals(_product(factors)), exact).max() > 1e-2


def _check_schur_form(A, q, t):
    K, m = A.shape[:2]
    for k in range(K):
        assert np.abs(q[k].T @ q[k] - np.eye(m)).max() < 1e-13
        scale = np.linalg.norm(A[k], 2)
        reduced = q[(k + 1) % K].T @ A[k] @ q[k]
        assert np.abs(reduced - t[k]).max() < 1e-13 * scale
        below = -1 if k == K - 1 else 0  # the last factor keeps its 2x2 blocks' subdiagonal
        assert np.abs(np.tril(reduced, below - 1)).max(initial=0.0) < 1e-14 * scale
        assert not np.tril(t[k], below - 1).any()
        if k < K - 1:
            assert np.abs(np.diag(reduced, -1)).max(initial=0.0) < 1e-14 * scale
    # T_{K-1} quasi-triangular: the 2x2 blocks do not overlap, each holds a complex pair
    sub = np.flatnonzero(np.diag(t[-1], -1))
    assert not np.any(np.diff(sub) == 1)
    for j in sub:
        block = np.eye(2)
        for k in range(K):
            block = t[k][j:j + 2, j:j + 2] @ block
        assert np.iscomplex(np.linalg.eigvals(block)).all()
    for j in range(m - 1):  # where the subdiagonal is zero, the reduced matrix's is below 1e-14
        if j not in sub:
            assert abs(reduced[j + 1, j]) < 1e-14 * np.linalg.norm(A[-1], 2)


def test_schur_form_invariants(rng):
    for A in (_spread_factors(rng)[0], _complex_factors(rng)[0], _oscillator_factors(8)[0],
              rng.standard_normal((3, 9, 9)), rng.standard_normal((1, 6, 6))):
        q, t = periodic_schur(A)
        _check_schur_form(A, q, t)
        # the Schur form's eigenvalues are those returned without it
        from_t = periodic_eigenvalues(t)
        assert _relative_errors(periodic_eigenvalues(A), from_t).max() < 1e-10


def test_singular_and_trivial_factors(rng):
    # a zero on a triangular factor's diagonal: an eigenvalue 0; the others are the diagonal products
    T = [np.triu(rng.uniform(0.5, 2.0, (5, 5))) for _ in range(3)]
    T[1][2, 2] = 0.0
    exact = np.prod([np.diag(t) for t in T], axis=0)
    computed = periodic_eigenvalues(_factors(rng, T))
    assert np.sort(np.abs(computed))[0] < 1e-12
    nonzero = exact != 0
    assert _relative_errors(computed[np.argsort(-np.abs(computed))][:4], exact[nonzero]).max() < 1e-10
    assert np.array_equal(periodic_eigenvalues(np.array([np.eye(4)] * 3)), np.ones(4))
    assert np.array_equal(periodic_eigenvalues(np.zeros((3, 4, 4))), np.zeros(4))
    assert periodic_eigenvalues([[[-2.5]], [[4.0]]]) == pytest.approx([-10.0], rel=1e-15)


def test_defective_and_repeated_eigenvalues(rng):
    # a Jordan block of size 2 split over four factors: the double eigenvalue 1 to sqrt(eps)
    J = np.array([[1.0, 1.0], [0.0, 1.0]])
    computed = periodic_eigenvalues(_factors(rng, [J] * 4))
    assert np.allclose(computed, 1.0, rtol=0, atol=1e-7)
    # a cyclic permutation: the 6th roots of unity squared, each twice
    shift = np.roll(np.eye(6), 1, axis=0)
    exact = np.exp(2j * np.pi * np.arange(6) / 6) ** 2
    assert _relative_errors(periodic_eigenvalues(np.array([shift, shift])), exact).max() < 1e-12


@settings(max_examples=fuzz_examples(40), deadline=None)
@given(seed=st.integers(0, 2**32 - 1), K=st.integers(1, 6), m=st.integers(1, 9))
def test_random_well_conditioned_factors_property(seed, K, m):
    rng = np.random.default_rng(seed)
    A = np.array([_orthogonal(rng, m) @ np.diag(rng.uniform(0.5, 2.0, m)) for _ in range(K)])
    computed = periodic_eigenvalues(A)
    assert computed.shape == (m,) and computed.dtype == complex
    assert np.all(np.diff(np.abs(computed)) <= 1e-12 * np.abs(computed).max())  # by decreasing modulus
    assert _relative_errors(computed, np.linalg.eigvals(_product(A))).max() < 1e-10


@pytest.mark.parametrize("bad", [np.ones((3, 3)), np.ones((2, 3, 4)), np.ones((0, 2, 2)), np.ones((2, 0, 0)),
                                 np.ones((2, 2, 2, 2))], ids=["2d", "not-square", "no-factor", "empty", "4d"])
def test_shape_is_validated(bad):
    for f in (periodic_eigenvalues, periodic_schur):
        with pytest.raises(ValueError, match=r"factors: expected shape \(K, m, m\)"):
            f(bad)


def test_ragged_factors_are_refused():
    with pytest.raises(ValueError, match=r"factors: expected an array of shape \(K, m, m\)"):
        periodic_eigenvalues([np.eye(2), np.eye(3)])


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_entries_are_refused(value):
    A = np.ones((3, 4, 4))
    A[1, 2, 3] = value
    for f in (periodic_eigenvalues, periodic_schur):
        with pytest.raises(ValueError, match="factors: expected finite entries, factor 1"):
            f(A)


def test_complex_and_non_numeric_factors_are_refused():
    with pytest.raises(ValueError, match="factors: expected real numbers"):
        periodic_eigenvalues(np.ones((2, 3, 3), complex))
    with pytest.raises(ValueError, match="factors: expected real numbers"):
        periodic_eigenvalues(np.full((1, 2, 2), "a"))


def test_the_factors_given_are_not_changed(rng):
    A = rng.standard_normal((3, 5, 5))
    kept = A.copy()
    periodic_eigenvalues(A)
    periodic_schur(A)
    assert np.array_equal(A, kept)


def test_no_convergence_raises_rather_than_returning(rng):
    A = rng.standard_normal((3, 8, 8))
    with pytest.raises(ArithmeticError, match="no deflation within 1 sweeps"):
        periodic_eigenvalues(A, max_iterations=1)
    with pytest.raises(ArithmeticError, match="no eigenvalues returned"):
        periodic_schur(A, max_iterations=1)
    for bad in (0, -3, 2.5, True, "10"):
        with pytest.raises(ValueError, match="max_iterations: expected a positive integer"):
            periodic_eigenvalues(A, max_iterations=bad)


def test_multipliers_survive_a_periodic_qr_that_does_not_deflate(monkeypatch):
    """Factors merged pairwise until the periodic QR deflates (here: never), then LAPACK on the product."""
    rng = np.random.default_rng(3)
    factors = np.eye(4) + 0.3 * rng.standard_normal((8, 4, 4))
    calls = []

    def stalls(f):
        calls.append(f.shape[0])
        raise ArithmeticError("periodic QR: no deflation")

    monkeypatch.setattr(ps, "periodic_eigenvalues", stalls)
    mu = ps.product_eigenvalues(factors)
    product = np.linalg.multi_dot(factors[::-1])
    np.testing.assert_allclose(np.sort_complex(mu), np.sort_complex(np.linalg.eigvals(product)), rtol=1e-10)
    assert calls == [8, 4, 2] and np.all(np.diff(np.abs(mu)) <= 1e-12)
