"""Eigenvalues of a product of matrices by the periodic Schur decomposition, the product never formed.

The monodromy matrix of a periodic orbit split into ``K`` segments is the
product ``P = A_{K-1} ... A_1 A_0`` of the segments' state-transition
matrices. Formed explicitly, ``P`` carries an absolute error of about
``eps ||P||``: on a strongly unstable orbit (a multiplier of ``1e8``) every
multiplier below ``1e-8`` is noise, and the verdict can depend on how many
segments there are. Working on the factors keeps each eigenvalue's
relative accuracy whatever the spread of the moduli.

Method
------
Orthogonal ``Q_k`` (``Q_K = Q_0``) bring the factors to the periodic Schur
form ``T_k = Q_{k+1}^T A_k Q_k``: ``T_0, ..., T_{K-2}`` upper triangular,
``T_{K-1}`` quasi-triangular (1x1 and 2x2 diagonal blocks), so that
``Q_0^T P Q_0 = T_{K-1} ... T_0`` is in real Schur form
(Bojanczyk, Golub & Van Dooren, "The periodic Schur decomposition", SPIE
1770, 1992; Hench & Laub, IEEE TAC 39, 1994; Kressner, *Numerical methods and
software for general and structured eigenvalue problems*, TU Berlin 2004,
ch. 3):

1. reduction to periodic Hessenberg-triangular form by Householder
   reflections, column by column: each triangular factor's column is zeroed
   below the diagonal, then the Hessenberg factor's below the subdiagonal,
   each reflection applied to the factor beside it (``O(K m^3)``);
2. the periodic QR algorithm: Francis double shifts taken from the
   product's trailing 2x2 block (formed from the factors' small blocks,
   each scaled by its factor's largest entry so nothing overflows), the
   bulge introduced in the Hessenberg factor, carried through every
   triangular factor by the QR decomposition of its 3x3 diagonal block and
   chased down; deflation where a subdiagonal entry of the Hessenberg factor
   is below ``eps`` times its diagonal neighbours; exceptional shifts after
   10 and 20 sweeps without a deflation (as in LAPACK's ``dlahqr``); a 2x2
   block whose eigenvalues are real is split by single-shift steps with the
   exact shift.

An eigenvalue of a 1x1 block is the product of the factors' diagonal
entries (accurate in relative terms however spread, each factor being
backward stable); a 2x2 block's pair is that of the product of the factors'
2x2 diagonal blocks. The scaling is by powers of two, so exact.

Failure: more than ``max_iterations`` sweeps without a deflation raises
``ArithmeticError``, never a partial spectrum. The measured accuracy and
timings are in ``docs/validation/monodromy.md``.
"""

from __future__ import annotations

import math
import numbers
from typing import NamedTuple

import numpy as np

from contin.util.jit import njit

__all__ = ["PeriodicSchur", "periodic_eigenvalues", "periodic_schur", "product_eigenvalues"]

_EPS = float(np.finfo(float).eps)
# below this a subdiagonal entry is negligible whatever its neighbours (LAPACK's smlnum, for n = 1)
_SMALL = float(np.finfo(float).tiny) / _EPS
#: sweeps allowed without a deflation before giving up (scaled by the dimension, LAPACK's 30 max(10, n))
_SWEEPS_PER_ORDER = 30
#: single-shift steps allowed to split a 2x2 block with real eigenvalues before keeping it whole
_SPLIT_STEPS = 8


class PeriodicSchur(NamedTuple):
    """The periodic Schur form of factors ``A_k``: ``q[k+1].T @ A_k @ q[k] = t[k]``, indices cyclic.

    Attributes
    ----------
    q : ndarray, shape (K, m, m)
        Orthogonal matrices ``Q_k``.
    t : ndarray, shape (K, m, m)
        ``T_0, ..., T_{K-2}`` upper triangular, ``T_{K-1}`` quasi-triangular
        (a nonzero subdiagonal entry marks a 2x2 block).
    """

    q: np.ndarray
    t: np.ndarray


# ---------------------------------------------------------------------------------------------
# compiled kernels
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def _house(v, n):
    """Householder vector in place: ``v[:n]`` holds ``x`` on entry, ``v`` (``v[0] = 1``) on exit.

    Returns ``beta`` with ``(I - beta v v^T) x = ||x|| e_1`` (0: nothing to do).
    Golub & Van Loan, Algorithm 5.1.1, on ``x`` scaled by its largest entry.
    """
    s = 0.0
    for a in range(n):
        s = max(s, abs(v[a]))
    if s == 0.0:
        v[0] = 1.0
        return 0.0
    sig = 0.0
    for a in range(1, n):
        v[a] /= s
        sig += v[a] * v[a]
    x0 = v[0] / s
    if sig == 0.0:
        v[0] = 1.0
        return 0.0 if x0 >= 0.0 else 2.0  # -x: the reflection I - 2 e1 e1^T flips it
    mu = math.sqrt(x0 * x0 + sig)
    v0 = x0 - mu if x0 <= 0.0 else -sig / (x0 + mu)
    beta = 2.0 * v0 * v0 / (sig + v0 * v0)
    for a in range(1, n):
        v[a] /= v0
    v[0] = 1.0
    return beta


@njit(cache=True)
def _reflect_rows(X, v, beta, r, n, c0, c1):
    """``X[r:r+n, c0:c1] = (I - beta v v^T) X[r:r+n, c0:c1]``."""
    for c in range(c0, c1):
        s = 0.0
        for a in range(n):
            s += v[a] * X[r + a, c]
        s *= beta
        for a in range(n):
            X[r + a, c] -= s * v[a]


@njit(cache=True)
def _reflect_cols(X, v, beta, r, n, r0, r1):
    """``X[r0:r1, r:r+n] = X[r0:r1, r:r+n] (I - beta v v^T)``."""
    for row in range(r0, r1):
        s = 0.0
        for a in range(n):
            s += X[row, r + a] * v[a]
        s *= beta
        for a in range(n):
            X[row, r + a] -= s * v[a]


@njit(cache=True)
def _rotate_rows(X, W, r, b, c0, c1, tmp):
    """``X[r:r+b, c0:c1] = W^T X[r:r+b, c0:c1]`` for a small orthogonal ``W`` (b x b)."""
    for c in range(c0, c1):
        for a in range(b):
            tmp[a] = X[r + a, c]
        for a in range(b):
            s = 0.0
            for e in range(b):
                s += W[e, a] * tmp[e]
            X[r + a, c] = s


@njit(cache=True)
def _rotate_cols(X, W, r, b, r0, r1, tmp):
    """``X[r0:r1, r:r+b] = X[r0:r1, r:r+b] W`` for a small orthogonal ``W`` (b x b)."""
    for row in range(r0, r1):
        for a in range(b):
            tmp[a] = X[row, r + a]
        for a in range(b):
            s = 0.0
            for e in range(b):
                s += tmp[e] * W[e, a]
            X[row, r + a] = s


@njit(cache=True)
def _reflector_matrix(v, beta, b, W):
    """``W[:b, :b] = I - beta v v^T``."""
    for a in range(b):
        for e in range(b):
            W[a, e] = (1.0 if a == e else 0.0) - beta * v[a] * v[e]


@njit(cache=True)
def _block_q(X, r, b, W, C, v):
    """``W[:b, :b]`` orthogonal with ``W^T X[r:r+b, r:r+b]`` upper triangular (Householder QR of the block)."""
    for a in range(b):
        for e in range(b):
            C[a, e] = X[r + a, r + e]
            W[a, e] = 1.0 if a == e else 0.0
    for j in range(b - 1):
        n = b - j
        for a in range(n):
            v[a] = C[j + a, j]
        beta = _house(v, n)
        if beta == 0.0:
            continue
        _reflect_rows(C, v, beta, j, n, j, b)
        _reflect_cols(W, v, beta, j, n, 0, b)


@njit(cache=True)
def _reduce(A, Q, want_q):
    """Periodic Hessenberg-triangular form in place: ``A[0..K-2]`` upper triangular, ``A[K-1]`` Hessenberg."""
    K, m = A.shape[0], A.shape[1]
    v = np.empty(m)
    for j in range(m - 1):
        for k in range(K - 1):
            n = m - j
            for a in range(n):
                v[a] = A[k, j + a, j]
            beta = _house(v, n)
            if beta != 0.0:
                _reflect_rows(A[k], v, beta, j, n, j, m)
                _reflect_cols(A[k + 1], v, beta, j, n, 0, m)
                if want_q:
                    _reflect_cols(Q[k + 1], v, beta, j, n, 0, m)
            for a in range(j + 1, m):
                A[k, a, j] = 0.0
        if j < m - 2:
            n = m - j - 1
            for a in range(n):
                v[a] = A[K - 1, j + 1 + a, j]
            beta = _house(v, n)
            if beta != 0.0:
                _reflect_rows(A[K - 1], v, beta, j + 1, n, j, m)
                _reflect_cols(A[0], v, beta, j + 1, n, 0, m)
                if want_q:
                    _reflect_cols(Q[0], v, beta, j + 1, n, 0, m)
            for a in range(j + 2, m):
                A[K - 1, a, j] = 0.0


@njit(cache=True)
def _chase(A, Q, W, r, b, lo, hi, want_t, want_q, C, v, tmp):
    """Apply ``W`` (b x b) to space 0 at rows ``r..r+b-1``, then restore every triangular factor.

    The Hessenberg factor ``A[K-1]`` takes ``W^T`` from the left, ``A[0]``
    takes ``W`` from the right; each triangular ``A[k]`` then has a full
    diagonal block at ``r``, cleared by its QR factor, which passes on to
    ``A[k+1]`` from the right and ends in the Hessenberg factor again.
    ``lo..hi`` is the active window; with ``want_t`` the transformations
    reach the whole matrices (for the Schur form), else the window only.
    """
    K, m = A.shape[0], A.shape[1]
    cend = m if want_t else hi + 1
    rbeg = 0 if want_t else lo
    rend = min(r + b, hi) + 1
    _rotate_rows(A[K - 1], W, r, b, max(r - 1, lo), cend, tmp)
    _rotate_cols(A[0], W, r, b, rbeg, rend, tmp)
    if want_q:
        _rotate_cols(Q[0], W, r, b, 0, m, tmp)
    for k in range(K - 1):
        _block_q(A[k], r, b, W, C, v)
        _rotate_rows(A[k], W, r, b, r, cend, tmp)
        for a in range(1, b):
            for e in range(a):
                A[k, r + a, r + e] = 0.0
        _rotate_cols(A[k + 1], W, r, b, rbeg, rend, tmp)
        if want_q:
            _rotate_cols(Q[k + 1], W, r, b, 0, m, tmp)


@njit(cache=True)
def _triangular_product(A, scale, a, n, R):
    """``R[:n, :n]`` = the diagonal blocks at ``a`` of ``A[K-2] ... A[0]``, each divided by its scale.

    The factors are upper triangular, so the block of the product is the
    product of the blocks.
    """
    K = A.shape[0]
    for p in range(n):
        for q in range(n):
            R[p, q] = 1.0 if p == q else 0.0
    for k in range(K - 1):
        s = scale[k]
        for q in range(n - 1, -1, -1):  # R <- (A_k block / s) R, column by column (both triangular)
            for p in range(q + 1):
                acc = 0.0
                for t in range(p, q + 1):
                    acc += A[k, a + p, a + t] * R[t, q]
                R[p, q] = acc / s


@njit(cache=True)
def _product_entry(A, scale, R, a, row, col):
    """Entry ``(row, col)`` of the scaled product ``H R``, ``R`` the triangular block at ``a``."""
    K = A.shape[0]
    acc = 0.0
    for t in range(max(a, row - 1), col + 1):
        acc += A[K - 1, row, t] * R[t - a, col - a]
    return acc / scale[K - 1]


@njit(cache=True)
def _shift_vector(A, scale, lo, hi, its, R, out):
    """First column of ``(P - s1)(P - s2)`` at ``lo`` (3 entries), ``s1, s2`` from ``P``'s trailing block.

    ``P`` is the scaled product restricted to the window ``lo..hi``; the
    shifts are the eigenvalues of its trailing 2x2 block, or LAPACK's
    exceptional shifts after 10 and 20 sweeps without a deflation.
    """
    a = max(lo, hi - 2)
    _triangular_product(A, scale, a, hi - a + 1, R)
    h11 = _product_entry(A, scale, R, a, hi - 1, hi - 1)
    h12 = _product_entry(A, scale, R, a, hi - 1, hi)
    h21 = _product_entry(A, scale, R, a, hi, hi - 1)
    h22 = _product_entry(A, scale, R, a, hi, hi)
    if its > 0 and its % 10 == 0:
        s = abs(h21)
        if hi - 2 >= lo:
            s += abs(_product_entry(A, scale, R, a, hi - 1, hi - 2))
        h11 = 0.75 * s + h22
        h12 = -0.4375 * s
        h21 = s
        h22 = h11
    tr = h11 + h22
    det = h11 * h22 - h12 * h21
    _triangular_product(A, scale, lo, 2, R)
    p00 = _product_entry(A, scale, R, lo, lo, lo)
    p01 = _product_entry(A, scale, R, lo, lo, lo + 1)
    p10 = _product_entry(A, scale, R, lo, lo + 1, lo)
    p11 = _product_entry(A, scale, R, lo, lo + 1, lo + 1)
    p21 = _product_entry(A, scale, R, lo, lo + 2, lo + 1)
    out[0] = p00 * p00 + p01 * p10 - tr * p00 + det
    out[1] = p10 * (p00 + p11 - tr)
    out[2] = p10 * p21


@njit(cache=True)
def _negligible(H, j, hnorm):
    """Whether the subdiagonal entry ``H[j, j-1]`` is negligible beside its diagonal neighbours."""
    h = abs(H[j, j - 1])
    tst = abs(H[j - 1, j - 1]) + abs(H[j, j])
    if tst == 0.0:
        tst = hnorm
    return h <= _EPS * tst or h <= _SMALL


@njit(cache=True)
def _periodic_qr(A, Q, want_t, want_q, max_iterations):
    """Periodic QR iteration in place on the Hessenberg-triangular form; 0 on success, 1 when it stalls."""
    K, m = A.shape[0], A.shape[1]
    scale = np.empty(K)
    for k in range(K):
        s = 0.0
        for p in range(m):
            for q in range(m):
                s = max(s, abs(A[k, p, q]))
        scale[k] = 1.0 if s == 0.0 else s
    H = A[K - 1]
    hnorm = scale[K - 1]
    W = np.empty((3, 3))
    C = np.empty((3, 3))
    R = np.empty((3, 3))
    v = np.empty(3)
    tmp = np.empty(3)
    hi = m - 1
    its = 0
    splits = 0  # single-shift steps on the current 2x2 block (its may count sweeps on a larger window before)
    while hi >= 0:
        lo = hi
        while lo > 0:
            if _negligible(H, lo, hnorm):
                H[lo, lo - 1] = 0.0
                break
            lo -= 1
        if lo == hi:  # a 1x1 block
            hi -= 1
            its = splits = 0
            continue
        if its >= max_iterations:
            return 1
        if lo == hi - 1:  # a 2x2 block: kept if its eigenvalues are complex, split if real
            _triangular_product(A, scale, lo, 2, R)
            p00 = _product_entry(A, scale, R, lo, lo, lo)
            p01 = _product_entry(A, scale, R, lo, lo, lo + 1)
            p10 = _product_entry(A, scale, R, lo, lo + 1, lo)
            p11 = _product_entry(A, scale, R, lo, lo + 1, lo + 1)
            half = 0.5 * (p00 - p11)
            disc = half * half + p01 * p10
            if disc < 0.0 or splits >= _SPLIT_STEPS:
                hi -= 2
                its = splits = 0
                continue
            mean = 0.5 * (p00 + p11)
            root = math.sqrt(disc)
            shift = mean + root if mean >= 0.0 else mean - root  # the larger: accurate in relative terms
            v[0] = p00 - shift
            v[1] = p10
            beta = _house(v, 2)
            _reflector_matrix(v, beta, 2, W)
            _chase(A, Q, W, lo, 2, lo, hi, want_t, want_q, C, v, tmp)
            its += 1
            splits += 1
            continue
        _shift_vector(A, scale, lo, hi, its, R, v)
        for r in range(lo, hi):
            b = min(3, hi - r + 1)
            if r > lo:
                for a in range(b):
                    v[a] = H[r + a, r - 1]
            beta = _house(v, b)
            _reflector_matrix(v, beta, b, W)
            _chase(A, Q, W, r, b, lo, hi, want_t, want_q, C, v, tmp)
            if r > lo:
                for a in range(1, b):
                    H[r + a, r - 1] = 0.0
        its += 1
    return 0


@njit(cache=True)
def _scaled_product(x, mant, expo):
    """``(mant, expo)`` times ``x``, renormalised: ``mant`` in [0.5, 1) so nothing overflows on the way."""
    f, e = math.frexp(mant * x)
    return f, expo + e


@njit(cache=True)
def _eigenvalues(T, re, im):
    """Eigenvalues of ``T[K-1] ... T[0]`` in periodic Schur form, block by block, into ``re``, ``im``."""
    K, m = T.shape[0], T.shape[1]
    B = np.empty((2, 2))
    j = 0
    while j < m:
        if j == m - 1 or T[K - 1, j + 1, j] == 0.0:
            mant, expo = 1.0, 0
            for k in range(K):
                mant, expo = _scaled_product(T[k, j, j], mant, expo)
            re[j] = math.ldexp(mant, expo)
            im[j] = 0.0
            j += 1
            continue
        # the 2x2 blocks multiplied, each divided by a power of two near its largest entry (exact)
        B[0, 0], B[0, 1], B[1, 0], B[1, 1] = 1.0, 0.0, 0.0, 1.0
        expo = 0
        dmant, dexpo = 1.0, 0
        for k in range(K):
            s = max(abs(T[k, j, j]), abs(T[k, j, j + 1]), abs(T[k, j + 1, j]), abs(T[k, j + 1, j + 1]))
            e = math.frexp(s)[1] if s > 0.0 else 0
            a00 = math.ldexp(T[k, j, j], -e)
            a01 = math.ldexp(T[k, j, j + 1], -e)
            a10 = math.ldexp(T[k, j + 1, j], -e)
            a11 = math.ldexp(T[k, j + 1, j + 1], -e)
            b00 = a00 * B[0, 0] + a01 * B[1, 0]
            b01 = a00 * B[0, 1] + a01 * B[1, 1]
            b10 = a10 * B[0, 0] + a11 * B[1, 0]
            b11 = a10 * B[0, 1] + a11 * B[1, 1]
            B[0, 0], B[0, 1], B[1, 0], B[1, 1] = b00, b01, b10, b11
            expo += e
            # the determinant as the product of the blocks' determinants
            dmant, dexpo = _scaled_product(a00 * a11 - a01 * a10, dmant, dexpo)
        det = math.ldexp(dmant, dexpo)  # of the scaled product
        half = 0.5 * (B[0, 0] - B[1, 1])
        mean = 0.5 * (B[0, 0] + B[1, 1])
        disc = half * half + B[0, 1] * B[1, 0]
        if disc < 0.0:
            re[j] = re[j + 1] = math.ldexp(mean, expo)
            im[j] = math.ldexp(math.sqrt(-disc), expo)
            im[j + 1] = -im[j]
        else:  # a real pair kept together: the larger from the trace, the other from the determinant
            big = mean + math.sqrt(disc) if mean >= 0.0 else mean - math.sqrt(disc)
            small = det / big if big != 0.0 else 0.0
            re[j] = math.ldexp(big, expo)
            re[j + 1] = math.ldexp(small, expo)
            im[j] = im[j + 1] = 0.0
        j += 2


# ---------------------------------------------------------------------------------------------
# the public functions
# ---------------------------------------------------------------------------------------------


def _checked(factors, max_iterations):
    """The factors as a fresh C-ordered float array (K, m, m) and the sweep cap, or ValueError."""
    try:
        arr = np.asarray(factors)
    except (TypeError, ValueError) as exc:  # ragged nesting
        raise ValueError(f"factors: expected an array of shape (K, m, m): {exc}") from None
    if arr.ndim != 3 or arr.shape[0] < 1 or arr.shape[1] < 1 or arr.shape[1] != arr.shape[2]:
        raise ValueError(f"factors: expected shape (K, m, m) with K >= 1 and m >= 1, got {arr.shape}")
    if np.iscomplexobj(arr) or not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool):
        raise ValueError(f"factors: expected real numbers, got dtype {arr.dtype}")
    arr = np.array(arr, dtype=np.float64, order="C")  # a copy: the kernels work in place
    if not np.isfinite(arr).all():
        k = int(np.argwhere(~np.isfinite(arr))[0][0])
        raise ValueError(f"factors: expected finite entries, factor {k} has nan or inf")
    if max_iterations is None:
        max_iterations = _SWEEPS_PER_ORDER * max(10, arr.shape[1])
    elif isinstance(max_iterations, bool) or not isinstance(max_iterations, numbers.Integral) or max_iterations < 1:
        raise ValueError(f"max_iterations: expected a positive integer, got {max_iterations!r}")
    return arr, int(max_iterations)


def _run(arr, want_t, want_q, max_iterations):
    K, m = arr.shape[0], arr.shape[1]
    Q = np.zeros((K, m, m)) if want_q else np.zeros((1, 1, 1))
    if want_q:
        Q[:] = np.eye(m)
    _reduce(arr, Q, want_q)
    if _periodic_qr(arr, Q, want_t, want_q, max_iterations):
        raise ArithmeticError(f"periodic QR: no deflation within {max_iterations} sweeps "
                              f"({K} factors of order {m}); no eigenvalues returned")
    return Q


def periodic_schur(factors, *, max_iterations: int | None = None) -> PeriodicSchur:
    """Periodic real Schur form of ``K`` real square factors: ``Q_{k+1}^T A_k Q_k = T_k``, ``Q_K = Q_0``.

    Parameters
    ----------
    factors : array_like, shape (K, m, m)
        Real factors ``A_0, ..., A_{K-1}`` of the product ``A_{K-1} ... A_0``.
    max_iterations : int, optional
        QR sweeps allowed without a deflation; default ``30 max(10, m)``.

    Returns
    -------
    PeriodicSchur
        ``q`` orthogonal, ``t`` with ``T_0 ... T_{K-2}`` upper triangular and
        ``T_{K-1}`` quasi-triangular: ``Q_0^T (A_{K-1} ... A_0) Q_0`` is the
        real Schur form ``T_{K-1} ... T_0``.

    Raises
    ------
    ValueError
        ``factors`` not of shape (K, m, m), not real, or not finite;
        ``max_iterations`` not a positive integer.
    ArithmeticError
        The QR iteration does not converge.
    """
    arr, cap = _checked(factors, max_iterations)
    Q = _run(arr, True, True, cap)
    return PeriodicSchur(Q, arr)


def periodic_eigenvalues(factors, *, max_iterations: int | None = None) -> np.ndarray:
    """Eigenvalues of ``A_{K-1} ... A_0`` from the factors, the product never formed.

    Each eigenvalue keeps its relative accuracy however widely the moduli
    are spread (the small multipliers of a strongly unstable orbit), where
    ``np.linalg.eigvals`` of the product resolves them only to
    ``eps ||P||``.

    Parameters
    ----------
    factors : array_like, shape (K, m, m)
        Real factors ``A_0, ..., A_{K-1}`` (``factors[0]`` acts first).
    max_iterations : int, optional
        QR sweeps allowed without a deflation; default ``30 max(10, m)``.

    Returns
    -------
    ndarray of complex, shape (m,)
        The eigenvalues by decreasing modulus; a complex pair adjacent,
        positive imaginary part first.

    Raises
    ------
    ValueError
        ``factors`` not of shape (K, m, m), not real, or not finite;
        ``max_iterations`` not a positive integer.
    ArithmeticError
        The QR iteration does not converge.
    """
    arr, cap = _checked(factors, max_iterations)
    _run(arr, False, False, cap)
    m = arr.shape[1]
    re, im = np.empty(m), np.empty(m)
    _eigenvalues(arr, re, im)
    lam = re + 1j * im
    return lam[np.lexsort((-im, -np.abs(lam)))]


def product_eigenvalues(factors: np.ndarray) -> np.ndarray:
    """Eigenvalues of the product of ``factors`` (K, m, m) by :func:`periodic_eigenvalues`, shape (m,).

    Where its QR iteration does not deflate (rare: seen once on the finite-element rig, 8 factors of order 24),
    the factors are merged pairwise and tried again, down to one factor (the monodromy itself, whose
    eigenvalues LAPACK computes); each merge
    costs accuracy only in multipliers smaller than ``eps`` times the merged factors' norm.
    """
    f = np.asarray(factors, dtype=float)
    while True:
        if f.shape[0] == 1:
            mu = np.linalg.eigvals(f[0])
            return mu[np.lexsort((-mu.imag, -np.abs(mu)))]
        try:
            return periodic_eigenvalues(f)
        except ArithmeticError:
            pass
        k = f.shape[0]
        merged = [f[i + 1] @ f[i] for i in range(0, k - 1, 2)] + ([f[-1]] if k % 2 else [])
        f = np.asarray(merged)
