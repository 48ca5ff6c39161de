"""Monodromy matrix of a harmonic-balance solution by time integration.

The first-order variational equations of ``M x'' + C x' + K x + f(x, x', tau) = f_ext(tau)``
about the periodic solution ``x*(t)`` are

    z' = A(t) z,    A = [[0, I], [-M^-1 (K + df/dx), -M^-1 (C + df/dx')]],    z = (dx, dx'),

and the monodromy matrix is ``Phi(T)`` with ``Phi(0) = I``, ``T = 2 pi nu / w``;
its eigenvalues are the Floquet multipliers.

Two paths are provided:

- :func:`monodromy_rk4` (production): the force elements are evaluated once,
  in one vectorised call per element, on ``2S`` points of the HB orbit
  (``S`` steps per period, the RK4 stages need the half steps), and
  ``Phi`` is propagated by a numba-compiled fixed-step classical Runge-Kutta
  scheme. For smooth forces the error is ``O(h^4)``, ``h = T/S``.
- :func:`monodromy_reference`: ``scipy.integrate.solve_ivp`` (DOP853, tight
  tolerances) of the *full nonlinear* state together with the variational
  equations, started from the HB state at ``t = 0``. It measures the HB
  truncation error too (``orbit_error``: how far the true flow is from
  returning to the start after one period). :func:`monodromy_orbit_ivp`
  integrates the variational equations along the HB orbit itself with the
  same adaptive scheme, isolating the error of the fixed-step scheme.

Non-smooth forces
-----------------
Piecewise-linear laws (gaps, clearances) have a Jacobian ``df/dx`` that jumps
where the orbit crosses a switching surface while the force itself stays
continuous. The flow is then still continuous in the initial state and no
saltation matrix is needed (it is the identity for a continuous vector
field), but the fixed-step RK4 on the sampled orbit does not resolve the
crossing instant: its stages integrate a step function, which costs an
``O(h)`` local error at each crossing, hence a first-order global error in
``h`` (refine ``steps_per_period``; the test suite and the benchmark show
the measured order). Where the force law *itself* jumps (impacts with a
velocity-dependent contact force switched on with a non-zero velocity,
Coulomb friction), the monodromy matrix must include the saltation matrix
``S = I + (f+ - f-) n^T / (n^T f-)`` at each switching event (Leine & Nijmeijer,
*Dynamics and Bifurcations of Non-Smooth Mechanical Systems*, Springer 2004,
ch. 7); neither path here inserts saltation matrices, so the multipliers of
such orbits are not reliable, and Hill's method, which smears the jump over
the harmonics, is no better.
"""

from __future__ import annotations

import dataclasses

import numba as nb
import numpy as np
from scipy.integrate import solve_ivp

from contin import aft
from contin.harmonics import coefficient_blocks

__all__ = [
    "Monodromy",
    "state_matrices",
    "rk4_propagate",
    "monodromy_rk4",
    "monodromy_orbit_ivp",
    "monodromy_reference",
    "orbit_state",
]


@dataclasses.dataclass(frozen=True, eq=False)
class Monodromy:
    """A monodromy matrix and how it was obtained.

    Attributes
    ----------
    matrix : ndarray, shape (2n, 2n)
        ``Phi(T)`` for the state ``z = (x, x')``.
    period : float
    method : str
        ``"rk4"``, ``"orbit-dop853"`` or ``"dop853"``.
    steps : int
        RK4 steps per period (0 for the adaptive paths; then the number of
        right-hand-side evaluations is in ``evaluations``).
    evaluations : int
    orbit_error : float
        For ``"dop853"`` only: ``max |z(T) - z(0)|`` of the nonlinear flow
        started on the HB state (NaN otherwise).
    """

    matrix: np.ndarray
    period: float
    method: str
    steps: int = 0
    evaluations: int = 0
    orbit_error: float = float("nan")

    @property
    def multipliers(self) -> np.ndarray:
        """Eigenvalues of :attr:`matrix`, shape (2n,) complex."""
        return np.linalg.eigvals(self.matrix)


def _frequency(hb, lam: float) -> float:
    Omega = float(hb.params_at(lam)[hb.kw]) / hb.nu
    if not Omega > 0:
        raise ValueError(f"the monodromy needs a positive excitation frequency, got w/nu = {Omega}")
    return Omega


def _force_jacobians(hb, x, xd, tau, p):
    N, n = x.shape
    f = np.zeros((N, n))
    dfdx = np.zeros((N, n, n))
    dfdxd = np.zeros((N, n, n))
    for el in hb.model.forces:
        el.evaluate(x, xd, tau, p, f, dfdx, dfdxd)
    return f, dfdx, dfdxd


def state_matrices(hb, u: np.ndarray, lam: float, samples: int):
    """``A(t_j)`` on ``t_j = j T / samples`` along the HB orbit.

    The force elements are called once each, on all samples.

    Parameters
    ----------
    hb : HarmonicBalance
    u : ndarray, shape (hb.size,)
    lam : float
    samples : int
        ``>= 2H+1``.

    Returns
    -------
    A : ndarray, shape (samples, 2n, 2n)
    period : float
    """
    n = hb.n
    if samples < 2 * hb.H + 1:
        raise ValueError(f"need at least 2H+1 = {2 * hb.H + 1} orbit samples, got {samples}")
    p = hb.params_at(lam)
    Omega = _frequency(hb, lam)
    U = np.ascontiguousarray(coefficient_blocks(u, n))
    x, xp = aft.synthesize(U, samples)
    xd = Omega * xp
    theta = 2.0 * np.pi * np.arange(samples) / samples
    _, dfdx, dfdxd = _force_jacobians(hb, x, xd, hb.nu * theta, p)
    M, C, K = hb.model.linear(p)
    Minv = np.linalg.inv(M)
    A = np.zeros((samples, 2 * n, 2 * n))
    A[:, :n, n:] = np.eye(n)
    A[:, n:, :n] = -np.einsum("ab,jbc->jac", Minv, K[None] + dfdx)
    A[:, n:, n:] = -np.einsum("ab,jbc->jac", Minv, C[None] + dfdxd)
    return A, 2.0 * np.pi / Omega


@nb.njit(cache=True)
def _matmul_into(A, B, out):
    d = A.shape[0]
    for i in range(d):
        for j in range(d):
            s = 0.0
            for k in range(d):
                s += A[i, k] * B[k, j]
            out[i, j] = s


@nb.njit(cache=True)
def rk4_propagate(A, h):
    """Classical RK4 for ``Phi' = A(t) Phi``, ``Phi(0) = I``, over one period.

    Parameters
    ----------
    A : ndarray, shape (2S, d, d)
        ``A`` at ``t_j = j h / 2`` (periodic: ``A(S h) = A(0)``).
    h : float
        Step ``T / S``.

    Returns
    -------
    ndarray, shape (d, d)
        ``Phi(T)``.
    """
    S = A.shape[0] // 2
    d = A.shape[1]
    Phi = np.eye(d)
    k1 = np.empty((d, d))
    k2 = np.empty((d, d))
    k3 = np.empty((d, d))
    k4 = np.empty((d, d))
    tmp = np.empty((d, d))
    for step in range(S):
        A0 = A[2 * step]
        A1 = A[2 * step + 1]
        A2 = A[(2 * step + 2) % (2 * S)]
        _matmul_into(A0, Phi, k1)
        for i in range(d):
            for j in range(d):
                tmp[i, j] = Phi[i, j] + 0.5 * h * k1[i, j]
        _matmul_into(A1, tmp, k2)
        for i in range(d):
            for j in range(d):
                tmp[i, j] = Phi[i, j] + 0.5 * h * k2[i, j]
        _matmul_into(A1, tmp, k3)
        for i in range(d):
            for j in range(d):
                tmp[i, j] = Phi[i, j] + h * k3[i, j]
        _matmul_into(A2, tmp, k4)
        for i in range(d):
            for j in range(d):
                Phi[i, j] += h / 6.0 * (k1[i, j] + 2.0 * k2[i, j] + 2.0 * k3[i, j] + k4[i, j])
    return Phi


def monodromy_rk4(hb, u: np.ndarray, lam: float, steps: int = 512) -> Monodromy:
    """Monodromy matrix by fixed-step RK4 on the sampled HB orbit.

    Parameters
    ----------
    hb : HarmonicBalance
    u : ndarray, shape (hb.size,)
    lam : float
    steps : int
        RK4 steps per period ``S`` (at least ``H+1``, so that the ``2S``
        orbit samples resolve every harmonic).

    Returns
    -------
    Monodromy
    """
    steps = int(steps)
    if steps < hb.H + 1:
        raise ValueError(f"steps_per_period must be >= H+1 = {hb.H + 1}, got {steps}")
    A, T = state_matrices(hb, u, lam, 2 * steps)
    Phi = rk4_propagate(A, T / steps)
    return Monodromy(Phi, T, "rk4", steps=steps, evaluations=2 * steps)


def orbit_state(hb, u: np.ndarray, lam: float, t) -> np.ndarray:
    """State ``(x, x')`` of the HB solution at times ``t``.

    Parameters
    ----------
    t : float or ndarray, shape (K,)

    Returns
    -------
    ndarray, shape (2n,) or (K, 2n)
    """
    Omega = _frequency(hb, lam)
    U = coefficient_blocks(u, hb.n)
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    th = Omega * tt
    k = np.arange(1, hb.H + 1)
    c = np.cos(np.outer(th, k))
    s = np.sin(np.outer(th, k))
    x = U[0][None, :] + c @ U[1::2] + s @ U[2::2]
    xd = Omega * ((-s * k) @ U[1::2] + (c * k) @ U[2::2])
    z = np.concatenate([x, xd], axis=1)
    return z[0] if np.ndim(t) == 0 else z


def _pointwise(hb, p):
    """Callables evaluating the model at one state (the reference path)."""
    n = hb.n
    M, C, K = hb.model.linear(p)
    Minv = np.linalg.inv(M)
    w = float(p[hb.kw])
    f = np.zeros((1, n))
    dfdx = np.zeros((1, n, n))
    dfdxd = np.zeros((1, n, n))
    fe = np.zeros((1, n))
    tau = np.zeros(1)

    def forces(x, xd, t):
        f[:] = 0.0
        dfdx[:] = 0.0
        dfdxd[:] = 0.0
        tau[0] = w * t
        for el in hb.model.forces:
            el.evaluate(x[None, :], xd[None, :], tau, p, f, dfdx, dfdxd)
        return f[0], dfdx[0], dfdxd[0]

    def excitation(t):
        fe[:] = 0.0
        tau[0] = w * t
        for el in hb.model.excitations:
            el.evaluate(tau, p, fe)
        return fe[0]

    return M, C, K, Minv, forces, excitation


def _state_matrix(Minv, C, K, dfdx, dfdxd, n):
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -Minv @ (K + dfdx)
    A[n:, n:] = -Minv @ (C + dfdxd)
    return A


def monodromy_orbit_ivp(hb, u: np.ndarray, lam: float, rtol: float = 1e-11, atol: float = 1e-12) -> Monodromy:
    """Monodromy of the variational equations along the HB orbit, adaptive DOP853.

    Same equations as :func:`monodromy_rk4` (the orbit is the HB solution,
    evaluated exactly at every requested time) with an error-controlled
    integrator: the reference for the fixed-step error.
    """
    n = hb.n
    p = hb.params_at(lam)
    Omega = _frequency(hb, lam)
    T = 2.0 * np.pi / Omega
    M, C, K, Minv, forces, _ = _pointwise(hb, p)
    d = 2 * n

    def rhs(t, y):
        z = orbit_state(hb, u, lam, t)
        _, dfdx, dfdxd = forces(z[:n], z[n:], t)
        A = _state_matrix(Minv, C, K, dfdx, dfdxd, n)
        return (A @ y.reshape(d, d)).reshape(-1)

    sol = solve_ivp(rhs, (0.0, T), np.eye(d).reshape(-1), method="DOP853", rtol=rtol, atol=atol)
    if not sol.success:
        raise ArithmeticError(f"solve_ivp failed on the variational equations: {sol.message}")
    return Monodromy(sol.y[:, -1].reshape(d, d), T, "orbit-dop853", evaluations=int(sol.nfev))


def monodromy_reference(hb, u: np.ndarray, lam: float, rtol: float = 1e-11, atol: float = 1e-12) -> Monodromy:
    """Reference monodromy: nonlinear state plus variational equations, DOP853.

    Integrates ``M x'' + C x' + K x + f(x, x', w t) = f_ext(w t)`` together with
    ``Phi' = A(t) Phi`` from the HB state at ``t = 0`` over one period. The
    right-hand side calls the elements with ``(1, n)`` arrays (slow, but this
    is the reference).

    Returns
    -------
    Monodromy
        With ``orbit_error = max |z(T) - z(0)|``.
    """
    n = hb.n
    p = hb.params_at(lam)
    Omega = _frequency(hb, lam)
    T = 2.0 * np.pi / Omega
    M, C, K, Minv, forces, excitation = _pointwise(hb, p)
    d = 2 * n
    z0 = orbit_state(hb, u, lam, 0.0)

    def rhs(t, y):
        x, xd = y[:n], y[n:d]
        f, dfdx, dfdxd = forces(x, xd, t)
        acc = Minv @ (excitation(t) - C @ xd - K @ x - f)
        A = _state_matrix(Minv, C, K, dfdx, dfdxd, n)
        out = np.empty_like(y)
        out[:n] = xd
        out[n:d] = acc
        out[d:] = (A @ y[d:].reshape(d, d)).reshape(-1)
        return out

    y0 = np.concatenate([z0, np.eye(d).reshape(-1)])
    sol = solve_ivp(rhs, (0.0, T), y0, method="DOP853", rtol=rtol, atol=atol)
    if not sol.success:
        raise ArithmeticError(f"solve_ivp failed on the reference integration: {sol.message}")
    yT = sol.y[:, -1]
    return Monodromy(
        yT[d:].reshape(d, d), T, "dop853", evaluations=int(sol.nfev), orbit_error=float(np.max(np.abs(yT[:d] - z0)))
    )
