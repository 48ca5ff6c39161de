"""Two-dimensional AFT kernels for quasi-periodic solutions, compiled with numba.

Coefficients follow :mod:`contin.hb.qp_basis` (``U`` of shape ``(2P-1, n)``
over the pairs ``(k1, k2)``); samples lie on the ``N2 x N1`` grid of
``(theta2, theta1)``, flattened to ``(N1 N2, n)``. Transforms are 2-D real
FFTs (``rfft2`` over the axes ``(theta2, theta1)``, ``theta1`` the halved
one, through ``rocket-fft``). ``N1 >= 2 H1 + 1`` and ``N2 >= 2 H2 + 1``.

The Jacobian of the projected force follows from the same product-to-sum
identities as in one dimension (:mod:`contin.hb.aft`) with vector indices,

    <G cos(k.theta) cos(l.theta)> = (C(k-l) + C(k+l))/2,   ...

``C(m), S(m)`` being the discrete averages of ``G cos(m.theta)`` and
``G sin(m.theta)`` over the grid, read from one 2-D FFT of each sampled
entry of ``G`` (aliasing included: the exact derivative of the discrete
residual). Cost ``O(n^2 (N log N + P^2))``.
"""

from __future__ import annotations

import numpy as np
import rocket_fft  # noqa: F401  (registers numpy.fft for numba)

from contin.hb.aft import product_block
from contin.util.jit import njit

__all__ = ["synthesize2", "project2", "jacobian2", "multiplication_matrix2", "linear_operator2", "linear_apply2",
           "linear_apply2_dfreq"]


@njit(cache=True)
def synthesize2(U, pairs, N1, N2):
    """Samples of ``x``, ``dx/dtheta1`` and ``dx/dtheta2`` on the grid.

    Parameters
    ----------
    U : ndarray, shape (2P-1, n)
    pairs : ndarray of int, shape (P, 2)
    N1, N2 : int

    Returns
    -------
    x, x1, x2 : ndarray, shape (N1 N2, n)
    """
    P = pairs.shape[0]
    n = U.shape[1]
    N = N1 * N2
    Z = np.zeros((N2, N1 // 2 + 1, n), dtype=np.complex128)
    Z1 = np.zeros((N2, N1 // 2 + 1, n), dtype=np.complex128)
    Z2 = np.zeros((N2, N1 // 2 + 1, n), dtype=np.complex128)
    for i in range(n):
        Z[0, 0, i] = N * U[0, i]
    for j in range(1, P):
        k1 = pairs[j, 0]
        k2 = pairs[j, 1]
        if 2 * k1 >= N1 or 2 * abs(k2) >= N2:
            raise ValueError("synthesize2 needs N1 >= 2 H1 + 1 and N2 >= 2 H2 + 1")
        r = k2 % N2
        for i in range(n):
            c = 0.5 * N * (U[2 * j - 1, i] - 1j * U[2 * j, i])
            Z[r, k1, i] += c
            Z1[r, k1, i] += 1j * k1 * c
            Z2[r, k1, i] += 1j * k2 * c
            if k1 == 0:  # the theta1-constant column must be Hermitian in k2 for irfft2
                Z[N2 - r, 0, i] += np.conj(c)
                Z2[N2 - r, 0, i] += np.conj(1j * k2 * c)
    x = np.fft.irfft2(Z, s=(N2, N1), axes=(0, 1))
    x1 = np.fft.irfft2(Z1, s=(N2, N1), axes=(0, 1))
    x2 = np.fft.irfft2(Z2, s=(N2, N1), axes=(0, 1))
    return x.reshape(N, n), x1.reshape(N, n), x2.reshape(N, n)


@njit(cache=True)
def project2(f, pairs, N1, N2):
    """Coefficients of sampled values (the discrete Galerkin projection), shape (2P-1, n).

    Parameters
    ----------
    f : ndarray, shape (N1 N2, n)
    pairs : ndarray of int, shape (P, 2)
    N1, N2 : int
    """
    P = pairs.shape[0]
    n = f.shape[1]
    N = N1 * N2
    F = np.fft.rfft2(np.ascontiguousarray(f).reshape(N2, N1, n), axes=(0, 1))
    out = np.empty((2 * P - 1, n))
    for i in range(n):
        out[0, i] = F[0, 0, i].real / N
    for j in range(1, P):
        r = pairs[j, 1] % N2
        k1 = pairs[j, 0]
        for i in range(n):
            z = F[r, k1, i]
            out[2 * j - 1, i] = 2.0 * z.real / N
            out[2 * j, i] = -2.0 * z.imag / N
    return out


@njit(cache=True)
def _cs2(Ghat, m1, m2, N1, N2):
    """``C(m), S(m)`` of a real field from its ``rfft2`` (shape (N2, N1//2+1)), folded for aliasing."""
    N = N1 * N2
    a = m1 % N1
    if a <= N1 // 2:
        z = Ghat[m2 % N2, a]
        return z.real / N, -z.imag / N
    z = Ghat[(-m2) % N2, N1 - a]
    return z.real / N, z.imag / N


@njit(cache=True)
def _cs_table(Ghat, pairs, N1, N2):
    """``C(m), S(m)`` for every ``m = k -+ l`` of two pairs, as tables indexed ``[m1 + 2 H1, m2 + 2 H2]``."""
    H1 = 0
    H2 = 0
    for j in range(pairs.shape[0]):
        H1 = max(H1, pairs[j, 0])
        H2 = max(H2, abs(pairs[j, 1]))
    C = np.empty((4 * H1 + 1, 4 * H2 + 1))
    S = np.empty((4 * H1 + 1, 4 * H2 + 1))
    for a in range(4 * H1 + 1):
        for b in range(4 * H2 + 1):
            C[a, b], S[a, b] = _cs2(Ghat, a - 2 * H1, b - 2 * H2, N1, N2)
    return C, S, 2 * H1, 2 * H2


@njit(cache=True)
def _fill_block2(Ghat, pairs, N1, N2, n, a, b, T, scale, freqs, velocity):
    # Block of "multiply by G_ab" between dof a (rows) and dof b (columns); with velocity, the
    # columns of pair l act through d/dt: (a_l, b_l) <- f_l (-b_l, a_l) with f_l = freqs[l].
    P = pairs.shape[0]
    C, S, o1, o2 = _cs_table(Ghat, pairs, N1, N2)
    for k in range(P):
        wk = scale if k == 0 else 2.0 * scale
        rc = (0 if k == 0 else 2 * k - 1) * n + a
        rs = 2 * k * n + a
        k1 = pairs[k, 0]
        k2 = pairs[k, 1]
        for l in range(P):
            if velocity and l == 0:
                continue
            d1 = k1 - pairs[l, 0] + o1
            d2 = k2 - pairs[l, 1] + o2
            s1 = k1 + pairs[l, 0] + o1
            s2 = k2 + pairs[l, 1] + o2
            Cm, Sm = C[d1, d2], S[d1, d2]
            Cp, Sp = C[s1, s2], S[s1, s2]
            cc = (0 if l == 0 else 2 * l - 1) * n + b
            cs = 2 * l * n + b
            if velocity:
                s = 0.5 * wk * freqs[l]
                T[rc, cc] -= s * (Sp - Sm)
                T[rc, cs] += s * (Cm + Cp)
                if k > 0:
                    T[rs, cc] -= s * (Cm - Cp)
                    T[rs, cs] += s * (Sp + Sm)
                continue
            product_block(T, rc, rs, cc, cs, k > 0, l > 0, 0.5 * wk, Cm, Sm, Cp, Sp)


@njit(cache=True)
def multiplication_matrix2(G, pairs, N1, N2, T, scale):
    """Accumulate ``T += scale * [v -> proj(G v)]`` for a sampled matrix field ``G`` of shape (N1 N2, n, n)."""
    n = G.shape[1]
    freqs = np.zeros(pairs.shape[0])
    for a in range(n):
        for b in range(n):
            g = np.ascontiguousarray(G[:, a, b])
            if np.max(np.abs(g)) == 0.0:
                continue
            Ghat = np.fft.rfft2(g.reshape(N2, N1))
            _fill_block2(Ghat, pairs, N1, N2, n, a, b, T, scale, freqs, False)


@njit(cache=True)
def jacobian2(dfdx, dfdxd, pairs, freqs, N1, N2, J):
    """Accumulate ``d proj(f(x, xdot)) / du`` into ``J`` (shape (n(2P-1), n(2P-1))).

    ``xdot`` of pair ``l`` is ``freqs[l] (-a_l sin + b_l cos)``: the velocity
    part enters through the pairs' frequencies ``k1 Omega1 + k2 w2``.

    Parameters
    ----------
    dfdx, dfdxd : ndarray, shape (N1 N2, n, n)
    pairs : ndarray of int, shape (P, 2)
    freqs : ndarray, shape (P,)
    N1, N2 : int
    J : ndarray, accumulated in place.
    """
    N = dfdx.shape[0]
    n = dfdx.shape[1]
    g = np.empty(N)
    for a in range(n):
        for b in range(n):
            hx = False
            hv = False
            for s in range(N):
                hx = hx or dfdx[s, a, b] != 0.0
                hv = hv or dfdxd[s, a, b] != 0.0
            if hx:
                for s in range(N):
                    g[s] = dfdx[s, a, b]
                _fill_block2(np.fft.rfft2(g.reshape(N2, N1)), pairs, N1, N2, n, a, b, J, 1.0, freqs, False)
            if hv:
                for s in range(N):
                    g[s] = dfdxd[s, a, b]
                _fill_block2(np.fft.rfft2(g.reshape(N2, N1)), pairs, N1, N2, n, a, b, J, 1.0, freqs, True)


@njit(cache=True)
def linear_operator2(M, C, K, freqs, out):
    """Add the block-diagonal linear operator to ``out``: ``K`` on the mean and, for pair ``j`` of frequency
    ``f = freqs[j]``, ``[[K - f^2 M, f C], [-f C, K - f^2 M]]`` on ``(a_j, b_j)``."""
    n = M.shape[0]
    for a in range(n):
        for b in range(n):
            out[a, b] += K[a, b]
            for j in range(1, freqs.shape[0]):
                f = freqs[j]
                rc = (2 * j - 1) * n
                rs = 2 * j * n
                diag = K[a, b] - f * f * M[a, b]
                off = f * C[a, b]
                out[rc + a, rc + b] += diag
                out[rs + a, rs + b] += diag
                out[rc + a, rs + b] += off
                out[rs + a, rc + b] -= off


def linear_apply2(M, C, K, freqs, U):
    """The linear operator of :func:`linear_operator2` applied to ``U`` (shape (2P-1, n)), same shape.

    Vectorised over the pairs in numpy: ``O(n^2 P)``, no dense operator.
    """
    f = np.asarray(freqs)[1:, None]
    A, B = U[1::2], U[2::2]
    out = np.empty_like(U)
    out[0] = K @ U[0]
    out[1::2] = A @ K.T - f * f * (A @ M.T) + f * (B @ C.T)
    out[2::2] = B @ K.T - f * f * (B @ M.T) - f * (A @ C.T)
    return out


def linear_apply2_dfreq(M, C, freqs, dfreqs, U):
    """``sum_j (dA_j/df) dfreqs[j]`` applied to ``U``: the derivative of :func:`linear_apply2` when the
    frequencies move at the rates ``dfreqs`` (shape (P,)), shape (2P-1, n)."""
    f = np.asarray(freqs)[1:, None]
    d = np.asarray(dfreqs)[1:, None]
    A, B = U[1::2], U[2::2]
    out = np.zeros_like(U)
    out[1::2] = d * (-2.0 * f * (A @ M.T) + B @ C.T)
    out[2::2] = d * (-2.0 * f * (B @ M.T) - A @ C.T)
    return out
