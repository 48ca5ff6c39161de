"""The linear part of the harmonic-balance residual: the block-diagonal operator ``A(Omega)``, compiled with numba.

With the coefficient layout of :mod:`contin.hb.harmonics` (``U`` of shape
``(2H+1, n)``, rows ``a_0, a_1, b_1, ..., a_H, b_H``), the linear terms
``M x'' + C x' + K x`` of a solution with base frequency ``Omega`` act on each
harmonic separately: ``K`` on the mean and, for harmonic ``k``,

    [ K - (k Omega)^2 M     k Omega C        ]  acting on (a_k, b_k).
    [ -k Omega C            K - (k Omega)^2 M ]

The kernels take ``Omega`` as a float; the harmonic-balance problem computes
it once per evaluation (:meth:`contin.hb.problem.HarmonicBalance.base_frequency`).
:class:`LinearTerms` gives ``M``, ``C``, ``K`` as the continuation parameter moves.
"""

from __future__ import annotations

import numpy as np

from contin.util.jit import njit

__all__ = ["linear_operator", "linear_apply", "linear_apply_dOmega", "split_operator", "LinearTerms"]


@njit(cache=True)
def linear_operator(M, C, K, Omega, H, out, dOmega_only):
    """Fill the block-diagonal linear operator ``A`` (or ``dA/dOmega``).

    Parameters
    ----------
    M, C, K : ndarray, shape (n, n)
    Omega : float
    H : int
    out : ndarray, shape (n(2H+1), n(2H+1)), overwritten on the diagonal blocks
        (added to, so pass zeros).
    dOmega_only : bool
        If True, fill ``dA/dOmega`` instead of ``A``.
    """
    n = M.shape[0]
    for a in range(n):
        for b in range(n):
            if not dOmega_only:
                out[a, b] += K[a, b]
            for k in range(1, H + 1):
                rc = (2 * k - 1) * n
                rs = 2 * k * n
                if dOmega_only:
                    diag = -2.0 * k * k * Omega * M[a, b]
                    off = k * C[a, b]
                else:
                    diag = K[a, b] - (k * Omega) ** 2 * M[a, b]
                    off = k * Omega * C[a, b]
                out[rc + a, rc + b] += diag
                out[rs + a, rs + b] += diag
                out[rc + a, rs + b] += off
                out[rs + a, rc + b] -= off


@njit(cache=True)
def linear_apply(M, C, K, Omega, U):
    """``A(Omega; M, C, K) u`` block by block, shape (2H+1, n), without the dense ``A``.

    Written as loops rather than matrix products: the blocks are n x n with
    small n, and numba's ``@`` pulls in its BLAS bindings, seconds of
    compilation on a cold cache for no gain at these sizes.
    """
    n = M.shape[0]
    H = (U.shape[0] - 1) // 2
    res = np.zeros((2 * H + 1, n))
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += K[i, j] * U[0, j]
        res[0, i] = s
    for k in range(1, H + 1):
        kO = k * Omega
        for i in range(n):
            sa = 0.0
            sb = 0.0
            for j in range(n):
                d = K[i, j] - kO * kO * M[i, j]
                g = kO * C[i, j]
                a = U[2 * k - 1, j]
                b = U[2 * k, j]
                sa += d * a + g * b
                sb += d * b - g * a
            res[2 * k - 1, i] = sa
            res[2 * k, i] = sb
    return res


@njit(cache=True)
def linear_apply_dOmega(M, C, Omega, U):
    """``(dA/dOmega) u`` block by block, shape (2H+1, n): ``-2 k^2 Omega M`` on the diagonal, ``k C`` off it.

    That is ``A`` at ``Omega = 1`` with ``M -> 2 Omega M`` and ``K -> 0``.
    """
    return linear_apply(2.0 * Omega * M, C, np.zeros_like(M), 1.0, U)


def split_operator(M, C, K, H: int):
    """``A = A0 + Omega A1 + Omega^2 A2`` (the operator is quadratic in ``Omega``): the parts from ``K``, ``C``, ``M``.

    Returns
    -------
    A0, A1, A2 : ndarray, shape (n(2H+1), n(2H+1))
    """
    Z = np.zeros_like(M)
    size = M.shape[0] * (2 * H + 1)
    parts = []
    for Mi, Ci, Ki in ((Z, Z, K), (Z, C, Z), (M, Z, Z)):
        A = np.zeros((size, size))
        linear_operator(Mi, Ci, Ki, 1.0, H, A, False)
        parts.append(A)
    return tuple(parts)


class LinearTerms:
    """``M``, ``C``, ``K`` of a model as parameter ``k`` (the continuation parameter) moves.

    Only ``p[k]`` changes during a run: the terms of ``M``, ``C``, ``K`` that do
    not depend on it are summed once, and the few that do (the gyroscopic
    ``ip*w`` of the rotor) are kept for each evaluation.

    Parameters
    ----------
    model : Model
    k : int
        Index of the continuation parameter.
    p0 : ndarray
        The parameter vector (its entry ``k`` is replaced at each evaluation).

    Attributes
    ----------
    depends : bool
        Whether any of ``M``, ``C``, ``K`` depends on ``p[k]``.
    """

    def __init__(self, model, k: int, p0: np.ndarray):
        self.k = k
        mats = (model.mass, model.damping, model.stiffness)
        self.depends = any(mono.depends_on(k) for mat in mats for mono, _ in mat.terms)
        self._at_p0 = model.linear(p0)
        n = model.n_dof
        self._fixed, self._terms = [], []
        for mat in mats:
            fixed = np.zeros((n, n))
            for mono, A in mat.terms:
                if not mono.depends_on(k):
                    fixed += mono.value(p0) * A
            self._fixed.append(fixed)
            self._terms.append([(mono, A) for mono, A in mat.terms if mono.depends_on(k)])

    def at(self, p: np.ndarray):
        """``(M, C, K)`` at ``p`` (``p0`` with its entry ``k`` changed), each (n, n)."""
        if not self.depends:
            return self._at_p0
        out = []
        for fixed, terms in zip(self._fixed, self._terms):
            mat = fixed.copy()
            for mono, A in terms:
                mat += mono.value(p) * A
            out.append(mat)
        return tuple(out)

    def dp(self, p: np.ndarray):
        """``d(M, C, K)/dp_k`` at ``p`` (only the terms that depend on ``p[k]``), each (n, n)."""
        out = []
        for fixed, terms in zip(self._fixed, self._terms):
            mat = np.zeros_like(fixed)
            for mono, A in terms:
                mat += mono.derivative(p, self.k) * A
            out.append(mat)
        return tuple(out)
