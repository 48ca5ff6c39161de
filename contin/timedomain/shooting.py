"""Periodic orbits of the time integrator by shooting: an independent reference for harmonic balance.

Harmonic balance solves a truncated problem. Where the truncation converges
slowly (orbits that graze or hit a contact converge algebraically in ``H``),
its bifurcations can lie far from those of the equations of motion, and no
result of the harmonic-balance code can tell by how much. Shooting finds the
periodic orbit of the time integrator itself,

    F(z) = phi_T(z) - z = 0,        T = nu 2 pi / w,

with ``phi_T`` the flow map of :func:`contin.timedomain.simulation.simulate` (compiled
RK4, contact switches located in time: fourth order through them) and
``z = (x, x')`` the state at ``t = 0`` (shape (2n,)). Newton's matrix is
``Phi - I`` with the monodromy ``Phi = d phi_T / dz`` taken by central
differences of the flow map in the ``2n`` directions of the state, the
construction the tests use as the truth for the saltation matrices
(``tests/stability/test_saltation.py``). The monodromy at the converged orbit
comes with it, so the Floquet multipliers are those of the integrated flow,
saltation included, not of a harmonic-balance orbit. The module shares only
the model's compiled time-domain kernels with the harmonic-balance code; it
is a reference (``2n + 1`` simulations of one period per Newton step), not
the production path.

Period doubling: a real multiplier crosses -1 exactly where the flip test

    d(lambda) = det(Phi + I) = prod_i (mu_i + 1)

changes sign (a complex pair contributes ``|mu + 1|^2 > 0``; Kuznetsov,
*Elements of Applied Bifurcation Theory*, 3rd ed., 2004, sec. 7.4). It is
located by Brent's method in the parameter, each evaluation a converged orbit.

Branches: :class:`ShootingProblem` and :class:`ShootingOptions` live in
:mod:`contin.timedomain.multiple_shooting` (multiple shooting with the
variational equations, the production discretisation),
:class:`ShootingStability` and :func:`period_doubling_start` in
:mod:`contin.timedomain.shooting_bifurcations`; all are re-exported here. This module keeps the single-shooting reference of central differences:
:func:`flow_map`, :func:`periodic_orbit` and :func:`period_doubling_scan`.
Where an orbit starts or stops touching a contact (grazing) the flow map
stays continuous but its derivative jumps, so the branch has a corner there,
which harmonic balance, whose truncated series ripples about the contact,
cannot pass (:mod:`contin.timedomain.shooting_events`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping

import numpy as np

from contin.timedomain.multiple_shooting import ShootingProblem, flip_test
from contin.timedomain.shooting_options import ShootingOptions
from contin.timedomain.shooting_bifurcations import ShootingStability, period_doubling_start
from contin.timedomain.simulation import SimulationError, simulate

__all__ = ["ShootingOptions", "ShootingOrbit", "PeriodDoublingScan", "ShootingProblem", "ShootingStability",
           "flow_map", "periodic_orbit", "period_doubling_scan", "period_doubling_start"]


@dataclasses.dataclass
class ShootingOrbit:
    """A periodic orbit of the integrated flow (or the last Newton iterate, with ``converged`` False).

    Attributes
    ----------
    params : dict
        Parameter overrides it was computed with.
    state : ndarray, shape (2n,)
        ``(x, x')`` at ``t = 0``.
    monodromy : ndarray, shape (2n, 2n)
        ``d phi_T / dz`` at ``state`` (central differences of the flow).
    multipliers : ndarray of complex, shape (2n,)
        Eigenvalues of ``monodromy``, by decreasing modulus.
    residual : float
        ``max |phi_T(state) - state|``.
    iterations : int
    converged : bool
    message : str
    """

    params: dict
    state: np.ndarray
    monodromy: np.ndarray
    multipliers: np.ndarray
    residual: float
    iterations: int
    converged: bool
    message: str

    @property
    def flip_test(self) -> float:
        """``det(Phi + I)``: changes sign where a real multiplier crosses -1."""
        return _flip(self.multipliers)

    @property
    def stable(self) -> bool:
        return bool(np.abs(self.multipliers).max() < 1.0)


_flip = flip_test


def flow_map(model, params: Mapping[str, float], z: np.ndarray, options: ShootingOptions = ShootingOptions()):
    """``phi_T(z)``: the state after ``nu`` forcing periods from ``z`` at ``t = 0``, shape (2n,)."""
    n = model.n_dof
    z = np.asarray(z, float)
    S = options.steps_per_period
    run = simulate(model, dict(params), z[:n], z[n:], periods=options.subharmonic, steps_per_period=S,
                   record_every=S * options.subharmonic)
    return run.final_state


def _flow_and_jacobian(model, params, z, options):
    """``phi_T(z)`` and its central-difference Jacobian (``2n + 1`` integrations)."""
    f0 = flow_map(model, params, z, options)
    m = z.size
    h = options.fd_step * max(1.0, float(np.max(np.abs(z))))
    Phi = np.empty((m, m))
    for j in range(m):
        e = np.zeros(m)
        e[j] = h
        Phi[:, j] = (flow_map(model, params, z + e, options) - flow_map(model, params, z - e, options)) / (2.0 * h)
    return f0, Phi


def periodic_orbit(model, params: Mapping[str, float], z0, options: ShootingOptions = ShootingOptions()) -> ShootingOrbit:
    """Newton on ``phi_T(z) - z = 0`` from ``z0`` (module docstring).

    Never raises for a numerical failure: a Newton that does not converge in
    ``max_iter`` steps, a singular ``Phi - I`` (a multiplier +1) or a flow
    that blows up returns the last finite iterate with ``converged`` False and
    the reason in ``message``.

    Parameters
    ----------
    model : Model
    params : dict
        Parameter overrides by name (the frequency included when it differs
        from the model's).
    z0 : array_like, shape (2n,)
    options : ShootingOptions
    """
    params = dict(params)
    z = np.array(z0, dtype=float)
    if z.shape != (2 * model.n_dof,):
        raise ValueError(f"z0 must have shape ({2 * model.n_dof},) = (x, x') of model '{model.name}', got {z.shape}")
    m = z.size
    Phi = np.full((m, m), 0.0)
    res = math.inf
    message = ""
    converged = False
    it = 0
    for it in range(options.max_iter + 1):
        try:
            f, Phi_new = _flow_and_jacobian(model, params, z, options)
        except SimulationError as exc:
            message = f"the flow blew up from iterate {it}: {exc}"
            break
        if not (np.all(np.isfinite(f)) and np.all(np.isfinite(Phi_new))):
            message = f"non-finite flow map at iterate {it}"
            break
        Phi = Phi_new
        r = f - z
        res = float(np.max(np.abs(r)))
        if res <= options.tol * max(1.0, float(np.max(np.abs(z)))):
            converged = True
            message = f"converged in {it} Newton steps, residual {res:.1e}"
            break
        if it == options.max_iter:
            message = f"Newton did not converge in {options.max_iter} steps (residual {res:.1e})"
            break
        A = Phi - np.eye(m)
        if np.linalg.cond(A) > 1e14:
            message = f"Phi - I is singular at iterate {it} (a multiplier +1: a fold or a branch point)"
            break
        dz = np.linalg.solve(A, -r)
        if not np.all(np.isfinite(dz)):
            message = f"non-finite Newton step at iterate {it}"
            break
        z = z + dz
    mu = np.linalg.eigvals(Phi)
    mu = mu[np.argsort(-np.abs(mu))]
    return ShootingOrbit(params, z, Phi, mu, res, it, converged, message)


@dataclasses.dataclass
class PeriodDoublingScan:
    """Orbits along a grid of one parameter, and the period doublings located between them.

    Attributes
    ----------
    parameter : str
    values : ndarray, shape (K,)
        Grid values with a converged orbit (in the order scanned).
    flip : ndarray, shape (K,)
        ``det(Phi + I)`` there.
    orbits : list of ShootingOrbit
    points : list of ShootingOrbit
        Located period doublings (``params[parameter]`` is the located value).
    located : list of bool
        Whether Brent's method converged for each point (False: the bracket's midpoint, with why in
        the orbit's message).
    status : str
        ``complete`` or ``failed`` (an orbit did not converge; the scan ends there).
    message : str
    """

    parameter: str
    values: np.ndarray
    flip: np.ndarray
    orbits: list
    points: list
    located: list
    status: str
    message: str


class _OrbitFailed(ArithmeticError):
    pass


def period_doubling_scan(model, params: Mapping[str, float], parameter: str, values, z0,
                         options: ShootingOptions = ShootingOptions(), xtol: float = 1e-10,
                         hidden_pairs: bool = True) -> PeriodDoublingScan:
    """Follow the orbit over ``values`` of ``parameter`` (natural continuation) and locate its period doublings.

    Each orbit starts from the previous one. Between two grid values where the
    flip test changes sign, the period doubling is located by Brent's method to
    ``xtol`` in the parameter. Two period doublings close together (near the
    tip of a region, where they merge) can fall between two grid values without
    a sign change: with ``hidden_pairs``, at every interior local minimum of a
    positive flip test on the grid, its minimum between the neighbours is
    found (bounded Brent), and if negative the pair is located on both sides
    of it. A grid value whose orbit does not converge ends the scan with status
    ``failed`` and keeps what was computed.

    Parameters
    ----------
    model : Model
    params : dict
        The other parameter overrides.
    parameter : str
    values : array_like, shape (K,)
        Monotonic grid; the grid must be fine enough that no two period
        doublings fall between neighbours.
    z0 : array_like, shape (2n,)
        A state near the orbit at ``values[0]``.
    """
    from scipy.optimize import brentq, minimize_scalar  # here: most runs never scan by shooting

    if parameter not in model.parameters:
        raise ValueError(f"unknown parameter {parameter!r} of model '{model.name}'; valid: {list(model.parameters)}")
    values = np.asarray(values, float)
    if values.ndim != 1 or values.size < 2 or not (np.all(np.diff(values) > 0) or np.all(np.diff(values) < 0)):
        raise ValueError("values must be a monotonic list of at least two parameter values")
    base = dict(params)
    z = np.asarray(z0, float)
    done, flips, orbits, points, located = [], [], [], [], []
    status, message = "complete", f"{values.size} orbits"

    def orbit_at(v, guess):
        orb = periodic_orbit(model, {**base, parameter: float(v)}, guess, options)
        if not orb.converged:
            raise _OrbitFailed(f"{parameter} = {v:.10g}: {orb.message}")
        return orb

    def locate(a, b, start):
        """The sign change of the flip test between ``a`` and ``b`` (orbits from ``start``)."""
        last = {"orbit": start}

        def test(lam):
            o = orbit_at(lam, last["orbit"].state)
            last["orbit"] = o
            return o.flip_test

        try:
            lam = brentq(test, a, b, xtol=xtol, rtol=4 * np.finfo(float).eps, maxiter=100)
            points.append(orbit_at(lam, last["orbit"].state))
            located.append(True)
        except (_OrbitFailed, RuntimeError) as exc:
            mid = last["orbit"]
            mid.message = f"period doubling between {a:.10g} and {b:.10g} not located: {exc}"
            points.append(mid)
            located.append(False)

    for v in values:
        try:
            orb = orbit_at(v, z)
        except _OrbitFailed as exc:
            status, message = "failed", f"the orbit was lost at {exc}; {len(done)} orbits kept"
            break
        if orbits and np.sign(orb.flip_test) != np.sign(orbits[-1].flip_test):
            locate(done[-1], float(v), orbits[-1])
        z = orb.state
        done.append(float(v))
        flips.append(orb.flip_test)
        orbits.append(orb)
    if hidden_pairs:
        for i in range(1, len(done) - 1):
            f = flips
            if not (0 < f[i] <= f[i - 1] and f[i] <= f[i + 1] and f[i + 1] > 0):
                continue
            a, b = sorted((done[i - 1], done[i + 1]))
            near = {"orbit": orbits[i]}

            def flip_at(lam):
                o = orbit_at(lam, near["orbit"].state)
                near["orbit"] = o
                return o.flip_test

            try:
                res = minimize_scalar(flip_at, bounds=(a, b), method="bounded",
                                      options={"xatol": xtol * max(1.0, abs(a))})
            except _OrbitFailed:
                continue
            if res.fun < 0:
                centre = near["orbit"]
                locate(min(done[i - 1], float(res.x)), max(done[i - 1], float(res.x)), centre)
                locate(min(float(res.x), done[i + 1]), max(float(res.x), done[i + 1]), centre)
    order = np.argsort([float(p.params[parameter]) for p in points])
    points = [points[k] for k in order]
    located = [located[k] for k in order]
    return PeriodDoublingScan(parameter, np.array(done), np.array(flips), orbits, points, located, status, message)
