"""Compiled complex LU factorisations, dense and banded, for the per-harmonic blocks of :mod:`contin.hb.condensation`.

Dense factors are kept in place of the square matrix (``PA = LU``, ``perm``
the row order). Banded factors follow LAPACK's ``gbtrf``: a matrix with
``kl`` sub- and ``ku`` super-diagonals is held in ``AB`` of shape
``(2 kl + ku + 1, n)`` with ``A[i, j]`` at ``AB[kl + ku + i - j, j]``; the first
``kl`` rows are room for the fill-in of the row interchanges, and ``piv[j]``
is the row swapped with row ``j`` at step ``j``. A banded factorisation costs
``O(n kl (kl + ku))`` and a solve ``O(n (2 kl + ku))``.

The dispatchers :func:`factor` and :func:`solve` (plain or transposed) take either
form: ``kl < 0`` marks dense factors.
"""

from __future__ import annotations

import numpy as np

from contin.util.jit import njit

__all__ = ["band_lu", "band_solve", "band_solve_t", "bandwidths", "dense_lu", "dense_solve", "dense_solve_t",
           "factor", "solve"]


def bandwidths(pattern) -> tuple:
    """The lower and upper bandwidths of a square pattern.

    Parameters
    ----------
    pattern : array_like of bool, shape (n, n)

    Returns
    -------
    kl, ku : int
        The largest ``i - j`` and ``j - i`` over the true entries ``(i, j)`` (0 when there are none).
    """
    i, j = np.nonzero(np.asarray(pattern, dtype=bool))
    if i.size == 0:
        return 0, 0
    return int(max(0, (i - j).max())), int(max(0, (j - i).max()))


# ------------------------------------------------------------------ dense
@njit(cache=True)
def dense_lu(A, perm) -> bool:
    """LU with partial pivoting of the square complex ``A`` in place (``PA = LU``, ``perm`` the row order).

    Parameters
    ----------
    A : complex ndarray, shape (n, n)
        Overwritten by the factors (unit lower ``L`` below the diagonal).
    perm : int ndarray, shape (n,)
        Written: row ``i`` of ``PA`` is row ``perm[i]`` of ``A``.

    Returns
    -------
    bool
        False on a zero or non-finite pivot.
    """
    n = A.shape[0]
    for i in range(n):
        perm[i] = i
    for j in range(n):
        r = j
        big = abs(A[j, j])
        for i in range(j + 1, n):
            if abs(A[i, j]) > big:
                r, big = i, abs(A[i, j])
        if not (big > 0.0 and np.isfinite(big)):
            return False
        if r != j:
            for q in range(n):
                A[j, q], A[r, q] = A[r, q], A[j, q]
            perm[j], perm[r] = perm[r], perm[j]
        for i in range(j + 1, n):
            m = A[i, j] / A[j, j]
            A[i, j] = m
            for q in range(j + 1, n):
                A[i, q] -= m * A[j, q]
    return True


@njit(cache=True)
def dense_solve(A, perm, r, out):
    """``out = A^-1 r`` from the factors of :func:`dense_lu`; ``r``, ``out`` of shape (n,), distinct."""
    n = A.shape[0]
    for i in range(n):
        s = r[perm[i]]
        for q in range(i):
            s -= A[i, q] * out[q]
        out[i] = s
    for i in range(n - 1, -1, -1):
        s = out[i]
        for q in range(i + 1, n):
            s -= A[i, q] * out[q]
        out[i] = s / A[i, i]


@njit(cache=True)
def dense_solve_t(A, perm, r, out):
    """``out = A^-T r`` (plain transpose) from the factors of :func:`dense_lu`: ``U^T L^T P out = r``."""
    n = A.shape[0]
    w = np.empty(n, dtype=np.complex128)
    for i in range(n):
        s = r[i]
        for q in range(i):
            s -= A[q, i] * w[q]
        w[i] = s / A[i, i]
    for i in range(n - 1, -1, -1):
        s = w[i]
        for q in range(i + 1, n):
            s -= A[q, i] * w[q]
        w[i] = s
    for i in range(n):
        out[perm[i]] = w[i]


# ------------------------------------------------------------------ banded
@njit(cache=True)
def band_lu(AB, kl, ku, piv) -> bool:
    """LU with partial pivoting of a banded complex matrix in ``gbtrf`` storage, in place.

    Parameters
    ----------
    AB : complex ndarray, shape (2 kl + ku + 1, n)
        ``A[i, j]`` at ``AB[kl + ku + i - j, j]``; the first ``kl`` rows must be
        zero on entry (room for fill-in). Overwritten by ``U`` (rows
        ``0 .. kl + ku``) and the multipliers of ``L`` (rows below).
    kl, ku : int
        Lower and upper bandwidths, ``>= 0``.
    piv : int ndarray, shape (n,)
        Written: row ``j`` was swapped with row ``piv[j] >= j`` at step ``j``.

    Returns
    -------
    bool
        False on a zero or non-finite pivot.
    """
    n = AB.shape[1]
    kv = kl + ku
    ju = 0  # the last column touched by the interchanges so far
    for j in range(n):
        km = min(kl, n - 1 - j)
        jp = 0
        big = abs(AB[kv, j])
        for i in range(1, km + 1):
            if abs(AB[kv + i, j]) > big:
                jp, big = i, abs(AB[kv + i, j])
        piv[j] = j + jp
        if not (big > 0.0 and np.isfinite(big)):
            return False
        ju = max(ju, min(j + ku + jp, n - 1))
        if jp != 0:
            for q in range(j, ju + 1):
                a, b = kv + j - q, kv + j + jp - q
                AB[a, q], AB[b, q] = AB[b, q], AB[a, q]
        d = AB[kv, j]
        for i in range(1, km + 1):
            AB[kv + i, j] = AB[kv + i, j] / d
        for q in range(j + 1, ju + 1):
            a = AB[kv + j - q, q]
            if a != 0:
                for i in range(1, km + 1):
                    AB[kv + j + i - q, q] -= AB[kv + i, j] * a
    return True


@njit(cache=True)
def band_solve(AB, kl, ku, piv, b):
    """``b <- A^-1 b`` in place, from the factors of :func:`band_lu`; ``b`` of shape (n,)."""
    n = AB.shape[1]
    kv = kl + ku
    for j in range(n - 1):
        p = piv[j]
        if p != j:
            b[j], b[p] = b[p], b[j]
        bj = b[j]
        for i in range(1, min(kl, n - 1 - j) + 1):
            b[j + i] -= AB[kv + i, j] * bj
    for i in range(n - 1, -1, -1):
        s = b[i]
        for q in range(i + 1, min(n, i + kv + 1)):
            s -= AB[kv + i - q, q] * b[q]
        b[i] = s / AB[kv, i]


@njit(cache=True)
def band_solve_t(AB, kl, ku, piv, b):
    """``b <- A^-T b`` (plain transpose, not conjugate) in place, from the factors of :func:`band_lu`."""
    n = AB.shape[1]
    kv = kl + ku
    for i in range(n):
        s = b[i]
        for q in range(max(0, i - kv), i):
            s -= AB[kv + q - i, i] * b[q]
        b[i] = s / AB[kv, i]
    for j in range(n - 2, -1, -1):
        s = b[j]
        for i in range(1, min(kl, n - 1 - j) + 1):
            s -= AB[kv + i, j] * b[j + i]
        b[j] = s
        p = piv[j]
        if p != j:
            b[j], b[p] = b[p], b[j]


# ------------------------------------------------------------------ either storage
@njit(cache=True)
def factor(F, kl, ku, piv) -> bool:
    """:func:`dense_lu` of ``F`` when ``kl < 0``, else :func:`band_lu`."""
    if kl < 0:
        return dense_lu(F, piv)
    return band_lu(F, kl, ku, piv)


@njit(cache=True)
def solve(F, kl, ku, piv, r, out, transpose=False):
    """``out = A^-1 r``, or ``A^-T r`` (plain transpose) with ``transpose``, from :func:`factor`'s factors;
    ``r``, ``out`` of shape (n,), distinct."""
    if kl < 0:
        if transpose:
            dense_solve_t(F, piv, r, out)
        else:
            dense_solve(F, piv, r, out)
        return
    out[:] = r
    if transpose:
        band_solve_t(F, kl, ku, piv, out)
    else:
        band_solve(F, kl, ku, piv, out)
