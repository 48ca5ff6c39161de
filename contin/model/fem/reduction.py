"""Craig-Bampton reduction of a linear structure onto boundary dofs and fixed-interface modes.

With the dofs split into boundary ``b`` (kept physical: contact and forced
dofs) and interior ``i``, the basis is (Craig & Bampton, AIAA J. 6 (1968)
1313-1319)

    T = [[ I_bb,               0     ],
         [ -K_ii^-1 K_ib,      Phi_i ]],

static constraint modes plus the ``m`` lowest modes ``Phi_i`` of the interior
with the boundary held (``K_ii phi = w^2 M_ii phi``, mass-normalised). A
matrix ``A`` becomes ``T^T A T`` and coordinates ``x = T q``; the boundary
coordinates of ``q`` are the physical boundary dofs. Exact for statics and
as ``m`` grows; the error of a truncation is shown by its natural
frequencies against the full model's (docs/validation/fe-rotor.md).
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sl

__all__ = ["craig_bampton"]


def craig_bampton(M: np.ndarray, K: np.ndarray, boundary, modes: int):
    """The Craig-Bampton basis.

    Parameters
    ----------
    M, K : ndarray, shape (n, n)
        Mass and stiffness at which the basis is built (their symmetric parts
        are used for the interior modes).
    boundary : sequence of int
        Dofs kept physical, in the order they take in ``q``.
    modes : int
        Fixed-interface modes kept (``0 <= modes <= n - len(boundary)``).

    Returns
    -------
    T : ndarray, shape (n, len(boundary) + modes)
    frequencies : ndarray, shape (modes,)
        Natural frequencies of the kept interior modes [rad per time unit].

    Raises
    ------
    ValueError
        A repeated or out-of-range boundary dof, a bad mode count, or an
        interior that is not held by the boundary (``K_ii`` singular).
    """
    n = M.shape[0]
    b = np.asarray(boundary, dtype=int).reshape(-1)
    if b.size == 0 or len(set(b.tolist())) != b.size or b.min() < 0 or b.max() >= n:
        raise ValueError(f"reduction: boundary dofs must be distinct dofs in 0..{n - 1}, got {b.tolist()}")
    i = np.setdiff1d(np.arange(n), b)
    if not 0 <= int(modes) <= i.size:
        raise ValueError(f"reduction.modes: expected an integer from 0 to {i.size} (interior dofs), found {modes}")
    Ks = 0.5 * (K + K.T)
    Ms = 0.5 * (M + M.T)
    Kii = Ks[np.ix_(i, i)]
    try:
        with warnings.catch_warnings():  # a singular K_ii is reported below, in words
            warnings.simplefilter("ignore", sl.LinAlgWarning)
            lu = sl.lu_factor(Kii, check_finite=True)
        if np.min(np.abs(np.diag(lu[0]))) <= 1e-13 * np.max(np.abs(np.diag(lu[0]))):
            raise np.linalg.LinAlgError
    except (np.linalg.LinAlgError, ValueError):
        raise ValueError("reduction: the interior dofs are not held when the boundary dofs are fixed (their "
                         "stiffness is singular); add a bearing or keep more boundary dofs") from None
    T = np.zeros((n, b.size + int(modes)))
    T[b, np.arange(b.size)] = 1.0
    T[np.ix_(i, np.arange(b.size))] = -sl.lu_solve(lu, Ks[np.ix_(i, b)])
    freqs = np.zeros(0)
    if modes:
        w2, phi = sl.eigh(Kii, Ms[np.ix_(i, i)], subset_by_index=[0, int(modes) - 1])
        T[np.ix_(i, b.size + np.arange(int(modes)))] = phi
        freqs = np.sqrt(np.maximum(w2, 0.0))
    return T, freqs
