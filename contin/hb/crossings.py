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
(``S`` the row of the synthesis, :mod:`contin.hb.harmonics` ordering), so each
crossing adds a rank-one term ``P(theta_a) (x) dc_a/dt L_a (x) dt/du`` to the
Jacobian (:func:`add_crossing_jacobian`, which sums them as one product of
rank ``K`` on the dofs they touch), besides ``c_a dL/dx`` on the two
samples' own derivatives.
"""

from __future__ import annotations

import numpy as np

from contin.util.jit import njit

__all__ = ["switching_intervals", "series_at", "locate_crossings", "Crossings", "apply_crossings",
           "crossing_gradients", "add_crossing_jacobian", "add_crossing_dp"]


@njit(cache=True)
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


@njit(cache=True)
def series_at(U, phi):
    """The series and its first two ``theta`` derivatives at arbitrary phases.

    ``cos(h phi)``, ``sin(h phi)`` by the angle-addition recurrence from
    ``cos(phi)``, ``sin(phi)`` (a rotation: its rounding error grows linearly
    in ``h``, as that of the argument ``h phi`` does).

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
        c1 = np.cos(phi[k])
        s1 = np.sin(phi[k])
        c = c1
        s = s1
        for hh in range(1, H + 1):
            for q in range(n):
                a = U[2 * hh - 1, q]
                b = U[2 * hh, q]
                v = a * c + b * s
                x[k, q] += v
                x1[k, q] += hh * (b * c - a * s)
                x2[k, q] -= hh * hh * v
            c, s = c * c1 - s * s1, s * c1 + c * s1
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


@njit(cache=True)
def _first_guess(h, intervals):
    """Root in ``[0, 1]`` of the cubic through ``h`` at samples ``j-1, j, j+1, j+2`` of each interval.

    Parameters
    ----------
    h : ndarray, shape (N, m)
    intervals : ndarray of int, shape (K, 3)

    Returns
    -------
    ndarray, shape (K,)
        The place in the interval, a first guess for the root along the series.
    """
    N = h.shape[0]
    K = intervals.shape[0]
    out = np.empty(K)
    for k in range(K):
        j = intervals[k, 0]
        j1 = intervals[k, 1]
        i = intervals[k, 2]
        hm = h[j - 1 if j > 0 else N - 1, i]
        h0 = h[j, i]
        h1 = h[j1, i]
        h2 = h[j1 + 1 if j1 + 1 < N else 0, i]
        # p(t) = a0 + a1 t + a2 t^2 + a3 t^3 with p(-1, 0, 1, 2) = hm, h0, h1, h2
        a1 = -hm / 3.0 - 0.5 * h0 + h1 - h2 / 6.0
        a2 = 0.5 * hm - h0 + 0.5 * h1
        a3 = (h2 - hm) / 6.0 + 0.5 * (h0 - h1)
        t = h0 / (h0 - h1)
        lo = 0.0  # p(lo) has the sign of h0 (p(0) = h0, p(1) = h1)
        hi = 1.0
        pos = h0 > 0.0
        for _ in range(30):
            pv = h0 + t * (a1 + t * (a2 + t * a3))
            if (pv > 0.0) == pos:
                lo = t
            else:
                hi = t
            dp = a1 + t * (2.0 * a2 + 3.0 * t * a3)
            new = t - pv / dp if dp != 0.0 else 0.5 * (lo + hi)
            if not (min(lo, hi) < new < max(lo, hi)):
                new = 0.5 * (lo + hi)
            done = abs(new - t) < 1e-15
            t = new
            if done:
                break
        out[k] = t
    return out


@njit(cache=True)
def _series_bounds(U):
    """Sums of the coefficients' magnitudes, bounds of ``|x|`` and ``|dx/dtheta|``, shapes (n,)."""
    R, n = U.shape
    b0 = np.zeros(n)
    b1 = np.zeros(n)
    for q in range(n):
        b0[q] = abs(U[0, q])
    for r in range(1, R):
        hh = (r + 1) // 2
        for q in range(n):
            b0[q] += abs(U[r, q])
            b1[q] += hh * abs(U[r, q])
    return b0, b1


# a crossing's Newton iteration stops where |h| is below this many estimated rounding errors
_NOISE = 2.0


@njit(cache=True)
def _newton_sweep(active, law, value, grad_x, grad_xd, x, x1, x2, Omega, dphi, h0, tol, bound0, bound1,
                  t, lo, hi, phi_a, out_phi, out_gx, out_gxd, out_slope, out_x, out_x1, last):
    """One safeguarded Newton step of the unconverged crossings; store the data evaluated at ``t``.

    A crossing has converged when its Newton step, or its bracket, is below
    ``tol``, or when ``h`` is within its rounding error along the series
    (``eps`` times the coefficients' magnitudes weighted by the gradient):
    near a tangential touch the slope is small and that error, not ``tol``,
    bounds how well the root is determined; further steps would only wander
    inside it.

    Parameters
    ----------
    active : ndarray of int, shape (A,)
        Crossings evaluated in this sweep.
    law : ndarray of int, shape (K,)
    value : ndarray, shape (A, m)
    grad_x, grad_xd : ndarray, shape (A, m, n)
        The switching functions at the states of the active crossings.
    x, x1, x2 : ndarray, shape (A, n)
        The series and its ``theta`` derivatives there.
    Omega, dphi, tol : float
    h0 : ndarray, shape (K,)
        ``h`` at the first sample of each interval.
    bound0, bound1 : ndarray, shape (n,)
        From :func:`_series_bounds`.
    t, lo, hi : ndarray, shape (K,)
        Place and bracket, updated in place.
    phi_a : ndarray, shape (A,)
        Phases evaluated.
    out_phi, out_slope : ndarray, shape (K,)
    out_gx, out_gxd, out_x, out_x1 : ndarray, shape (K, n)
        Data at the evaluated place, written for the active crossings.
    last : bool
        Store the data only, no step.

    Returns
    -------
    ndarray of int
        The crossings still unconverged (a converged one keeps the place
        evaluated).
    """
    A = active.shape[0]
    n = x.shape[1]
    eps = np.finfo(np.float64).eps
    keep = np.empty(A, dtype=np.int64)
    nk = 0
    for r in range(A):
        k = active[r]
        i = law[k]
        hv = value[r, i]
        sl = 0.0
        sd = 0.0
        noise = 0.0
        for q in range(n):
            sl += grad_x[r, i, q] * x1[r, q]
            sd += grad_xd[r, i, q] * x2[r, q]
            noise += abs(grad_x[r, i, q]) * bound0[q] + Omega * abs(grad_xd[r, i, q]) * bound1[q]
            out_gx[k, q] = grad_x[r, i, q]
            out_gxd[k, q] = grad_xd[r, i, q]
            out_x[k, q] = x[r, q]
            out_x1[k, q] = x1[r, q]
        slope = (sl + Omega * sd) * dphi
        out_slope[k] = slope
        out_phi[k] = phi_a[r]
        tk = t[k]
        # converged: the Newton step below tol, or h within its rounding error of zero
        if last or abs(hv) < tol * abs(slope) or abs(hv) <= _NOISE * eps * noise:
            continue
        if (hv > 0.0) == (h0[k] > 0.0):
            lo[k] = tk
        else:
            hi[k] = tk
        a = min(lo[k], hi[k])
        b = max(lo[k], hi[k])
        new = tk - hv / slope if slope != 0.0 else 0.5 * (lo[k] + hi[k])
        if not (a < new < b):  # also catches a non-finite step
            new = 0.5 * (lo[k] + hi[k])
            if abs(new - tk) < tol:  # the bracket has closed on tk
                continue
        t[k] = new
        keep[nk] = k
        nk += 1
    return keep[:nk]


def locate_crossings(element, U, Omega, theta, h, p, tol=1e-13, max_iter=40) -> Crossings:
    """Roots of the element's switching functions along the series, one per switching interval.

    A Newton iteration in the interval coordinate ``t``, kept inside the
    bracket of the sign change (bisection when a step leaves it), from the
    root of the cubic through the samples of ``h`` around the interval.
    Each crossing stops on its own (see :func:`_newton_sweep`), keeping the
    place evaluated last, whose data are returned; only the unconverged
    ones are evaluated again.

    Parameters
    ----------
    element : ForceElement
        With :meth:`~contin.model.base.ForceElement.switching_functions`.
    U : ndarray, shape (2H+1, n)
    Omega : float
        Base frequency: ``x' = Omega dx/dtheta``.
    theta : ndarray, shape (N,)
        Sample phases.
    h : ndarray, shape (N, m)
        Switching functions at the samples.
    p : ndarray
        Parameter vector.
    tol : float
        Step in ``t`` below which a crossing has converged.
    max_iter : int
        Newton steps at most; a crossing still moving then is evaluated at
        its last iterate.
    """
    N = theta.shape[0]
    iv = switching_intervals(h)
    K = iv.shape[0]
    n = U.shape[1]
    dphi = 2.0 * np.pi / N
    if K == 0:
        z = np.zeros((0, n))
        return Crossings(iv, np.zeros(0), np.zeros(0), np.zeros(0), z, z, np.zeros(0), (z, z), z)
    U = np.ascontiguousarray(U, dtype=float)
    j, law = iv[:, 0], np.ascontiguousarray(iv[:, 2])
    h0 = np.ascontiguousarray(h[iv[:, 0], law], dtype=float)
    h1 = h[iv[:, 1], law]
    t = _first_guess(np.ascontiguousarray(h, dtype=float), iv)
    lo, hi = np.zeros(K), np.ones(K)  # h(lo) has the sign of h0
    bound0, bound1 = _series_bounds(U)
    phi, slope = np.empty(K), np.empty(K)
    gx, gxd, x, x1 = np.empty((K, n)), np.empty((K, n)), np.empty((K, n)), np.empty((K, n))
    Omega = float(Omega)
    active = np.arange(K)
    for it in range(max_iter + 1):
        phi_a = theta[j[active]] + t[active] * dphi
        xa, x1a, x2a = series_at(U, phi_a)
        sw = element.switching_functions(xa, Omega * x1a, phi_a, p)
        # after the last step only the data at the last iterate
        active = _newton_sweep(active, law, np.ascontiguousarray(sw.value), np.ascontiguousarray(sw.grad_x),
                               np.ascontiguousarray(sw.grad_xd), xa, x1a, x2a, Omega, dphi, h0,
                               tol, bound0, bound1, t, lo, hi, phi_a, phi, gx, gxd, slope, x, x1, it == max_iter)
        if active.size == 0:
            break
    sign = np.where(h1 > 0.0, 1.0, -1.0)
    return Crossings(iv, sign, t, phi, gx, gxd, slope, (x, Omega * x1), x1)


@njit(cache=True)
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


@njit(cache=True)
def crossing_gradients(phi, gx, gxd, slope, Omega, H):
    """``dt/dU`` of each crossing (implicit function theorem on ``h(theta*) = 0``).

    Parameters
    ----------
    phi : ndarray, shape (K,)
    gx, gxd : ndarray, shape (K, n)
    slope : ndarray, shape (K,)
    Omega : float
    H : int

    Returns
    -------
    ndarray, shape (K, 2H+1, n)
    """
    K, n = gx.shape
    out = np.zeros((K, 2 * H + 1, n))
    for k in range(K):
        inv = -1.0 / slope[k]
        for q in range(n):
            out[k, 0, q] = inv * gx[k, q]
        c1 = np.cos(phi[k])
        s1 = np.sin(phi[k])
        c = c1
        s = s1
        for hh in range(1, H + 1):
            for q in range(n):
                out[k, 2 * hh - 1, q] = inv * (gx[k, q] * c - Omega * gxd[k, q] * hh * s)
                out[k, 2 * hh, q] = inv * (gx[k, q] * s + Omega * gxd[k, q] * hh * c)
            c, s = c * c1 - s * s1, s * c1 + c * s1
    return out


@njit(cache=True)
def add_crossing_jacobian(intervals, coef, L, theta, dtdU, J):
    """Add ``P(theta_a) (x) dc_a/dt L_a (x) dt/dU`` of each crossing's two samples to ``J``.

    Both samples of a crossing share its ``dt/dU``, so the terms are one
    matrix product ``A B`` of rank ``K``: column ``k`` of ``A`` the sum over
    the two samples of ``P(theta_a) (x) dc_a/dt L_a``, row ``k`` of ``B`` the
    crossing's ``dt/dU``; both restricted to the dofs where ``L``, and
    ``dt/dU``, are nonzero (a contact acts on few dofs).

    Parameters
    ----------
    intervals : ndarray of int, shape (K, 3)
    coef : ndarray, shape (K, 4)
        From :func:`apply_crossings`.
    L : ndarray, shape (N, m, n)
    theta : ndarray, shape (N,)
    dtdU : ndarray, shape (K, 2H+1, n)
    J : ndarray, shape (n(2H+1), n(2H+1))
        Accumulated in place (rows and columns in the ordering of :mod:`contin.hb.harmonics`).
    """
    K, R, n = dtdU.shape
    H = (R - 1) // 2
    N = theta.shape[0]
    rows = np.zeros(n, dtype=np.bool_)
    cols = np.zeros(n, dtype=np.bool_)
    for k in range(K):
        i = intervals[k, 2]
        for side in range(2):
            for r in range(n):
                if L[intervals[k, side], i, r] != 0.0:
                    rows[r] = True
        for r1 in range(R):
            for q in range(n):
                if dtdU[k, r1, q] != 0.0:
                    cols[q] = True
    rd = np.nonzero(rows)[0]
    cd = np.nonzero(cols)[0]
    nr = rd.shape[0]
    nc = cd.shape[0]
    if K == 0 or nr == 0 or nc == 0:
        return
    A = np.zeros((R * nr, K))
    B = np.empty((K, R * nc))
    w = np.empty(nr)
    for k in range(K):
        i = intervals[k, 2]
        for side in range(2):
            a = intervals[k, side]
            dc = coef[k, 2 + side]
            for ir in range(nr):
                w[ir] = dc * L[a, i, rd[ir]]
            for ir in range(nr):
                A[ir, k] += w[ir] / N
            c1 = np.cos(theta[a])
            s1 = np.sin(theta[a])
            c = c1
            s = s1
            for hh in range(1, H + 1):
                pc = 2.0 * c / N
                ps = 2.0 * s / N
                for ir in range(nr):
                    A[(2 * hh - 1) * nr + ir, k] += pc * w[ir]
                    A[2 * hh * nr + ir, k] += ps * w[ir]
                c, s = c * c1 - s * s1, s * c1 + c * s1
        for r1 in range(R):
            for ic in range(nc):
                B[k, r1 * nc + ic] = dtdU[k, r1, cd[ic]]
    M = np.dot(A, B)
    for r1 in range(R):
        for ir in range(nr):
            I = r1 * n + rd[ir]
            for c1 in range(R):
                for ic in range(nc):
                    J[I, c1 * n + cd[ic]] += M[r1 * nr + ir, c1 * nc + ic]


@njit(cache=True)
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
