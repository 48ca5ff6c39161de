"""An invariant circle's first guess from a simulation: its sections fitted by a trigonometric polynomial.

A trajectory on a torus of a forced system, sampled once a forcing period
(its stroboscopic sections ``s_k``), visits the invariant circle at the
angles ``theta_k = theta_0 + 2 pi k rho``. With the rotation number ``rho``
known, the circle is the trigonometric polynomial of degree ``K`` that
fits the sections at those angles by least squares; ``rho`` is the one
whose fit is best. Its first estimate is the mean turn of the sections
about their centre in the plane of their two leading principal
directions (the circle seen from its widest side); the fit's residual is
then minimised over ``rho`` in a window of ``1 / len(sections)`` about it,
the resolution the record itself gives.

The fit's relative residual says how far the sections are from a circle of
that degree: a transient not yet settled, a motion that is not
quasi-periodic, or a circle with corners (contact arcs that open along it)
that needs more points.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.optimize import minimize_scalar

__all__ = ["CircleFit", "fit_circle"]


@dataclasses.dataclass(frozen=True)
class CircleFit:
    """The circle fitted to a record of sections (:func:`fit_circle`).

    Attributes
    ----------
    points : ndarray, shape (N, 2n)
        The fitted circle at ``theta_j = 2 pi j / N``.
    rho : float
        The rotation number, in ``[0, 1)``.
    misfit : float
        The fit's residual relative to the sections' spread about their mean (RMS over RMS).
    """

    points: np.ndarray
    rho: float
    misfit: float


def _design(theta, degree: int) -> np.ndarray:
    cols = [np.ones_like(theta)]
    for k in range(1, degree + 1):
        cols += [np.cos(k * theta), np.sin(k * theta)]
    return np.array(cols).T


def fit_circle(sections, points: int) -> CircleFit:
    """Fit the invariant circle of ``points`` (odd) points to a trajectory's sections (module docstring).

    Parameters
    ----------
    sections : array_like, shape (K, 2n)
        The states at ``t = t_0 + k T``, ``k = 0 .. K - 1``, after the transient; ``K`` at least ``2 points``.
    points : int
        ``N``, odd: the fit's degree is ``(N - 1) / 2``.

    Returns
    -------
    CircleFit

    Raises
    ------
    ValueError
        For too few sections, an even ``points``, or sections that do not turn about their centre.
    """
    S = np.asarray(sections, dtype=float)
    if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < 3 or points % 2 == 0:
        raise ValueError(f"points: expected an odd integer >= 3, got {points!r}")
    if S.ndim != 2 or len(S) < 2 * points:
        raise ValueError(f"sections: expected at least {2 * points} states (2 per point of the circle), "
                         f"got shape {S.shape}")
    degree = (points - 1) // 2
    X = S - S.mean(axis=0)
    spread = float(np.linalg.norm(X))
    if spread == 0.0:
        raise ValueError("sections: all alike (a periodic orbit, not a torus)")
    P = X @ np.linalg.svd(X, full_matrices=False)[2][:2].T
    turns = np.diff(np.unwrap(np.arctan2(P[:, 1], P[:, 0]))) / (2.0 * math.pi)
    rho0 = float(np.mean(turns)) % 1.0
    k = np.arange(len(S))

    def misfit(rho):
        A = _design(2.0 * math.pi * ((k * rho) % 1.0), degree)
        coef = np.linalg.lstsq(A, S, rcond=None)[0]
        return float(np.linalg.norm(A @ coef - S)) / spread, coef

    half = 1.0 / len(S)
    best = minimize_scalar(lambda r: misfit(r)[0], bounds=(rho0 - half, rho0 + half), method="bounded",
                           options={"xatol": 1e-14})
    rho = float(best.x) % 1.0
    rel, coef = misfit(rho)
    U = _design(2.0 * math.pi * np.arange(points) / points, degree) @ coef
    return CircleFit(U, rho, rel)
