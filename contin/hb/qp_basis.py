"""Ordering of the coefficients of a quasi-periodic solution: the one place where it is defined.

A solution with two base frequencies, ``Omega1 = w/nu`` (the forcing's, in
the phase ``theta1 = w t / nu``, so the excitation phase is
``tau = nu theta1``) and an unknown second frequency ``w2`` (the
self-excited one, phase ``theta2 = w2 t``), lives on a two-torus:

    x_i(theta1, theta2) = a_{0,i} + sum_{j=1..P-1} ( a_{j,i} cos(k1_j theta1 + k2_j theta2)
                                                    + b_{j,i} sin(k1_j theta1 + k2_j theta2) )

over the harmonic pairs ``(k1, k2)`` of the box truncation ``0 <= k1 <= H1``,
``|k2| <= H2`` with one pair of each sign pair ``+-(k1, k2)`` kept:

==================  =======================================  =============================
pair ``j``          ``(k1, k2)``                             frequency ``k1 Omega1 + k2 w2``
==================  =======================================  =============================
0                   ``(0, 0)``                               the mean (cosine only)
1 .. H2             ``(0, k2)``, ``k2 = 1..H2``              the self-excited harmonics
then, by ``k1``     ``(k1, k2)``, ``k1 = 1..H1``,            forced harmonics (``k2 = 0``)
                    ``k2 = -H2..H2``                         and combinations
==================  =======================================  =============================

so ``P = 1 + H2 + H1 (2 H2 + 1)``. The coefficient matrix ``U`` has
``2P - 1`` rows laid out as in the periodic table of
:mod:`contin.hb.harmonics` with "harmonic ``k``" read as "pair ``j``": row 0
the mean, row ``2j - 1`` the cosine and row ``2j`` the sine of pair ``j``;
``u = U.ravel()`` (pair-major, the ``n`` dofs within a row). With
``H2 = 0`` the table is the periodic one. Time samples form the grid
``theta1_i = 2 pi i / N1``, ``theta2_l = 2 pi l / N2``, flattened with
``theta2`` major: sample ``s = l N1 + i``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["QPBasis"]


class QPBasis:
    """The harmonic pairs of the box truncation ``(H1, H2)``.

    Parameters
    ----------
    H1, H2 : int
        Harmonics of the first (forcing) and second (self-excited) base
        frequency, ``H1 >= 1``, ``H2 >= 1``.

    Attributes
    ----------
    pairs : ndarray of int, shape (P, 2)
        ``(k1, k2)`` of each pair, in the order of the table above.
    P : int
    rows : int
        ``2P - 1``, rows of ``U``.
    """

    def __init__(self, H1: int, H2: int):
        for name, v in (("H1", H1), ("H2", H2)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"QPBasis: {name} must be an integer >= 1, got {v!r}")
        self.H1, self.H2 = int(H1), int(H2)
        pairs = [(0, 0)] + [(0, k2) for k2 in range(1, H2 + 1)]
        pairs += [(k1, k2) for k1 in range(1, H1 + 1) for k2 in range(-H2, H2 + 1)]
        self.pairs = np.array(pairs, dtype=np.int64)
        self.P = len(pairs)
        self.rows = 2 * self.P - 1
        self._where = {p: j for j, p in enumerate(pairs)}

    def pair(self, k1: int, k2: int) -> tuple[int, int]:
        """``(j, sign)``: the pair index holding ``(k1, k2)``, and ``-1`` when it is stored as ``(-k1, -k2)``
        (then its sine coefficient changes sign)."""
        if (k1, k2) in self._where:
            return self._where[(k1, k2)], 1
        if (-k1, -k2) in self._where:
            return self._where[(-k1, -k2)], -1
        raise KeyError(f"the pair ({k1}, {k2}) is not in the truncation H1={self.H1}, H2={self.H2}")

    def frequencies(self, Omega1: float, w2: float) -> np.ndarray:
        """``k1 Omega1 + k2 w2`` of every pair, shape (P,)."""
        return self.pairs[:, 0] * Omega1 + self.pairs[:, 1] * w2

    def min_samples(self) -> tuple[int, int]:
        """Smallest grid ``(N1, N2)`` resolving every pair: ``(2 H1 + 1, 2 H2 + 1)``."""
        return 2 * self.H1 + 1, 2 * self.H2 + 1

    def embed_periodic(self, u: np.ndarray, n: int) -> np.ndarray:
        """A periodic solution (rows of :mod:`contin.hb.harmonics`, ``H`` harmonics of ``Omega1``) as pairs
        ``(k, 0)``; harmonics beyond ``H1`` are dropped. Shape (rows n,)."""
        U = np.asarray(u, dtype=float).reshape(-1, n)
        H = (U.shape[0] - 1) // 2
        out = np.zeros((self.rows, n))
        out[0] = U[0]
        for k in range(1, min(H, self.H1) + 1):
            j = self._where[(k, 0)]
            out[2 * j - 1] = U[2 * k - 1]
            out[2 * j] = U[2 * k]
        return out.reshape(-1)

    def periodic_part(self, U: np.ndarray) -> np.ndarray:
        """The pairs ``(k, 0)`` of ``U`` (shape (rows, n)) as a periodic series of ``H1`` harmonics,
        shape (2 H1 + 1, n)."""
        out = np.zeros((2 * self.H1 + 1, U.shape[1]))
        out[0] = U[0]
        for k in range(1, self.H1 + 1):
            j = self._where[(k, 0)]
            out[2 * k - 1], out[2 * k] = U[2 * j - 1], U[2 * j]
        return out

    def amplitudes(self, U: np.ndarray) -> np.ndarray:
        """``sqrt(a_j^2 + b_j^2)`` of every pair (``|a_0|`` for the mean), shape (P, n)."""
        amp = np.empty((self.P, U.shape[1]))
        amp[0] = np.abs(U[0])
        amp[1:] = np.hypot(U[1::2], U[2::2])
        return amp

    def whirl(self, U: np.ndarray, j: int, w1: float, w2: float, dx: int, dy: int) -> tuple[float, float]:
        """Forward and backward whirl radii of the pair ``j`` in the plane of dofs ``(dx, dy)``.

        ``z = x + i y`` holds ``c+ e^{i phi} + c- e^{-i phi}`` with ``phi``
        the pair's phase; the forward radius is that of the term turning
        with positive frequency (``|c+|`` if the pair's frequency
        ``k1 w1 + k2 w2`` is positive, ``|c-|`` otherwise).
        """
        ax, bx = U[2 * j - 1, dx], U[2 * j, dx]
        ay, by = U[2 * j - 1, dy], U[2 * j, dy]
        plus = 0.5 * np.hypot(ax + by, ay - bx)
        minus = 0.5 * np.hypot(ax - by, ay + bx)
        f = self.pairs[j, 0] * w1 + self.pairs[j, 1] * w2
        return (plus, minus) if f >= 0 else (minus, plus)
