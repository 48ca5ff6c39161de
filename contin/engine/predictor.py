"""Predictions along a branch: tangents, their orientation, and guesses for the corrector.

In scaled coordinates ``x = (u / su, lam / sl)``, shape (m+1,):

- the tangent at a converged point solves ``[[Ju su, Jlam sl], [t_ref^T]] z = e_last``
  (:func:`unit_tangent`, with the factorisation the corrector made anyway);
  ``t_ref`` is the previous tangent, so ``t . t_ref > 0`` and the orientation
  is kept through folds;
- at the start it is the null vector of ``[Ju su, Jlam sl]`` (:func:`initial_tangent`),
  oriented by a given tangent or by the sign asked of ``dlam``;
- the Euler predictor is ``x + ds t`` (:func:`predict`); between two points,
  :class:`HermiteArc` gives the cubic through both with their tangents.
"""

from __future__ import annotations

import math

import numpy as np

from contin.engine.newton import NUMERICAL_ERRORS, LUFactor, SingularMatrixError, factorize

__all__ = ["HermiteArc", "graph_tangent", "initial_tangent", "last_unit_vector", "orient_along_secant", "predict",
           "unit_tangent"]

#: A start tangent's parameter component below this has no sign to orient by (``direction`` is then ignored),
#: unless :func:`graph_tangent` resolves it.
DIRECTION_EPS = 1e-12
#: Smallest reciprocal condition of ``Ju su`` at which :func:`graph_tangent` is trusted (its direction is then
#: accurate to ``~eps / GRAPH_RCOND``).
GRAPH_RCOND = 1e-10


def last_unit_vector(m: int) -> np.ndarray:
    """``e_last = (0, ..., 0, 1)`` of shape (m+1,): the right-hand side of the tangent's bordered system."""
    e = np.zeros(m + 1)
    e[-1] = 1.0
    return e


def unit_tangent(lu: LUFactor, e_last: np.ndarray) -> np.ndarray | None:
    """The unit tangent (m+1,) from the factorised bordered matrix, or None if it is not finite."""
    z = lu.solve(e_last)
    nz = float(np.linalg.norm(z))
    if not (math.isfinite(nz) and nz > 0):
        return None
    return z / nz


def initial_tangent(Jh: np.ndarray, given: np.ndarray | None, direction: int) -> np.ndarray | None:
    """The unit tangent at the start point, or None if the SVD fails.

    Parameters
    ----------
    Jh : ndarray, shape (m, m+1)
        The scaled Jacobian ``[Ju su, Jlam sl]``.
    given : ndarray of shape (m+1,) or None
        A tangent whose orientation is kept (its projection on the null
        space when that has more than one dimension, as at a branch point).
    direction : int
        +1 or -1: the sign of the parameter component, without ``given``.
    """
    m = Jh.shape[0]
    try:
        _, sv, vt = np.linalg.svd(Jh, full_matrices=True)
    except np.linalg.LinAlgError:
        return None
    tol = max(Jh.shape) * np.finfo(float).eps * (sv[0] if sv.size else 1.0)
    rank = int(np.count_nonzero(sv > tol))
    null = vt[rank:]  # at least one row: Jh has m+1 columns
    if given is not None:
        if null.shape[0] > 1:
            t = null.T @ (null @ given)
            t = t if np.linalg.norm(t) > 0 else null[-1]
        else:
            t = null[-1]
        t = t / np.linalg.norm(t)
        if float(t @ given) < 0:
            t = -t
        return t
    t = vt[-1].copy()
    resolved = abs(t[m]) > DIRECTION_EPS
    if not resolved:
        # the SVD gives the parameter component only to ~eps of the whole vector: where it is smaller
        # (a parameter scale far larger than the scale of the branch's changes, such as the width of a
        # range [0.5, 1e17]) its sign is rounding, and the branch could set out backwards
        graph = graph_tangent(Jh)
        if graph is not None:
            t, resolved = graph, True
    if resolved and np.sign(t[m]) != direction:
        t = -t
    return t


def graph_tangent(Jh: np.ndarray) -> np.ndarray | None:
    """The unit tangent ``(y, 1) / |(y, 1)|`` with ``Ju su y = -Jlam sl``, or None where ``Ju su`` is near singular.

    Its parameter component is positive by construction however small it
    is, so its sign is exact where the null vector's is rounding; its
    direction is as accurate as the solve (``Ju su`` of reciprocal condition
    above :data:`GRAPH_RCOND`, so not at a fold).

    Parameters
    ----------
    Jh : ndarray, shape (m, m+1)
        The scaled Jacobian ``[Ju su, Jlam sl]``.
    """
    m = Jh.shape[0]
    try:
        lu = factorize(Jh[:, :m])
        if not lu.rcond >= GRAPH_RCOND:
            return None
        y = lu.solve(-Jh[:, m])
    except (SingularMatrixError, *NUMERICAL_ERRORS):
        return None
    z = np.append(y, 1.0)
    z /= float(np.max(np.abs(z)))  # first to its largest entry: |y| may be near the overflow (a scale of 1e300)
    nz = float(np.linalg.norm(z))
    if not (math.isfinite(nz) and nz > 0):
        return None
    return z / nz


def predict(x: np.ndarray, t: np.ndarray, ds: float) -> np.ndarray:
    """The Euler predictor ``x + ds t`` (m+1,)."""
    return x + ds * t


def orient_along_secant(cand, x: np.ndarray):
    """Orient a candidate's tangent along the secant from ``x`` (m+1,); returns the candidate.

    Beyond a corner the bordered orientation (``t_new . t_old > 0``) reverses
    the tangent after a turn beyond 90 deg; the secant does not.
    """
    if float(cand.tangent @ (cand.x - x)) < 0:
        cand.tangent = -cand.tangent
    return cand


class HermiteArc:
    """The cubic Hermite curve through two points of a branch with their unit tangents.

    ``x(q) = h00(q) xa + h10(q) L ta + h01(q) xb + h11(q) L tb`` for ``q`` in
    ``[0, 1]``, ``L`` the chord length (the arclength of a nearly straight
    arc); it lies ``O(L^4)`` off a smooth branch, where the chord lies
    ``O(L^2)`` off. :meth:`at` returns its point on the hyperplane
    ``ta . (x - xa) = sigma`` used by the engine's location.

    Parameters
    ----------
    xa, ta, xb, tb : ndarray, shape (m+1,)
        End points and unit tangents (scaled coordinates, oriented along the branch).
    h : float
        ``ta . (xb - xa)``.
    """

    def __init__(self, xa, ta, xb, tb, h):
        self.xa, self.ta, self.xb, self.tb, self.h = xa, ta, xb, tb, float(h)
        self.L = float(np.linalg.norm(xb - xa))
        # sigma(q) = ta . (x(q) - xa), a cubic in q
        self._c = (self.L, self.h, self.L * float(ta @ tb))

    def _sigma(self, q):
        """``sigma(q)`` and its derivative."""
        L, hb, Ltb = self._c
        h10, h01, h11 = q ** 3 - 2 * q ** 2 + q, -2 * q ** 3 + 3 * q ** 2, q ** 3 - q ** 2
        d10, d01, d11 = 3 * q ** 2 - 4 * q + 1, -6 * q ** 2 + 6 * q, 3 * q ** 2 - 2 * q
        return h10 * L + h01 * hb + h11 * Ltb, d10 * L + d01 * hb + d11 * Ltb

    def at(self, sigma: float) -> np.ndarray:
        """The curve's point with ``ta . (x - xa) = sigma`` (the chord's if the cubic is not monotone there)."""
        q = sigma / self.h if self.h > 0 else 0.0
        for _ in range(8):
            f, df = self._sigma(q)
            if not df > 0:
                q = sigma / self.h if self.h > 0 else 0.0
                break
            dq = (sigma - f) / df
            q += dq
            if abs(dq) < 1e-14:
                break
        if not 0.0 <= q <= 1.0:
            q = min(max(sigma / self.h if self.h > 0 else 0.0, 0.0), 1.0)
        h00, h10 = 2 * q ** 3 - 3 * q ** 2 + 1, q ** 3 - 2 * q ** 2 + q
        h01, h11 = -2 * q ** 3 + 3 * q ** 2, q ** 3 - q ** 2
        return h00 * self.xa + h10 * self.L * self.ta + h01 * self.xb + h11 * self.L * self.tb

