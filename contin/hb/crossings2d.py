"""Crossing-resolved sampling of switching force laws on the grid of a torus.

The one-dimensional method of :mod:`contin.hb.crossings` carried to the
``N2 x N1`` grid of :mod:`contin.hb.qp_basis`: each line of constant
``theta2`` is a periodic sequence of ``N1`` samples in ``theta1``, and the
interval ``[theta1_i, theta1_i+1]`` of a line in which a switching function
``h`` changes sign is integrated over its contact part only. The crossing
``theta1*`` is the root of ``h`` along the torus' own series on that line (a
safeguarded Newton iteration), ``t = (theta1* - theta1_i) / (2 pi / N1)`` its
place in the interval, and the two samples get the corrections of the
table in :mod:`contin.hb.crossings` (:func:`contin.hb.crossings.apply_crossings`
with the grid's flat sample indices). The error of a crossing falls from
``O(1/N1)`` to ``O(1/N1^2)`` and the residual is continuous in the
coefficients: Newton converges where plain sampling stalls at the size of a
jump (the rotor's ``c vn`` at contact onset).

Derivatives: with ``S(theta*)`` the synthesis rows of the torus at the
crossing and ``f_j`` the pairs' frequencies,

    dtheta1*/du = -(dh/dx S + dh/dx' S') / (dh/dtheta1),   S' = d/dt S = sum_j f_j dS/dphi_j,

and ``dtheta1*/dw2 = -(dh/dx' x_theta2) / (dh/dtheta1)``; each crossing adds the
rank-one term ``P(samples) (x) dc/dt L (x) dt/du`` to the Jacobian.
"""

from __future__ import annotations

import numpy as np

from contin.hb.crossings import add_crossing_dp, apply_crossings

__all__ = ["GridCrossings", "locate_grid_crossings", "series_on_lines"]

#: slope (relative to the largest on the grid) below which a crossing counts as a tangential touch
TOUCH = 1e-6


def series_on_lines(U, pairs, freqs, th1, th2):
    """The torus series at the phases ``(th1, th2)`` (each shape (K,)).

    Returns
    -------
    x, x1, x2, xd, xd1 : ndarray, shape (K, n)
        ``x``, ``dx/dtheta1``, ``dx/dtheta2``, ``dx/dt`` and ``d(dx/dt)/dtheta1``.
    c, s : ndarray, shape (K, P-1)
        ``cos`` and ``sin`` of the pairs' phases (pair 0, the mean, left out).
    """
    k1 = pairs[1:, 0].astype(float)
    k2 = pairs[1:, 1].astype(float)
    f = freqs[1:]
    ph = np.outer(th1, k1) + np.outer(th2, k2)
    c, s = np.cos(ph), np.sin(ph)
    A, B = U[1::2], U[2::2]
    x = U[0][None, :] + c @ A + s @ B
    x1 = (-s * k1) @ A + (c * k1) @ B
    x2 = (-s * k2) @ A + (c * k2) @ B
    xd = (-s * f) @ A + (c * f) @ B
    xd1 = (-c * (f * k1)) @ A + (-s * (f * k1)) @ B
    return x, x1, x2, xd, xd1, c, s


class GridCrossings:
    """Located crossings of one element on the grid, with what their derivatives need.

    Attributes
    ----------
    intervals : ndarray of int, shape (K, 3)
        Flat sample indices ``s, s'`` of the interval and the law ``i``.
    sign : ndarray, shape (K,)
        +1 where the law switches on, -1 where it switches off.
    t : ndarray, shape (K,)
    coef : ndarray, shape (K, 4)
        As returned by :func:`contin.hb.crossings.apply_crossings`.
    dtdU : ndarray, shape (K, 2P-1, n)
        ``dt/du`` of each crossing.
    dtdw2 : ndarray, shape (K,)
    dtdw : ndarray, shape (K,)
        ``dt/dw`` through the velocity (``x' = (w/nu) x_theta1 + w2 x_theta2``).
    state : (ndarray, ndarray), shapes (K, n)
        ``x``, ``x'`` at the crossings; ``phase`` (K,) their ``tau``.
    slope : ndarray, shape (K,)
        ``dh/dtheta1`` times the interval length.
    """

    def __init__(self, intervals, sign, t, coef, dtdU, dtdw2, dtdw, state, phase, slope):
        self.intervals, self.sign, self.t, self.coef = intervals, sign, t, coef
        self.dtdU, self.dtdw2, self.dtdw = dtdU, dtdw2, dtdw
        self.state, self.phase, self.slope = state, phase, slope


def _h_on_lines(el, U, pairs, freqs, th1, th2, law, nu, p):
    x, x1, x2, xd, xd1, c, s = series_on_lines(U, pairs, freqs, th1, th2)
    sw = el.switching_functions(x, xd, nu * th1, p)
    K = th1.size
    rows = np.arange(K)
    gx, gxd = sw.grad_x[rows, law], sw.grad_xd[rows, law]
    slope = np.einsum("kq,kq->k", gx, x1) + np.einsum("kq,kq->k", gxd, xd1)
    return sw.value[rows, law], slope, gx, gxd, (x, x1, x2, xd, c, s)


def locate_grid_crossings(el, sw, U, pairs, freqs, N1: int, N2: int, nu: int, p, f, dfdx, dfdxd,
                          tol: float = 1e-13, max_iter: int = 40) -> GridCrossings | None:
    """Locate the crossings of one element along the ``theta1`` lines and correct the samples in place.

    Parameters
    ----------
    el : ForceElement
    sw : Switching
        Its switching data at the grid samples (``value`` (N, m), ``difference`` ...).
    U : ndarray, shape (2P-1, n)
    pairs : ndarray of int, shape (P, 2)
    freqs : ndarray, shape (P,)
    N1, N2, nu : int
    p : ndarray
    f, dfdx, dfdxd : ndarray
        Sampled force and derivatives, shapes (N, n), (N, n, n): corrected in place.

    Returns
    -------
    GridCrossings or None
        None when no law switches on the grid.
    """
    m = sw.value.shape[1]
    on = sw.value.reshape(N2, N1, m) > 0.0
    nxt = np.roll(on, -1, axis=1)
    line, i, law = np.nonzero(on != nxt)
    if not line.size:
        return None
    dth = 2.0 * np.pi / N1
    th2 = 2.0 * np.pi * line / N2
    lo = dth * i
    hi = lo + dth
    s0 = line * N1 + i
    s1 = line * N1 + (i + 1) % N1
    h0 = sw.value[s0, law]
    h1 = sw.value[s1, law]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(h0 != h1, h0 / (h0 - h1), 0.5)
    th = lo + np.clip(t, 0.0, 1.0) * dth
    pos0 = h0 > 0.0
    act = np.arange(th.size)  # crossings not yet converged: Newton kept in its bracket, bisection as a fallback
    for _ in range(max_iter):
        hv, slope, *_ = _h_on_lines(el, U, pairs, freqs, th[act], th2[act], law[act], nu, p)
        same = (hv > 0.0) == pos0[act]
        lo[act] = np.where(same, th[act], lo[act])
        hi[act] = np.where(same, hi[act], th[act])
        with np.errstate(divide="ignore", invalid="ignore"):
            new = th[act] - hv / slope
        bad = ~np.isfinite(new) | (new <= lo[act]) | (new >= hi[act])
        new = np.where(bad, 0.5 * (lo[act] + hi[act]), new)
        done = np.abs(new - th[act]) <= tol * np.maximum(1.0, np.abs(th[act]))
        th[act] = new
        act = act[~done]
        if not act.size:
            break
    hv, slope, gx, gxd, (x, x1, x2, xd, c, s) = _h_on_lines(el, U, pairs, freqs, th, th2, law, nu, p)
    t = np.clip((th - dth * i) / dth, 0.0, 1.0)
    intervals = np.stack([s0, s1, law], axis=1).astype(np.int64)
    sign = np.where(pos0, -1.0, 1.0)
    coef = apply_crossings(intervals, sign, t, sw.difference, sw.difference_x, sw.difference_xd, f, dfdx, dfdxd)
    # dt/du = dtheta*/du / dth (implicit function theorem on h(theta*) = 0). Where a line touches the
    # contact set tangentially (its two crossings merging) the slope vanishes and dt/du with it grows without
    # bound while the crossing's contribution vanishes: the factor is kept finite there (a Tikhonov-type
    # 1/slope), which leaves the transversal crossings' derivatives exact to TOUCH**2 relative.
    sl = slope * dth
    ref = TOUCH * np.max(np.abs(sl))
    inv = -sl / (sl * sl + ref * ref)
    fr = freqs[1:][None, :, None]
    K, n = gx.shape
    dtdU = np.empty((K, U.shape[0], n))
    dtdU[:, 0] = inv[:, None] * gx
    dtdU[:, 1::2] = inv[:, None, None] * (c[:, :, None] * gx[:, None, :] - (fr * s[:, :, None]) * gxd[:, None, :])
    dtdU[:, 2::2] = inv[:, None, None] * (s[:, :, None] * gx[:, None, :] + (fr * c[:, :, None]) * gxd[:, None, :])
    dtdw2 = inv * np.einsum("kq,kq->k", gxd, x2)
    dtdw = inv * np.einsum("kq,kq->k", gxd, x1) / nu
    return GridCrossings(intervals, sign, t, coef, dtdU, dtdw2, dtdw, (x, xd), nu * th, slope * dth)


def crossing_columns(cr: GridCrossings, L, pairs, N1: int, N2: int) -> np.ndarray:
    """``P(samples) (x) dc/dt L`` of each crossing, the columns of the rank-``K`` Jacobian term, shape (2P-1, n, K)."""
    N = N1 * N2
    K = cr.intervals.shape[0]
    n = L.shape[2]
    law = cr.intervals[:, 2]
    out = np.zeros((2 * pairs.shape[0] - 1, n, K))
    for side in range(2):
        smp = cr.intervals[:, side]
        th1 = 2.0 * np.pi * (smp % N1) / N1
        th2 = 2.0 * np.pi * (smp // N1) / N2
        ph = np.outer(pairs[1:, 0], th1) + np.outer(pairs[1:, 1], th2)  # (P-1, K)
        v = cr.coef[:, 2 + side][:, None] * L[smp, law]  # (K, n)
        out[0] += v.T / N
        out[1::2] += (2.0 / N) * np.cos(ph)[:, None, :] * v.T[None, :, :]
        out[2::2] += (2.0 / N) * np.sin(ph)[:, None, :] * v.T[None, :, :]
    return out


def crossing_dp(cr: GridCrossings, L, Lp, dt, N: int, n: int) -> np.ndarray:
    """The sample-wise derivative of the corrected force for a crossing-place rate ``dt`` (K,), shape (N, n)."""
    out = np.zeros((N, n))
    add_crossing_dp(cr.intervals, cr.coef, L, Lp, np.ascontiguousarray(dt, dtype=float), out)
    return out
