"""Exact Fourier integrals of contact laws over their located contact and flight arcs.

The sampled AFT integrates a switching law by the trapezoidal rule, whose
error jumps whenever a sample crosses the contact surface (:mod:`contin.hb.crossings`
makes it continuous but only to second order, and its derivative grows like
``1/(dh/dtheta)`` when the orbit touches the surface tangentially: grazing).
Here the arcs where law ``i`` of an element is active (``h_i > 0``) are
located on the solution's trigonometric series (every sign change, including
a short flight or touch that falls between two samples), and the Fourier
integral of the element's force is evaluated as

- ``sum over on-arcs of G[L w]`` when the on-arcs are the shorter set, or
- ``T[L w] - sum over off-arcs of G[L w]`` when the off-arcs are,

with ``L`` the force of the active law (smooth and periodic when extended
over the whole period, so its trapezoidal rule ``T`` on the samples is
spectrally accurate), ``w`` the Fourier weights and ``G`` composite
Gauss-Legendre quadrature on panels no longer than a sample interval. The
two forms agree to the quadrature error, so the choice between them does not
move the residual. The result is a smooth function of the coefficients
except where a contact or flight arc appears or vanishes (a tangential touch,
where the exact integrals themselves have a ``d^(3/2)`` singularity), and the
derivative at an arc end is the Leibniz term ``+-L w d(theta*)/du``, in which
``L`` vanishes with ``dh/dtheta`` at a tangential touch (the damping force
``c vn`` of a contact law does), so it stays bounded through grazing.

Arc ends move as ``d theta*/du = -(dh/dx S + dh/dx' Omega S') / (dh/dtheta)``
(implicit function theorem; ``S`` the synthesis row of :mod:`contin.hb.harmonics`).
"""

from __future__ import annotations

import numpy as np

from contin.hb.crossings import series_at

__all__ = ["GAUSS_POINTS", "ArcQuadrature", "law_arcs", "arc_quadrature"]

#: Gauss-Legendre points per panel (the integrand is smooth inside an arc)
GAUSS_POINTS = 6
#: longest panel, in theta
MAX_PANEL = 0.05
_XI, _WI = np.polynomial.legendre.leggauss(GAUSS_POINTS)
_TWO_PI = 2.0 * np.pi


def _h_and_slope(element, U, Omega, phi, p, law):
    """``h``, ``dh/dtheta``, ``dh/dx``, ``dh/dx'`` along the series at phases ``phi``."""
    x, x1, x2 = series_at(U, np.ascontiguousarray(phi, dtype=float))
    sw = element.switching_functions(x, Omega * x1, phi, p)
    gx, gxd = sw.grad_x[:, law], sw.grad_xd[:, law]
    slope = np.einsum("kq,kq->k", gx, x1) + Omega * np.einsum("kq,kq->k", gxd, x2)
    return sw.value[:, law], slope, gx, gxd, x1


def _bracketed_roots(element, U, Omega, a, b, ha, p, law, tol=1e-14, max_iter=60):
    """Roots of ``h`` in ``[a, b]`` (one sign change each; ``ha`` the sign side at ``a``); Newton kept in the bracket."""
    lo, hi = a.copy(), b.copy()
    t = 0.5 * (a + b)
    pos_a = ha > 0.0
    for _ in range(max_iter):
        hv, slope, _, _, _ = _h_and_slope(element, U, Omega, t, p, law)
        same = (hv > 0.0) == pos_a
        lo = np.where(same, t, lo)
        hi = np.where(same, hi, t)
        with np.errstate(divide="ignore", invalid="ignore"):
            new = t - hv / slope
        bad = ~np.isfinite(new) | (new <= lo) | (new >= hi)
        new = np.where(bad, 0.5 * (lo + hi), new)
        done = np.abs(new - t) <= tol * np.maximum(1.0, np.abs(t))
        t = new
        if done.all():
            break
    return t


def _extremum(element, U, Omega, a, b, rising_at_a, p, law, iters=40):
    """The extremum of ``h`` in ``[a, b]`` where ``dh/dtheta`` changes sign (bisection on the slope)."""
    lo, hi = a.copy(), b.copy()
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        _, slope, _, _, _ = _h_and_slope(element, U, Omega, mid, p, law)
        before = (slope > 0.0) == rising_at_a
        lo = np.where(before, mid, lo)
        hi = np.where(before, hi, mid)
    return 0.5 * (lo + hi)


def law_arcs(element, U, Omega, theta, h, slope, p, law):
    """Sorted switching phases of law ``law`` over one period, with their direction.

    Parameters
    ----------
    element : ForceElement
    U : ndarray, shape (2H+1, n)
    Omega : float
    theta : ndarray, shape (N,)
        Sample phases.
    h, slope : ndarray, shape (N,)
        ``h`` and ``dh/dtheta`` at the samples.
    p : ndarray
    law : int

    Returns
    -------
    roots : ndarray, shape (K,)
        Phases in ``[0, 2 pi)``, increasing.
    entering : ndarray of bool, shape (K,)
        True where the law switches on.
    """
    N = theta.shape[0]
    dphi = _TWO_PI / N
    nxt = np.roll(np.arange(N), -1)
    on = h > 0.0
    change = on != on[nxt]
    # an extremum of h between two samples on the same side that may dip through zero: h turns towards
    # zero there, and is not so far from it that the slopes at the ends could not reach it in one interval
    dip = (~change) & (np.sign(slope) != np.sign(slope[nxt])) & np.where(on, slope < 0.0, slope > 0.0)
    dip &= np.minimum(np.abs(h), np.abs(h[nxt])) <= dphi * np.maximum(np.abs(slope), np.abs(slope[nxt]))
    roots, entering = [], []
    j = np.flatnonzero(change)
    if j.size:
        a = theta[j]
        r = _bracketed_roots(element, U, Omega, a, a + dphi, h[j], p, law)
        roots.append(r)
        entering.append(~on[j])
    j = np.flatnonzero(dip)
    if j.size:
        a = theta[j]
        m = _extremum(element, U, Omega, a, a + dphi, slope[j] > 0.0, p, law)
        hm, _, _, _, _ = _h_and_slope(element, U, Omega, m, p, law)
        cross = (hm > 0.0) != on[j]
        if cross.any():
            j, a, m = j[cross], a[cross], m[cross]
            hj = h[j]
            hmj = hm[cross]
            r1 = _bracketed_roots(element, U, Omega, a, m, hj, p, law)
            r2 = _bracketed_roots(element, U, Omega, m, a + dphi, hmj, p, law)
            roots += [r1, r2]
            entering += [~on[j], on[j]]
    if not roots:
        return np.zeros(0), np.zeros(0, dtype=bool)
    r = np.mod(np.concatenate(roots), _TWO_PI)
    e = np.concatenate(entering)
    order = np.argsort(r)
    return r[order], e[order]


class ArcQuadrature:
    """One law's quadrature over its located arcs.

    Attributes
    ----------
    sign : float
        +1: the arcs are on-arcs (the law's integral is their sum); -1: they
        are off-arcs, subtracted from the trapezoidal rule of ``L`` over all
        samples (``full`` is True then).
    full : bool
    starts, ends : ndarray, shape (A,)
        Arc ends (``ends`` may exceed ``2 pi``: arcs wrap).
    phi, weight : ndarray, shape (G,)
        Gauss nodes and weights (in ``theta``).
    """

    def __init__(self, sign, full, starts, ends, phi, weight):
        self.sign, self.full = sign, full
        self.starts, self.ends = starts, ends
        self.phi, self.weight = phi, weight


def arc_quadrature(roots, entering, N, on_everywhere, H) -> ArcQuadrature:
    """Gauss nodes over the shorter of the on- and off-arcs.

    Panels are a quarter period of harmonic ``H`` or a sample interval
    ``2 pi/N`` long, whichever is longer, and at most ``MAX_PANEL`` (the law
    times a Fourier weight is smooth inside an arc, but the law has harmonics
    beyond ``H``). ``on_everywhere`` tells which of all-on and all-off holds
    when there is no root.
    """
    if roots.size == 0:
        z = np.zeros(0)
        return ArcQuadrature(1.0, bool(on_everywhere), z, z, z, z)
    nxt = np.roll(roots, -1)
    length = np.mod(nxt - roots, _TWO_PI)
    length = np.where(length == 0.0, _TWO_PI if roots.size == 1 else 0.0, length)
    on_len = float(length[entering].sum())
    use_on = on_len <= _TWO_PI - on_len
    pick = entering if use_on else ~entering
    starts = roots[pick]
    ends = starts + length[pick]
    panel = min(MAX_PANEL, max(_TWO_PI / N, 0.5 * np.pi / max(H, 1)))
    phis, weights = [], []
    for a, b in zip(starts, ends):
        panels = max(1, int(np.ceil((b - a) / panel)))
        edges = np.linspace(a, b, panels + 1)
        half = 0.5 * np.diff(edges)
        mid = 0.5 * (edges[1:] + edges[:-1])
        phis.append((mid[:, None] + half[:, None] * _XI[None, :]).ravel())
        weights.append((half[:, None] * _WI[None, :]).ravel())
    return ArcQuadrature(1.0 if use_on else -1.0, not use_on, starts, ends, np.concatenate(phis),
                         np.concatenate(weights))


def _fourier_rows(phi, H):
    """Projection rows ``P`` (1/2pi, cos k/pi, sin k/pi), synthesis rows ``S`` and ``dS/dtheta``, shapes (K, 2H+1)."""
    k = np.arange(1, H + 1)
    c, s = np.cos(np.outer(phi, k)), np.sin(np.outer(phi, k))
    K = phi.shape[0]
    P = np.empty((K, 2 * H + 1))
    S = np.empty((K, 2 * H + 1))
    Sp = np.empty((K, 2 * H + 1))
    P[:, 0], S[:, 0], Sp[:, 0] = 1.0 / _TWO_PI, 1.0, 0.0
    P[:, 1::2], P[:, 2::2] = c / np.pi, s / np.pi
    S[:, 1::2], S[:, 2::2] = c, s
    Sp[:, 1::2], Sp[:, 2::2] = -k * s, k * c
    return P, S, Sp


class LawIntegral:
    """The exact Fourier integral of one law of one element at one orbit (see the module docstring).

    Attributes
    ----------
    coefficients : ndarray, shape (2H+1, n)
        The arcs' contribution (the trapezoidal part, if any, went into the samples).
    """

    def __init__(self, element, law, U, Omega, nu, theta, h, slope, p):
        self.element, self.law, self.Omega, self.nu, self.p = element, law, Omega, nu, p
        H = (U.shape[0] - 1) // 2
        self.H = H
        roots, entering = law_arcs(element, U, Omega, theta, h, slope, p, law)
        if roots.size and (roots.size % 2 or np.any(entering == np.roll(entering, 1))):
            raise FloatingPointError(f"the contact switches of '{element.kind}' do not alternate on and off "
                                     f"({roots.size} located)")
        self.quad = q = arc_quadrature(roots, entering, theta.shape[0], bool(h[0] > 0.0), H)
        n = U.shape[1]
        self.coefficients = np.zeros((2 * H + 1, n))
        if q.phi.size == 0:
            return
        x, x1, _ = series_at(U, q.phi)
        sw = element.switching_functions(x, Omega * x1, q.phi, p)
        self.nodes = (x, Omega * x1, x1)
        self.L = sw.difference[:, law]
        self.Lx, self.Lxd = sw.difference_x[:, law], sw.difference_xd[:, law]
        self.P, self.S, self.Sp = _fourier_rows(q.phi, H)
        self.coefficients = q.sign * (self.P * q.weight[:, None]).T @ self.L
        # arc ends: phase, Leibniz sign, the law's force there, dh/dx, dh/dx', dh/dtheta, dx/dtheta
        ends = np.concatenate([q.starts, q.ends])
        side = np.concatenate([-np.ones(q.starts.size), np.ones(q.ends.size)])
        _, sl, gx, gxd, e1 = _h_and_slope(element, U, Omega, ends, p, law)
        xe, _, _ = series_at(U, ends)
        self.ends = (ends, side, sl, gx, gxd, xe, e1)
        swe = element.switching_functions(xe, Omega * e1, ends, p)
        self.Le = swe.difference[:, law]
        self.Pe, self.Se, self.Spe = _fourier_rows(ends, H)

    def _end_vectors(self, dofs=None):
        """``g_e = P(theta_e) (x) L_e`` (signed by side and form), shape (E, (2H+1) n), or (E, (2H+1) len(dofs))
        on the coefficients of ``dofs`` alone."""
        ends, side, sl, _, _, _, _ = self.ends
        Le = self.Le if dofs is None else self.Le[:, dofs]
        g = (self.Pe[:, :, None] * Le[:, None, :]).reshape(ends.size, -1)
        return g * (self.quad.sign * side)[:, None]

    def _add(self, J, Dx, Dxd, Sx, Sxd, ex, exd, dofs=None):
        """``J += sum_g W_g P_g (x) (Dx_g Sx_g + Dxd_g Sxd_g)`` plus the arc ends' Leibniz terms.

        ``dofs`` (sorted indices, optional): ``J`` is the block of the coefficients of these dofs only
        (rows and columns), shape (n_d (2H+1), n_d (2H+1)).
        """
        ends, side, sl, gx, gxd, _, _ = self.ends
        if dofs is not None:
            Dx = Dx[:, dofs][:, :, dofs]
            Dxd = None if Dxd is None else Dxd[:, dofs][:, :, dofs]
            gx, gxd = gx[:, dofs], gxd[:, dofs]
        G, n = Dx.shape[0], Dx.shape[1]
        R = 2 * self.H + 1
        left = self.P * (self.quad.sign * self.quad.weight)[:, None]  # (G, R)
        right = Dx.reshape(G, n * n)[:, :, None] * Sx[:, None, :]
        if Dxd is not None:
            right = right + Dxd.reshape(G, n * n)[:, :, None] * Sxd[:, None, :]  # (G, n*n, R)
        block = (left.T @ right.reshape(G, -1)).reshape(R, n, n, R)
        J += block.transpose(0, 1, 3, 2).reshape(R * n, R * n)
        # the arc ends move with the orbit: d theta_e = -(dh/dx dx + dh/dx' dx') / (dh/dtheta)
        dphi = -ex[:, :, None] * gx[:, None, :]
        if exd is not None:
            dphi = dphi - exd[:, :, None] * gxd[:, None, :]
        dphi = (dphi / sl[:, None, None]).reshape(ends.size, -1)
        J += self._end_vectors(dofs).T @ dphi

    def add_jacobian(self, J, dofs=None):
        """Accumulate ``d coefficients / dU`` into ``J``.

        Parameters
        ----------
        J : ndarray, shape (n(2H+1), n(2H+1)), or (n_d(2H+1), n_d(2H+1)) with ``dofs``
        dofs : ndarray of int, optional
            Sorted dofs that include every dof the element acts on or depends on: ``J``
            is the block of their coefficients (harmonic-major, :mod:`contin.hb.harmonics`).
        """
        if self.quad.phi.size:
            self._add(J, self.Lx, self.Lxd, self.S, self.Omega * self.Sp, self.Se, self.Omega * self.Spe, dofs)

    def add_velocity_jacobian(self, D):
        """Accumulate the derivative of the coefficients with respect to velocity coefficients into ``D``.

        This is the operator ``T(df/dx')`` of Hill's matrix ``Delta1``: a
        perturbation ``dx' = Y(theta)`` of the velocity alone.
        """
        if self.quad.phi.size:
            self._add(D, self.Lxd, None, self.S, None, self.Se, None)

    def lam_derivative(self, is_frequency: bool, k=None):
        """Derivative of the coefficients with respect to lambda, shape (2H+1, n).

        ``is_frequency``: lambda is ``w`` (``x' = (w/nu) dx/dtheta``); ``k``: index of lambda
        among the parameters when the element depends on it.
        """
        out = np.zeros_like(self.coefficients)
        if self.quad.phi.size == 0:
            return out
        ends, side, sl, gx, gxd, xe, e1 = self.ends
        left = self.P * (self.quad.sign * self.quad.weight)[:, None]
        dL = np.zeros_like(self.L)
        dend = np.zeros(ends.size)
        if is_frequency:
            dL += np.einsum("gpq,gq->gp", self.Lxd, self.nodes[2]) / self.nu
            dend -= np.einsum("eq,eq->e", gxd, e1) / self.nu / sl
        if k is not None:
            x, xd, _ = self.nodes
            _, Lp = self.element.switching_dp(x, xd, self.quad.phi, self.p, k)
            dL += Lp[:, self.law]
            hp, _ = self.element.switching_dp(xe, self.Omega * e1, ends, self.p, k)
            dend -= hp[:, self.law] / sl
        out += left.T @ dL
        out += (self._end_vectors() * dend[:, None]).sum(axis=0).reshape(out.shape)
        return out
