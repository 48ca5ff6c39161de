"""Crossing-resolved sampling of force laws that switch (contact onset and release).

The AFT projects ``N`` samples of the force, which is the trapezoidal rule of
the Fourier integrals. A contact law that switches on where ``h(x, x') > 0``
makes the sampled force, and so the residual, jump whenever a sample crosses
the surface ``h = 0``: by ``c v`` for a dashpot that acts only in contact (the
bearing rotor's law, Inagaki et al. 2005, eq. 3). Newton then stalls at the
size of that jump, and continuation cannot pass grazing.

Here the one sample interval ``[theta_j, theta_j+1]`` in which ``h`` changes
sign is integrated over its contact part only. The crossing ``theta*`` is the
root of ``h`` along the solution's own trigonometric series (not of an
interpolant of the samples), found by a safeguarded Newton iteration; its
place in the interval is ``t = (theta* - theta_j) / (2 pi / N)``. The law
``L`` (the force with the contact active, evaluated on both samples whatever
their side) times the Fourier weight is integrated as its linear interpolant
from the crossing to the end of the interval. That changes the two sample
values only:

=================================  ======================  =====================
interval                           sample ``j`` gets       sample ``j+1`` gets
=================================  ======================  =====================
entering (``h_j <= 0 < h_j+1``)    ``+(1 - t)^2/2 L_j``    ``-t^2/2 L_j+1``
leaving (``h_j > 0 >= h_j+1``)     ``-(1 - t)^2/2 L_j``    ``+t^2/2 L_j+1``
=================================  ======================  =====================

so the corrected samples go into the same FFT. The error of a crossing falls
from O(1/N) to O(1/N^2), and the Fourier coefficients are continuous in the
coefficients ``u``, and continuously differentiable as long as the orbit
crosses the surface transversally (the derivative with respect to the
crossing is minus the interpolant there, continuous when the crossing passes
a sample; ``theta*`` is a smooth function of ``u`` by the implicit function
theorem). At grazing itself (a tangential touch) the true Fourier
coefficients have a square-root singularity; the branch passes it as a corner.

Derivatives: ``dt/du = -(dh/dx S(theta*) + dh/dx' Omega S'(theta*)) / (dh/dtheta (2 pi/N))``
(``S`` the row of the synthesis, :mod:`contin.harmonics` ordering), so each
crossing adds a rank-one term ``P(theta_a) (x) dc_a/dt L_a (x) dt/du`` to the
Jacobian (:func:`add_crossing_jacobian`), besides ``c_a dL/dx`` on the two
samples' own derivatives.
"""

from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["switching_intervals", "series_at", "locate_crossings", "Crossings", "apply_crossings",
           "crossing_gradients", "add_crossing_jacobian", "add_crossing_dp"]


@nb.njit(cache=True)
def switching_intervals(h):
    """Sample intervals in which a law switches.

    Parameters
    ----------
    h : ndarray, shape (N, m)
        Switching functions at the samples (law ``i`` active where ``h > 0``).

    Returns
    -------
    ndarray of int, shape (K, 3)
        ``j, j+1 (mod N), i`` of each interval with a sign change.
    """
    N, m = h.shape
    count = 0
    for i in range(m):
        for j in range(N):
            j1 = j + 1 if j + 1 < N else 0
            if (h[j, i] > 0.0) != (h[j1, i] > 0.0):
                count += 1
    out = np.empty((count, 3), dtype=np.int64)
    K = 0
    for i in range(m):
        for j in range(N):
            j1 = j + 1 if j + 1 < N else 0
            if (h[j, i] > 0.0) != (h[j1, i] > 0.0):
                out[K, 0] = j
                out[K, 1] = j1
                out[K, 2] = i
                K += 1
    return out


@nb.njit(cache=True)
def series_at(U, phi):
    """The series and its first two ``theta`` derivatives at arbitrary phases.

    Parameters
    ----------
    U : ndarray, shape (2H+1, n)
    phi : ndarray, shape (K,)

    Returns
    -------
    x, x1, x2 : ndarray, shape (K, n)
    """
    R, n = U.shape
    H = (R - 1) // 2
    K = phi.shape[0]
    x = np.zeros((K, n))
    x1 = np.zeros((K, n))
    x2 = np.zeros((K, n))
    for k in range(K):
        for q in range(n):
            x[k, q] = U[0, q]
        for hh in range(1, H + 1):
            c = np.cos(hh * phi[k])
            s = np.sin(hh * phi[k])
            for q in range(n):
                a = U[2 * hh - 1, q]
                b = U[2 * hh, q]
                x[k, q] += a * c + b * s
                x1[k, q] += hh * (b * c - a * s)
                x2[k, q] -= hh * hh * (a * c + b * s)
    return x, x1, x2


class Crossings:
    """Located crossings of one element's switching surfaces.

    Attributes
    ----------
    intervals : ndarray of int, shape (K, 3)
        ``j, j+1, law``.
    sign : ndarray, shape (K,)
        +1 where the law switches on, -1 where it switches off.
    t : ndarray, shape (K,)
        Place of the crossing in its interval, in [0, 1].
    phi : ndarray, shape (K,)
        Crossing phase ``theta*``.
    gx, gxd : ndarray, shape (K, n)
        ``dh/dx``, ``dh/dx'`` at the crossing state.
    slope : ndarray, shape (K,)
        ``dh/dtheta`` at the crossing times the interval length ``2 pi/N``
        (``dh/dt`` in interval units).
    state : (ndarray, ndarray), shapes (K, n)
        ``x`` and ``x'`` at the crossings.
    dx1 : ndarray, shape (K, n)
        ``dx/dtheta`` at the crossings.
    """

    def __init__(self, intervals, sign, t, phi, gx, gxd, slope, state, dx1):
        self.intervals, self.sign, self.t, self.phi = intervals, sign, t, phi
        self.gx, self.gxd, self.slope = gx, gxd, slope
        self.state, self.dx1 = state, dx1


def locate_crossings(element, U, Omega, theta, h, p, tol=1e-13, max_iter=40) -> Crossings:
    """Roots of the element's switching functions along the series, one per switching interval.

    A Newton iteration in the interval coordinate ``t``, kept inside the
    bracket of the sign change (bisection when a step leaves it), all
    crossings at once.

    Parameters
    ----------
    element : ForceElement
        With :meth:`~contin.model.ForceElement.switching_functions`.
    U : ndarray, shape (2H+1, n)
    Omega : float
        Base frequency: ``x' = Omega dx/dtheta``.
    theta : ndarray, shape (N,)
        Sample phases.
    h : ndarray, shape (N, m)
        Switching functions at the samples.
    p : ndarray
        Parameter vector.
    """
    N = theta.shape[0]
    iv = switching_intervals(h)
    K = iv.shape[0]
    n = U.shape[1]
    dphi = 2.0 * np.pi / N
    if K == 0:
        z = np.zeros((0, n))
        return Crossings(iv, np.zeros(0), np.zeros(0), np.zeros(0), z, z, np.zeros(0), (z, z), z)
    j, law = iv[:, 0], iv[:, 2]
    rows = np.arange(K)
    h0 = h[iv[:, 0], law]
    h1 = h[iv[:, 1], law]
    lo, hi = np.zeros(K), np.ones(K)  # h(lo) has the sign of h0
    t = h0 / (h0 - h1)
    for _ in range(max_iter):
        phi = theta[j] + t * dphi
        x, x1, x2 = series_at(U, phi)
        sw = element.switching_functions(x, Omega * x1, phi, p)
        hv = sw.value[rows, law]
        gx, gxd = sw.grad_x[rows, law], sw.grad_xd[rows, law]
        slope = (np.einsum("kq,kq->k", gx, x1) + Omega * np.einsum("kq,kq->k", gxd, x2)) * dphi
        same = (hv > 0.0) == (h0 > 0.0)
        lo = np.where(same, t, lo)
        hi = np.where(same, hi, t)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(slope != 0.0, -hv / slope, np.inf)
        new = t + step
        bad = ~np.isfinite(new) | (new <= np.minimum(lo, hi)) | (new >= np.maximum(lo, hi))
        new = np.where(bad, 0.5 * (lo + hi), new)
        done = np.abs(new - t) < tol
        t = new
        if done.all():
            break
    phi = theta[j] + t * dphi
    x, x1, x2 = series_at(U, phi)
    xd = Omega * x1
    sw = element.switching_functions(x, xd, phi, p)
    gx, gxd = sw.grad_x[rows, law], sw.grad_xd[rows, law]
    slope = (np.einsum("kq,kq->k", gx, x1) + Omega * np.einsum("kq,kq->k", gxd, x2)) * dphi
    sign = np.where(h1 > 0.0, 1.0, -1.0)
    return Crossings(iv, sign, t, phi, gx, gxd, slope, (x, xd), x1)


@nb.njit(cache=True)
def apply_crossings(intervals, sign, t, L, Lx, Lxd, f, dfdx, dfdxd):
    """Correct the two samples of each switching interval (values and own derivatives).

    Parameters
    ----------
    intervals : ndarray of int, shape (K, 3)
    sign : ndarray, shape (K,)
        +1 where the law switches on in the interval, -1 where it switches off.
    t : ndarray, shape (K,)
    L : ndarray, shape (N, m, n)
        The force of law ``i`` active, at every sample.
    Lx, Lxd : ndarray, shape (N, m, n, n)
    f : ndarray, shape (N, n)
    dfdx, dfdxd : ndarray, shape (N, n, n)
        Corrected in place.

    Returns
    -------
    ndarray, shape (K, 4)
        ``c_j, c_j+1, dc_j/dt, dc_j+1/dt`` of each interval.
    """
    K = intervals.shape[0]
    n = f.shape[1]
    coef = np.empty((K, 4))
    for k in range(K):
        j = intervals[k, 0]
        j1 = intervals[k, 1]
        i = intervals[k, 2]
        s = sign[k]
        tk = t[k]
        c0 = 0.5 * s * (1.0 - tk) * (1.0 - tk)
        c1 = -0.5 * s * tk * tk
        coef[k, 0] = c0
        coef[k, 1] = c1
        coef[k, 2] = -s * (1.0 - tk)
        coef[k, 3] = -s * tk
        for r in range(n):
            f[j, r] += c0 * L[j, i, r]
            f[j1, r] += c1 * L[j1, i, r]
            for q in range(n):
                dfdx[j, r, q] += c0 * Lx[j, i, r, q]
                dfdxd[j, r, q] += c0 * Lxd[j, i, r, q]
                dfdx[j1, r, q] += c1 * Lx[j1, i, r, q]
                dfdxd[j1, r, q] += c1 * Lxd[j1, i, r, q]
    return coef


@nb.njit(cache=True)
def crossing_gradients(phi, gx, gxd, slope, Omega, H):
    """``dt/dU`` of each crossing, shape (K, 2H+1, n) (implicit function theorem on ``h(theta*) = 0``)."""
    K, n = gx.shape
    out = np.zeros((K, 2 * H + 1, n))
    for k in range(K):
        inv = -1.0 / slope[k]
        for q in range(n):
            out[k, 0, q] = inv * gx[k, q]
        for hh in range(1, H + 1):
            c = np.cos(hh * phi[k])
            s = np.sin(hh * phi[k])
            for q in range(n):
                out[k, 2 * hh - 1, q] = inv * (gx[k, q] * c - Omega * gxd[k, q] * hh * s)
                out[k, 2 * hh, q] = inv * (gx[k, q] * s + Omega * gxd[k, q] * hh * c)
    return out


@nb.njit(cache=True)
def add_crossing_jacobian(intervals, coef, L, theta, dtdU, J):
    """Add ``P(theta_a) (x) dc_a/dt L_a (x) dt/dU`` of each crossing's two samples to ``J``.

    Parameters
    ----------
    intervals : ndarray of int, shape (K, 3)
    coef : ndarray, shape (K, 4)
        From :func:`apply_crossings`.
    L : ndarray, shape (N, m, n)
    theta : ndarray, shape (N,)
    dtdU : ndarray, shape (K, 2H+1, n)
    J : ndarray, shape (n(2H+1), n(2H+1))
        Accumulated in place (rows and columns in the ordering of :mod:`contin.harmonics`).
    """
    K, R, n = dtdU.shape
    H = (R - 1) // 2
    N = theta.shape[0]
    P = np.empty(R)
    row = np.empty(R * n)
    for k in range(K):
        i = intervals[k, 2]
        for side in range(2):
            a = intervals[k, side]
            dc = coef[k, 2 + side]
            P[0] = 1.0 / N
            for hh in range(1, H + 1):
                P[2 * hh - 1] = 2.0 * np.cos(hh * theta[a]) / N
                P[2 * hh] = 2.0 * np.sin(hh * theta[a]) / N
            for r1 in range(R):
                for r in range(n):
                    row[r1 * n + r] = P[r1] * dc * L[a, i, r]
            g = dtdU[k].ravel()
            for I in range(R * n):
                v = row[I]
                if v != 0.0:
                    for Jc in range(R * n):
                        J[I, Jc] += v * g[Jc]


@nb.njit(cache=True)
def add_crossing_dp(intervals, coef, L, Lp, dt, dfdp):
    """Add the parameter derivative of the corrected samples to ``dfdp`` (shape (N, n)).

    ``dt`` (shape (K,)) is the derivative of each crossing's place, ``Lp``
    (shape (N, m, n), or empty) the explicit derivative of the law.
    """
    n = L.shape[2]
    for k in range(intervals.shape[0]):
        i = intervals[k, 2]
        for side in range(2):
            a = intervals[k, side]
            for r in range(n):
                v = coef[k, 2 + side] * L[a, i, r] * dt[k]
                if Lp.shape[0] > 0:
                    v += coef[k, side] * Lp[a, i, r]
                dfdp[a, r] += v
