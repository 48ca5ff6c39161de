"""Models and independent references shared by the hard-case tests."""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from contin.model.elements import GapForce
from contin.model.base import Monomial
from contin.models.polynomial import polynomial_model


def clearance_oscillator(kc: float, c: float = 0.05, F: float = 0.03, g: float = 0.5):
    """x'' + c x' + x + kc (x - g)_+ = F cos(w t): a one-sided elastic stop at x = g."""
    m = polynomial_model(["x"], {"c": c, "F": F, "g": g, "kc": kc, "w": 0.5}, [[1]], [["c"]], [[1]],
                         forcing=[{"dof": "x", "amplitude": "F"}])
    names = list(m.parameters)
    m.forces.append(GapForce(0, Monomial.parse("g", names), Monomial.parse("kc", names), sides="+"))
    return m


def clearance_orbit(w, kc, c=0.05, F=0.03, g=0.5, z0=(0.0, 0.0), tol=1e-11, max_iter=40):
    """Periodic orbit of :func:`clearance_oscillator` by shooting on event-located integration.

    Each smooth piece (free, or in contact) is integrated with DOP853 at
    rtol 1e-12 up to the switching time located by ``solve_ivp``'s event
    function ``x - g``; the period map's fixed point is found by ``fsolve``.

    Returns
    -------
    z : ndarray (2,)
        ``(x, x')`` at ``t = 0`` (phase of the forcing ``cos(w t)``).
    x_max, x_min : float
        Extremes of ``x`` over the period (dense output, 4000 samples per piece).
    defect : float
        ``|phi_T(z) - z|_inf``.
    """
    T = 2 * math.pi / w

    def free(t, z):
        return [z[1], F * math.cos(w * t) - c * z[1] - z[0]]

    def contact(t, z):
        return [z[1], F * math.cos(w * t) - c * z[1] - z[0] - kc * (z[0] - g)]

    def enter(t, z):
        return z[0] - g

    def leave(t, z):
        return z[0] - g

    # one crossing direction per piece: a piece that starts on the surface does not stop at once
    enter.terminal, enter.direction = True, 1.0
    leave.terminal, leave.direction = True, -1.0

    def period_map(z0, keep=False):
        t, z = 0.0, np.array(z0, dtype=float)
        xs = []
        inside = z[0] > g
        while t < T * (1 - 1e-14):
            sol = solve_ivp(contact if inside else free, (t, T), z, method="DOP853", rtol=1e-12, atol=1e-14,
                            events=leave if inside else enter, dense_output=keep)
            if keep:
                xs.append(sol.sol(np.linspace(sol.t[0], sol.t[-1], 4000))[0])
            t, z = float(sol.t[-1]), sol.y[:, -1].copy()
            if sol.status == 1:
                t, z = float(sol.t_events[0][0]), sol.y_events[0][0].copy()
                inside = not inside
        return z, (np.concatenate(xs) if keep else None)

    # shooting: Newton on P(z) - z with a central-difference Jacobian of the period map (2 x 2);
    # the orbit near grazing is often unstable, so iterating the map would not find it
    z = np.asarray(z0, dtype=float)
    for _ in range(max_iter):
        r = period_map(z)[0] - z
        if np.abs(r).max() <= tol:
            break
        J = np.empty((2, 2))
        for j in range(2):
            e = np.zeros(2)
            e[j] = 1e-7 * max(1.0, abs(z[j]))
            J[:, j] = (period_map(z + e)[0] - period_map(z - e)[0]) / (2 * e[j])
        J -= np.eye(2)
        dz = np.linalg.solve(J, -r)
        lam = 1.0
        while lam > 1e-3 and np.abs(period_map(z + lam * dz)[0] - z - lam * dz).max() > np.abs(r).max():
            lam *= 0.5
        z = z + lam * dz
    zT, xs = period_map(z, keep=True)
    return z, float(xs.max()), float(xs.min()), float(np.abs(zT - z).max())


def hb_state(u, w, H):
    """``(x, x')`` at ``t = 0`` of a one-dof HB solution ``u = [a0, a1, b1, ...]``."""
    return float(u[0] + u[1:2 * H + 1:2].sum()), float(sum(k * w * u[2 * k] for k in range(1, H + 1)))


def duffing_folds(F, c):
    """Folds in ``w`` of the ``H = 1`` Duffing amplitude equation
    ``[(1 - w^2 + 3/4 A^2)^2 + (c w)^2] A^2 = F^2`` (x'' + c x' + x + x^3 = F cos w t).

    In ``rho = A^2`` the equation is the cubic ``p rho^3 + 3/2 a rho^2 + (a^2 +
    c^2 w^2) rho - F^2`` (``p = 9/16``, ``a = 1 - w^2``); at a fold it has a double
    root ``r`` and a simple root ``s``: ``p (rho - r)^2 (rho - s)``. Matching the
    coefficients gives ``s = F^2 / (p r^2)``, ``a = -3/8 (2 r + s)`` and, after the
    ``r^2`` terms cancel exactly on paper,

        g(r) = r s - s^2 / 4 - c^2 w^2 / p = 0,

    a well-conditioned equation in ``r`` alone (forming the cubic's
    discriminant instead cancels terms of size ``rho^3`` down to ``F^2``: useless
    for ``F = 1e-5``). Each root of ``g`` is one fold; near the cusp the two
    roots are ``~sqrt(F - F_c)`` apart in ``r``.
    """
    p = 9 / 16

    def parts(r):
        s = F * F / (p * r * r)
        a = -0.375 * (2 * r + s)
        return s, a

    def g(r):
        s, a = parts(r)
        return (r * s - s * s / 4 - c * c * (1 - a) / p) / (r * s)

    grid = np.geomspace(1e-14, 1e4, 400001)
    vals = g(grid)
    out = []
    for i in np.flatnonzero(np.sign(vals[1:]) != np.sign(vals[:-1])):
        r = brentq(g, grid[i], grid[i + 1], xtol=1e-300, rtol=1e-15)
        s, a = parts(r)
        if a < 1:  # a real frequency
            out.append(math.sqrt(1 - a))
    return sorted(out)


def duffing_cusp(c):
    """Cusp of the Duffing folds: ``(w_c, F_c, rho_c)``.

    ``G = G_rho = G_rhorho = 0``: ``G_rhorho = 0`` gives ``rho = -8 a / 9``; then
    ``G_rho = 0`` reduces to ``a^2 = 3 c^2 w^2``, i.e. ``w^2 - sqrt(3) c w - 1 = 0``.
    """
    wc = (math.sqrt(3) * c + math.sqrt(3 * c * c + 4)) / 2
    a = 1 - wc * wc
    rho = -8 * a / 9
    Fc = math.sqrt(9 / 16 * rho**3 + 1.5 * a * rho**2 + (a * a + (c * wc) ** 2) * rho)
    return wc, Fc, rho
