"""The products behind an invariant circle's Lyapunov exponents, compiled.

:func:`contin.timedomain.invariant_circle.circle_lyapunov` carries a basis
of the circle's normal space along the circle, period after period, with the
map's Jacobian ``DP(theta)`` given as a trigonometric polynomial in the
circle's angle. Thousands of periods of small products: one loop in numba,
the polynomial evaluated by the angle-addition recurrence and the basis
orthonormalised by modified Gram-Schmidt, twice ("twice is enough": Giraud,
Langou & Rozloznik, *Comput. Math. Appl.* 50 (2005) 1069), instead of a
numpy call per period.
"""

from __future__ import annotations

import math

import numpy as np

from contin.util.jit import njit

__all__ = ["fourier_rows", "normal_products"]


def fourier_rows(samples) -> np.ndarray:
    """The trigonometric interpolant of ``K`` samples at ``2 pi j / K`` as rows ``(a_0, a_1, b_1, ..., )``.

    Parameters
    ----------
    samples : array_like, shape (K, ...)

    Returns
    -------
    ndarray, shape (2 (K // 2) + 1, ...)
        ``f(theta) = a_0 + sum_k a_k cos(k theta) + b_k sin(k theta)``; for an even ``K`` the last cosine's
        coefficient is halved and its sine is zero, so the polynomial passes through the samples.
    """
    X = np.asarray(samples, dtype=float)
    K = len(X)
    c = np.fft.rfft(X, axis=0) / K
    top = K // 2
    out = np.zeros((2 * top + 1,) + X.shape[1:])
    out[0] = c[0].real
    for k in range(1, top + 1):
        scale = 1.0 if (K % 2 == 0 and k == top) else 2.0
        out[2 * k - 1] = scale * c[k].real
        out[2 * k] = -scale * c[k].imag
    return out


@njit(cache=True)
def normal_products(rows, theta, tangents, Q, sums):
    """Carry the normal basis ``Q`` (m, m - 1) along the circle; returns the tangential logarithms' sum.

    ``rows`` (2 k + 1, m, m): ``DP`` as :func:`fourier_rows`; ``theta`` (L + 1,) the angles and ``tangents``
    (L + 1, m) the unit tangents there. Over each period ``i``: ``log |DP t_i|`` to the tangential sum;
    ``A = DP Q`` with its component along ``t_{i+1}`` removed, orthonormalised (``Q`` replaced), the
    logarithms of its ``|R_jj|`` added to ``sums`` (m - 1,).
    """
    L = theta.size - 1
    m = Q.shape[0]
    top = (rows.shape[0] - 1) // 2
    P = np.empty((m, m))
    A = np.empty((m, m - 1))
    tangential = 0.0
    for i in range(L):
        c1, s1 = math.cos(theta[i]), math.sin(theta[i])
        ck, sk = 1.0, 0.0
        P[:, :] = rows[0]
        for k in range(1, top + 1):
            ck, sk = ck * c1 - sk * s1, sk * c1 + ck * s1
            P += ck * rows[2 * k - 1] + sk * rows[2 * k]
        image = P @ tangents[i]
        tangential += math.log(math.sqrt(np.sum(image * image)))
        A[:, :] = P @ Q
        t = tangents[i + 1]
        for j in range(m - 1):
            d = np.sum(t * A[:, j])
            A[:, j] -= d * t
        for j in range(m - 1):
            for _ in range(2):
                for l in range(j):
                    d = np.sum(A[:, l] * A[:, j])
                    A[:, j] -= d * A[:, l]
            norm = math.sqrt(np.sum(A[:, j] * A[:, j]))
            sums[j] += math.log(norm)
            A[:, j] /= norm
        Q[:, :] = A
    return tangential
