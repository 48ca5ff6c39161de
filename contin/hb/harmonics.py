"""Ordering of harmonic coefficients: the one place where it is defined.

A periodic solution of period ``T = 2*pi*nu/w`` is written in the base phase
``theta = w*t/nu`` (so the excitation phase is ``tau = nu*theta``) as

    x_i(theta) = a_{0,i} + sum_{k=1..H} ( a_{k,i} cos(k theta) + b_{k,i} sin(k theta) )

for every degree of freedom ``i = 0..n-1``. The unknown vector ``u`` of the
harmonic-balance problem has ``n*(2H+1)`` entries, harmonic-major:

=====================  ===========================  ====================
block (rows of ``U``)  entries of ``u``              meaning
=====================  ===========================  ====================
0                      ``u[0 : n]``                 mean ``a_0``
2k-1  (k = 1..H)       ``u[(2k-1)n : 2k n]``        cosine ``a_k``
2k    (k = 1..H)       ``u[2k n : (2k+1) n]``       sine ``b_k``
=====================  ===========================  ====================

so ``u.reshape(2H+1, n)`` gives the matrix ``U`` whose row ``r`` is one
coefficient block. Harmonic ``k`` of the base frequency ``w/nu`` is harmonic
``k/nu`` of the excitation frequency ``w``; for ``nu = 2`` the odd ``k`` are
the half-order (subharmonic) components. The same ordering is used for the
residual (the Fourier coefficients of the force balance) and for every
coefficient-space matrix (Jacobians, Hill matrices).

Time samples are ``theta_j = 2*pi*j/N``, ``j = 0..N-1``.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "n_coefficients",
    "index",
    "coefficient_blocks",
    "derivative_coefficients",
    "harmonic_amplitudes",
    "default_samples",
    "sample_phases",
    "embed",
]


def n_coefficients(n_dof: int, harmonics: int) -> int:
    """Length ``n*(2H+1)`` of the unknown vector."""
    return n_dof * (2 * harmonics + 1)


def index(dof: int, k: int, kind: str, n_dof: int) -> int:
    """Position in ``u`` of one coefficient.

    Parameters
    ----------
    dof : int
        Degree of freedom, ``0 <= dof < n_dof``.
    k : int
        Harmonic number (0 for the mean).
    kind : {'c', 's'}
        Cosine (also the mean for ``k = 0``) or sine.
    n_dof : int
        Number of degrees of freedom.
    """
    if k == 0:
        if kind != "c":
            raise ValueError("the mean (k = 0) has only a cosine ('c') coefficient")
        return dof
    row = 2 * k - 1 if kind == "c" else 2 * k
    return row * n_dof + dof


def coefficient_blocks(u: np.ndarray, n_dof: int) -> np.ndarray:
    """View ``u`` as the ``(2H+1, n)`` matrix ``U`` of the ordering table."""
    return np.asarray(u).reshape(-1, n_dof)


def derivative_coefficients(U: np.ndarray) -> np.ndarray:
    """Coefficients of ``d/dtheta`` of the series ``U`` (shape (2H+1, n)), same shape."""
    U = np.asarray(U)
    out = np.zeros_like(U, dtype=float)
    k = np.arange(1, (U.shape[0] - 1) // 2 + 1)[:, None]
    out[1::2] = k * U[2::2]
    out[2::2] = -k * U[1::2]
    return out


def harmonic_amplitudes(u: np.ndarray, n_dof: int) -> np.ndarray:
    """Amplitudes ``sqrt(a_k^2 + b_k^2)`` (``|a_0|`` for k = 0).

    Returns
    -------
    ndarray, shape (H+1, n)
    """
    U = coefficient_blocks(u, n_dof)
    amp = np.empty(((U.shape[0] + 1) // 2, n_dof))
    amp[0] = np.abs(U[0])
    amp[1:] = np.hypot(U[1::2], U[2::2])
    return amp


def default_samples(harmonics: int, degree: int | None) -> int:
    """Smallest AFT sample count that is exact for a polynomial force.

    A polynomial of degree ``d`` in ``x`` and ``x'`` has harmonics up to
    ``d*H``; its projection on ``cos(k theta)``, ``k <= H``, involves
    frequencies up to ``(d+1)*H``, which the discrete sum over ``N`` samples
    integrates exactly when ``N > (d+1)*H``. Hence ``N = (d+1)*H + 1``
    (``4H+1`` for a cubic). Non-polynomial forces (``degree=None``) get
    ``max(64, 16*H)`` rounded up to an even number, a starting point that the
    ``convergence`` analysis refines.
    """
    if degree is None:
        n = max(64, 16 * harmonics)
        return n + (n % 2)
    return max((max(degree, 1) + 1) * harmonics + 1, 2 * harmonics + 1, 1)


def sample_phases(samples: int) -> np.ndarray:
    """Base phases ``theta_j = 2 pi j / N``, shape (N,)."""
    return 2.0 * np.pi * np.arange(samples) / samples


def embed(u: np.ndarray, n_dof: int, factor: int, harmonics: int | None = None) -> np.ndarray:
    """Re-express a solution of order ``nu`` in the order ``factor*nu``.

    Harmonic ``k`` of base frequency ``w/nu`` is harmonic ``factor*k`` of
    ``w/(factor*nu)``; the other coefficients are zero.

    Parameters
    ----------
    u : ndarray, shape (n*(2H+1),)
    n_dof : int
    factor : int
        Ratio of the new order to the old one (2 for period doubling).
    harmonics : int, optional
        Harmonic count of the new representation (default ``factor*H``).
        Harmonics beyond it are dropped.
    """
    U = coefficient_blocks(u, n_dof)
    H = (U.shape[0] - 1) // 2
    H_new = factor * H if harmonics is None else harmonics
    V = np.zeros((2 * H_new + 1, n_dof))
    V[0] = U[0]
    for k in range(1, H + 1):
        kk = factor * k
        if kk > H_new:
            break
        V[2 * kk - 1] = U[2 * k - 1]
        V[2 * kk] = U[2 * k]
    return V.reshape(-1)
