"""Dense and banded complex LU of contin.hb.block_lu against scipy.linalg.solve."""

import numpy as np
import pytest
import scipy.linalg

from contin.hb.block_lu import (band_lu, band_solve, band_solve_t, bandwidths, dense_lu, dense_solve, dense_solve_t,
                                factor, solve)


def banded(rng, n, kl, ku):
    """A random complex matrix of bandwidths (kl, ku) with a small diagonal, so that rows must be swapped.

    A triangular one (kl or ku 0) gets a dominant diagonal instead: with a small one it is nearly singular.
    """
    A = rng.normal(size=(n, n)) + 1j * rng.normal(size=(n, n))
    i, j = np.indices((n, n))
    A[(i - j > kl) | (j - i > ku)] = 0.0
    A[i == j] = A[i == j] * 1e-3 if min(kl, ku) > 0 else 3.0 + A[i == j]
    return A


def close(x, ref, A):
    """``x`` equals ``ref`` to the accuracy the condition number of ``A`` allows."""
    tol = max(1e-12, 1e-14 * np.linalg.cond(A)) * np.abs(ref).max()
    np.testing.assert_allclose(x, ref, rtol=0, atol=tol)


def to_band(A, kl, ku):
    """``A`` in gbtrf storage: ``A[i, j]`` at ``AB[kl + ku + i - j, j]``, the first kl rows zero."""
    n = A.shape[0]
    AB = np.zeros((2 * kl + ku + 1, n), dtype=complex)
    for j in range(n):
        for i in range(max(0, j - ku), min(n, j + kl + 1)):
            AB[kl + ku + i - j, j] = A[i, j]
    return AB


@pytest.mark.parametrize("kl, ku", [(0, 0), (0, 2), (2, 0), (1, 1), (3, 2), (7, 7)])
def test_band_lu_solves_like_scipy(kl, ku, rng):
    swapped = False
    for n in (1, 2, 3, 5, 8, 13, 40):
        A = banded(rng, n, kl, ku)
        b = rng.normal(size=n) + 1j * rng.normal(size=n)
        AB, piv = to_band(A, kl, ku), np.empty(n, dtype=np.int64)
        assert band_lu(AB, kl, ku, piv)
        assert np.all(piv >= np.arange(n)) and np.all(piv <= np.minimum(np.arange(n) + kl, n - 1))
        swapped |= bool(np.any(piv != np.arange(n)))
        x = b.copy()
        band_solve(AB, kl, ku, piv, x)
        close(x, scipy.linalg.solve(A, b), A)
        y = b.copy()
        band_solve_t(AB, kl, ku, piv, y)
        close(y, scipy.linalg.solve(A.T, b), A)  # the transpose, not the conjugate one
        # the dispatchers, banded and dense, into an out array
        out = np.empty(n, dtype=complex)
        solve(AB, kl, ku, piv, b, out)
        np.testing.assert_array_equal(out, x)
        solve(AB, kl, ku, piv, b, out, True)
        np.testing.assert_array_equal(out, y)
        D, perm = A.copy(), np.empty(n, dtype=np.int64)
        assert factor(D, -1, -1, perm)
        solve(D, -1, -1, perm, b, out)
        close(out, x, A)
        solve(D, -1, -1, perm, b, out, True)
        close(out, y, A)
    assert swapped or min(kl, ku) == 0  # the small diagonals made rows swap


def test_dense_lu_solves_like_scipy(rng):
    for n in (1, 4, 17):
        A = banded(rng, n, n - 1, n - 1)
        b = rng.normal(size=n) + 1j * rng.normal(size=n)
        D, perm, x = A.copy(), np.empty(n, dtype=np.int64), np.empty(n, dtype=complex)
        assert dense_lu(D, perm)
        dense_solve(D, perm, b, x)
        close(x, scipy.linalg.solve(A, b), A)
        dense_solve_t(D, perm, b, x)
        close(x, scipy.linalg.solve(A.T, b), A)


def test_singular_matrices_are_refused(rng):
    A = banded(rng, 6, 1, 2)
    A[:, 3] = 0.0  # a zero column: no pivot at step 3
    piv = np.empty(6, dtype=np.int64)
    assert not band_lu(to_band(A, 1, 2), 1, 2, piv)
    assert not dense_lu(A.copy(), piv)
    B = to_band(banded(rng, 6, 1, 2), 1, 2)
    B[3, 2] = np.nan  # the diagonal entry of column 2
    assert not band_lu(B, 1, 2, piv)


def test_bandwidths():
    assert bandwidths(np.zeros((3, 3), dtype=bool)) == (0, 0)
    assert bandwidths(np.eye(4, dtype=bool)) == (0, 0)
    P = np.eye(5, dtype=bool)
    P[4, 1] = P[0, 2] = True
    assert bandwidths(P) == (3, 2)
