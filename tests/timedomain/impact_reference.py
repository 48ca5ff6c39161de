"""An event-driven shooting reference for oscillators with one-sided elastic stops (scipy only).

Independent of contin: it imports numpy and scipy and nothing of the package,
so that a periodic orbit contin computes can be checked against one computed
by a different integrator, a different switch handling and a different Newton.

The systems are mechanical chains

    M x'' + C x' + K x + sum_i a_i x_{c_i}^3 e_{c_i} + sum_j k_j (x_{s_j} - g_j) H(x_{s_j} - g_j) e_{s_j}
        = F cos(w t) e_f

(cubic springs to ground on dofs ``c_i``, soft one-sided stops of stiffness
``k_j`` beyond the gaps ``g_j`` on dofs ``s_j``, harmonic forcing on dof ``f``).
The state is ``z = (x, x')``; the switching functions are
``h_j(z) = x_{s_j} - g_j`` (contact where ``h_j > 0``).

The flow map
------------
``scipy.integrate.solve_ivp`` (DOP853, ``rtol = 1e-12``, ``atol = 1e-13``)
integrates each piece between switches in its own smooth law (the set of stops
in contact is fixed on a piece), with a terminal event on every switching
function in the direction that leaves the piece's mode: a piece that starts on
a switching surface cannot stop at once where it started. At a located switch
the mode flips and the next piece starts there.

The monodromy comes from the variational equations ``Phi' = A(t, z) Phi``
integrated with the state on each piece, and the saltation matrix

    S = I + (f+ - f-) grad(h)^T / (grad(h) . f-)

at every switch (Leine & Nijmeijer, *Dynamics and Bifurcations of Non-Smooth
Mechanical Systems*, Springer 2004, sec. 7.2). A soft stop's force is zero at
its surface, so ``f+ = f-`` and ``S = I``: the orbit's Jacobian is continuous
across a switch, and only its time derivative jumps. The general formula is
kept so that the reference would stay right for a law that jumps.

Periodic orbits are found by Newton on ``phi_T(z) - z = 0`` with ``T = 2 pi / w``
(forcing phase zero at ``t = 0``) and ``Phi - I`` as its matrix; branches by
natural continuation in ``w`` (each orbit from the previous one, or the secant
of the last two); the grazing frequency by Brent's method on the orbit's
largest ``x_s - g`` (the maxima of ``x_s`` located as events ``x_s' = 0``).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

RTOL = 1e-12
ATOL = 1e-13
#: Newton ends when max |phi_T(z) - z| falls below this (times max(1, |z|))
NEWTON_TOL = 1e-11


@dataclasses.dataclass(frozen=True)
class Chain:
    """A forced mechanical chain with cubic springs and soft one-sided stops (module docstring).

    Attributes
    ----------
    M, C, K : ndarray, shape (n, n)
    cubic : tuple of (dof, a)
        ``a x_dof^3`` on ``dof``, to ground.
    stops : tuple of (dof, gap, stiffness)
        ``stiffness (x_dof - gap)`` on ``dof`` where ``x_dof > gap``.
    forcing : tuple of (dof, F)
        ``F cos(w t)`` on ``dof``.
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    cubic: tuple = ()
    stops: tuple = ()
    forcing: tuple = ()

    @property
    def n(self) -> int:
        return self.M.shape[0]

    @functools.cached_property
    def Minv(self) -> np.ndarray:
        return np.linalg.inv(self.M)

    def switching(self, z):
        """``h_j(z) = x_{s_j} - g_j`` for every stop, shape (n_stops,)."""
        return np.array([z[dof] - gap for dof, gap, _ in self.stops])

    def mode_of(self, z):
        """Stops in contact at ``z`` (``h_j > 0``; on the surface, the side the velocity points to)."""
        n = self.n
        out = []
        for dof, gap, _ in self.stops:
            h = z[dof] - gap
            if h == 0.0:
                out.append(bool(z[n + dof] > 0.0))
            else:
                out.append(bool(h > 0.0))
        return tuple(out)

    def _force(self, t, x, w, mode):
        f = np.zeros(self.n)
        for dof, F in self.forcing:
            f[dof] += F * math.cos(w * t)
        for dof, a in self.cubic:
            f[dof] -= a * x[dof] ** 3
        for (dof, gap, k), on in zip(self.stops, mode):
            if on:
                f[dof] -= k * (x[dof] - gap)
        return f

    def _stiffness(self, x, mode):
        Kt = np.array(self.K, dtype=float)
        for dof, a in self.cubic:
            Kt[dof, dof] += 3.0 * a * x[dof] ** 2
        for (dof, _, k), on in zip(self.stops, mode):
            if on:
                Kt[dof, dof] += k
        return Kt

    def rhs(self, t, z, w, mode):
        """``z' = f(t, z)`` in ``mode`` (the law of the piece)."""
        n = self.n
        x, v = z[:n], z[n:]
        acc = self.Minv @ (self._force(t, x, w, mode) - self.C @ v - self.K @ x)
        return np.concatenate([v, acc])

    def jacobian(self, t, z, w, mode):
        """``d f / d z`` in ``mode``, shape (2n, 2n)."""
        n = self.n
        Minv = self.Minv
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -Minv @ self._stiffness(z[:n], mode)
        A[n:, n:] = -Minv @ self.C
        return A


def impact_oscillator(zeta: float, ks: float, g: float, F: float) -> Chain:
    """``x'' + 2 zeta x' + x + ks (x - g) H(x - g) = F cos(w t)``."""
    one = np.ones((1, 1))
    return Chain(M=one, C=2.0 * zeta * one, K=one, stops=((0, g, ks),), forcing=((0, F),))


def chain_stop(m1=1.0, m2=1.0, k1=1.0, k2=1.0, c=0.02, a=0.5, g=0.3, kc=20.0, F=0.15) -> Chain:
    """Two masses, ``k1`` and a damper ``c`` to ground on the first, ``k2`` and ``c`` between them,
    ``a x1^3`` to ground, a one-sided stop on ``x2`` (gap ``g``, stiffness ``kc``), ``F cos(w t)`` on ``x1``."""
    return Chain(M=np.diag([m1, m2]), C=np.array([[2 * c, -c], [-c, c]]),
                 K=np.array([[k1 + k2, -k2], [-k2, k2]]), cubic=((0, a),), stops=((1, g, kc),),
                 forcing=((0, F),))


def _flip(mode, j):
    return tuple((not on) if i == j else on for i, on in enumerate(mode))


def _missed_switch(system: Chain, sol, mode, t_a: float, t_end: float):
    """The first switch the terminal events stepped over in ``[t_a, t_end)``: ``(t, stop)`` or None.

    A step can jump over a whole short contact arc (near grazing, both ends of
    the step on the free side). Every extremum of a stop's ``x`` along the
    piece is located (non-terminal events ``x' = 0``, ``sol.t_events[k + 1]``
    for stop ``k``); one on the wrong side of the surface for the piece's mode
    means the surface was crossed between it and the extremum before it, where
    ``h`` is monotone: Brent's method on the dense output finds the crossing.
    """
    first = None
    for k, (dof, gap, _) in enumerate(system.stops):
        te, ye = sol.t_events[2 * k + 1], sol.y_events[2 * k + 1]
        for i, (tm, ym) in enumerate(zip(te, ye)):
            h = ym[dof] - gap
            if tm >= t_end or tm <= t_a:
                continue
            if (h < 0.0) if mode[k] else (h > 0.0):
                before = te[i - 1] if i > 0 and te[i - 1] > t_a else t_a
                tc = brentq(lambda t, dof=dof, gap=gap: sol.sol(t)[dof] - gap, before, tm, xtol=1e-15, rtol=1e-15)
                if first is None or tc < first[0]:
                    first = (tc, k)
                break
    return first


def flow(system: Chain, z0, w: float, t0: float, t1: float, jacobian: bool = True):
    """Integrate from ``(t0, z0)`` to ``t1``, piece by piece between switches.

    Returns
    -------
    z1 : ndarray, shape (2n,)
    Phi : ndarray, shape (2n, 2n) or None
        ``d z1 / d z0`` (variational equations and saltation matrices).
    pieces : list of (t_a, t_b, mode, sol)
        The pieces, ``sol`` the dense output of each (valid on ``[t_a, t_b]``).
    """
    m = 2 * system.n
    n = system.n
    z = np.array(z0, dtype=float)
    Phi = np.eye(m) if jacobian else None
    mode = system.mode_of(z)
    t = float(t0)
    pieces = []
    for _ in range(10000):
        if t >= t1:
            break
        events = []
        for j, (dof, gap, _) in enumerate(system.stops):
            def ev(tt, y, dof=dof, gap=gap, start=t, side=1e-300 if mode[j] else -1e-300):
                # just after the piece's start the state lies on the surface it has just crossed
                # (h rounds to either sign, or to 0): counted on the piece's own side, so that
                # the crossing is not found again
                return side if tt - start <= 1e-9 else y[dof] - gap
            ev.terminal = True
            ev.direction = -1.0 if mode[j] else 1.0  # leave the piece's mode only
            events.append(ev)

            def extremum(tt, y, dof=dof):
                return y[n + dof]
            events.append(extremum)  # located, not terminal: see _missed_switch

        md = mode
        if jacobian:
            def fun(tt, y, md=md):
                zz = y[:m]
                P = y[m:].reshape(m, m)
                return np.concatenate([system.rhs(tt, zz, w, md), (system.jacobian(tt, zz, w, md) @ P).ravel()])
            y0 = np.concatenate([z, Phi.ravel()])
        else:
            def fun(tt, y, md=md):
                return system.rhs(tt, y, w, md)
            y0 = z
        sol = solve_ivp(fun, (t, t1), y0, method="DOP853", rtol=RTOL, atol=ATOL, events=events or None,
                        dense_output=True)
        if sol.status < 0:
            raise ArithmeticError(f"solve_ivp failed at t = {t}: {sol.message}")
        t_end = float(sol.t[-1])
        y = sol.y[:, -1]
        hit = [j for j in range(len(system.stops)) if sol.t_events[2 * j].size]
        switch = (float(sol.t_events[2 * hit[0]][0]), hit[0]) if sol.status == 1 and hit else None
        missed = _missed_switch(system, sol, mode, t, t_end)
        if missed is not None and (switch is None or missed[0] < switch[0]):
            switch = missed
            y = sol.sol(missed[0])
        elif switch is not None:
            y = sol.y_events[2 * switch[1]][0]
        z = np.array(y[:m])
        if jacobian:
            Phi = np.array(y[m:]).reshape(m, m)
        if switch is None:
            pieces.append((t, t_end, mode, sol.sol))
            t = t_end
            continue
        t_s, j = switch
        if t_s - t <= 1e-9:
            raise ArithmeticError(f"a switch at the start of a piece (t = {t}): the orbit is too close to grazing")
        pieces.append((t, t_s, mode, sol.sol))
        new = _flip(mode, j)
        if jacobian:
            grad = np.zeros(m)
            grad[system.stops[j][0]] = 1.0
            f_minus = system.rhs(t_s, z, w, mode)
            f_plus = system.rhs(t_s, z, w, new)
            S = np.eye(m) + np.outer(f_plus - f_minus, grad) / (grad @ f_minus)
            Phi = S @ Phi
        mode = new
        t = t_s
    else:
        raise ArithmeticError("more than 10000 switches in one integration")
    return z, Phi, pieces


@dataclasses.dataclass
class Orbit:
    """A periodic orbit: its state at ``t = 0``, its monodromy and its extremes."""

    w: float
    z: np.ndarray
    monodromy: np.ndarray
    residual: float
    iterations: int

    @property
    def multipliers(self):
        mu = np.linalg.eigvals(self.monodromy)
        return mu[np.argsort(-np.abs(mu))]


def periodic_orbit(system: Chain, w: float, z0, max_iter: int = 30) -> Orbit:
    """Newton on ``phi_T(z) - z = 0``, ``T = 2 pi / w``; raises ``ArithmeticError`` if it does not converge."""
    z = np.array(z0, dtype=float)
    T = 2.0 * math.pi / w
    m = z.size
    z1, Phi, _ = flow(system, z, w, 0.0, T)
    r = z1 - z
    for it in range(max_iter + 1):
        res = float(np.max(np.abs(r)))
        if res <= NEWTON_TOL * max(1.0, float(np.max(np.abs(z)))):
            return Orbit(w, z, Phi, res, it)
        dz = np.linalg.solve(Phi - np.eye(m), -r)
        # backtracking: near grazing the map's derivative changes fast with z (a contact arc
        # appearing within a step), and full steps can cycle between the two sides
        for _ in range(30):
            z_new = z + dz
            z1, Phi_new, _ = flow(system, z_new, w, 0.0, T)
            r_new = z1 - z_new
            if np.linalg.norm(r_new) < np.linalg.norm(r) or np.linalg.norm(dz) < 1e-15:
                break
            dz = dz / 2.0
        z, Phi, r = z_new, Phi_new, r_new
    raise ArithmeticError(f"Newton did not converge at w = {w} in {max_iter} steps (residual {res:.1e})")


def continuation(system: Chain, ws, z0) -> list:
    """Orbits at the frequencies ``ws`` in order, each Newton started from the secant of the last two."""
    out = []
    for w in ws:
        if len(out) >= 2:
            a, b = out[-2], out[-1]
            guess = b.z + (b.z - a.z) * (w - b.w) / (b.w - a.w)
        elif out:
            guess = out[-1].z
        else:
            guess = z0
        out.append(periodic_orbit(system, float(w), guess))
    return out


def extremes(system: Chain, orbit: Orbit, dof: int):
    """``(max, min)`` of ``x_dof`` over the orbit's period, located on the dense output (``x_dof' = 0``)."""
    n = system.n
    T = 2.0 * math.pi / orbit.w
    _, _, pieces = flow(system, orbit.z, orbit.w, 0.0, T, jacobian=False)
    values = [orbit.z[dof]]
    for ta, tb, _, sol in pieces:
        ts = np.linspace(ta, tb, 65)
        vs = np.array([sol(t)[n + dof] for t in ts])
        for i in np.flatnonzero(np.sign(vs[:-1]) != np.sign(vs[1:])):
            tz = brentq(lambda t, sol=sol: sol(t)[n + dof], ts[i], ts[i + 1], xtol=1e-15, rtol=1e-15)
            values.append(sol(tz)[dof])
        values.append(sol(tb)[dof])
    return float(max(values)), float(min(values))


def without_stop(system: Chain, stop: int) -> Chain:
    """``system`` with stop ``stop`` removed (the law on the free side of its surface)."""
    return dataclasses.replace(system, stops=tuple(s for i, s in enumerate(system.stops) if i != stop))


def grazing_frequency(system: Chain, w_lo: float, w_hi: float, z_lo, stop: int = 0) -> float:
    """The frequency in ``(w_lo, w_hi)`` where an orbit free of stop ``stop`` touches it: ``max x_s = g``.

    Brent's method on ``w -> max x_s - g`` of the periodic orbit of the law
    without that stop (one sign change in the bracket; every orbit from the
    nearest one already found). At the grazing frequency that orbit is the
    orbit of the whole system, touching the surface tangentially; beside it,
    on the contact side, the whole system's orbit has a contact arc, and the
    distance is a smooth function of ``w`` only on the free side (the flow of
    the whole system is only once differentiable at grazing, which slows
    Newton there).
    """
    dof, gap, _ = system.stops[stop]
    free = without_stop(system, stop)
    cache = {w_lo: periodic_orbit(free, w_lo, z_lo)}

    def distance(w):
        near = min(cache, key=lambda v: abs(v - w))
        o = periodic_orbit(free, w, cache[near].z)
        cache[w] = o
        return extremes(free, o, dof)[0] - gap

    return brentq(distance, w_lo, w_hi, xtol=1e-14, rtol=1e-15)


def switches(system: Chain, orbit: Orbit) -> int:
    """Located switches of the whole system over the orbit's period."""
    _, _, pieces = flow(system, orbit.z, orbit.w, 0.0, 2.0 * math.pi / orbit.w, jacobian=False)
    return sum(1 for a, b in zip(pieces[:-1], pieces[1:]) if a[2] != b[2])


def harmonics(system: Chain, orbit: Orbit, dof: int, K: int):
    """``(a, b)``, shape (K + 1,) each: ``x_dof(t) = a_0 + sum_k a_k cos(k w t) + b_k sin(k w t)``, ``k <= K``.

    Gauss-Legendre quadrature (20 nodes on 16 subintervals of every piece) of the dense output.
    """
    T = 2.0 * math.pi / orbit.w
    _, _, pieces = flow(system, orbit.z, orbit.w, 0.0, T, jacobian=False)
    xg, wg = np.polynomial.legendre.leggauss(20)
    k = np.arange(K + 1)[:, None]
    a = np.zeros(K + 1)
    b = np.zeros(K + 1)
    for ta, tb, _, sol in pieces:
        edges = np.linspace(ta, tb, 17)
        for lo, hi in zip(edges[:-1], edges[1:]):
            t = 0.5 * (hi - lo) * xg + 0.5 * (hi + lo)
            x = sol(t)[dof]
            a += 0.5 * (hi - lo) * np.sum(wg * x * np.cos(k * orbit.w * t), axis=1)
            b += 0.5 * (hi - lo) * np.sum(wg * x * np.sin(k * orbit.w * t), axis=1)
    scale = np.full(K + 1, 2.0 / T)
    scale[0] = 1.0 / T
    return a * scale, b * scale


def fourier(system: Chain, orbit: Orbit, dof: int, k: int):
    """``(a_k, b_k)`` of :func:`harmonics`."""
    a, b = harmonics(system, orbit, dof, k)
    return float(a[k]), float(b[k])


def linear_orbit_state(system: Chain, w: float):
    """Closed form of the forced linear chain (no cubic spring, no contact): ``z`` at ``t = 0``.

    ``X = (K - w^2 M + i w C)^{-1} F``, ``x(t) = Re(X e^{i w t})``.
    """
    f = np.zeros(system.n, dtype=complex)
    for dof, F in system.forcing:
        f[dof] += F
    X = np.linalg.solve(system.K - w ** 2 * system.M + 1j * w * system.C, f)
    return np.concatenate([X.real, (1j * w * X).real])


def impact_grazing_closed_form(zeta: float, g: float, F: float) -> tuple:
    """The two frequencies where the linear oscillator's amplitude ``F / |1 - w^2 + 2 i zeta w|`` is ``g``.

    ``(1 - s)^2 + 4 zeta^2 s = (F / g)^2`` with ``s = w^2``.
    """
    b = 1.0 - 2.0 * zeta ** 2
    d = math.sqrt(b * b - 1.0 + (F / g) ** 2)
    return math.sqrt(b - d), math.sqrt(b + d)
