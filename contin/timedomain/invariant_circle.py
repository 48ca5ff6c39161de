"""Tori of a forced system as invariant circles of its stroboscopic map, by shooting.

A quasi-periodic response of a system forced at ``w`` lies on a torus; its
section at the forcing phase zero is a closed curve ``u(theta)`` of states that
the stroboscopic map ``P = phi_T`` (the flow over one forcing period
``T = 2 pi / w``, the integrator's RK4 with the contact switches located in
time) maps onto itself, turned by the rotation number ``rho``:

    P(u(theta)) = u(theta + 2 pi rho).

The circle is discretised by ``N`` (odd) points ``u_j = u(theta_j)``,
``theta_j = 2 pi j / N``, and ``u(theta_j + 2 pi rho)`` is its trigonometric
interpolant of degree ``K = (N - 1) / 2`` shifted by ``2 pi rho``: the rows of
the real ``N x N`` matrix

    S_rho[j, l] = (1 + 2 sum_{k=1..K} cos(k (theta_j - theta_l + 2 pi rho))) / N

(the Dirichlet kernel) act on each state component. The unknowns are the
points and ``rho``, ``(U, rho)`` of size ``2 n N + 1``, and the residual is

    r_j = phi_T(u_j) - (S_rho U)_j,          j = 0 .. N - 1,
    r_phase = sum_j (u_j - a_j) . a'_j,

the last an anchor fixing the circle's parametrisation (any ``theta``-shift of
a solution is one): ``a`` a reference circle, ``a'`` its derivative in
``theta`` by the same interpolant. Only the time direction carries the
contact's kinks, which the integrator resolves; the residual is as smooth as
the flow map (Schilder, Osinga & Vogt, *SIAM J. Appl. Dyn. Syst.* 4 (2005)
459, for the invariance equation and its Fourier shift; the map of a forced
system as there sec. 2).

Jacobian: ``dr_j/du_l = Phi(u_j) delta_jl - S_rho[j, l] I``, with ``Phi``
the exact derivative of the discrete flow map by the variational equations
(:class:`contin.timedomain.multiple_shooting.ShootingProblem`, one segment,
``nu = 1``); ``dr/drho = -(dS_rho/drho) U`` in closed form; ``dr/dlam`` the
shooting problem's (the flow's sensitivity to ``lam``, integrated with the
variational equations where ``lam`` enters the linear part or the frequency).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping

import numpy as np

from contin.stability.circle_products import fourier_rows, normal_products
from contin.timedomain.circle_measures import strongest_winding
from contin.timedomain.multiple_shooting import VARIATIONAL_COST, ShootingProblem
from contin.timedomain.shooting_options import ShootingOptions
from contin.util.options import from_mapping
from contin.engine.problem import solve_at

__all__ = ["CircleLyapunov", "CircleOptions", "InvariantCircleProblem", "circle_lyapunov", "circle_start",
           "point_jacobians", "shift_matrix"]


@dataclasses.dataclass(frozen=True)
class CircleOptions:
    """Options of :class:`InvariantCircleProblem`.

    Attributes
    ----------
    points : int
        ``N``, points of the circle (odd, >= 3): the interpolant's degree is ``(N - 1) / 2``.
    steps_per_period : int
        RK4 steps per forcing period of the stroboscopic map.
    fd_step : float
        Step of the central difference in the parameter, relative to ``max(1, |lam|)``.
    """

    points: int = 15
    steps_per_period: int = 1024
    fd_step: float = 1e-6

    def __post_init__(self):
        for name, lo in (("points", 3), ("steps_per_period", 16)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ValueError(f"CircleOptions.{name}: expected an integer >= {lo}, got {v!r}")
        if self.points % 2 == 0:
            raise ValueError(f"CircleOptions.points: expected an odd number (a real interpolant of degree "
                             f"(N - 1) / 2), got {self.points}")
        v = self.fd_step
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 < v <= 1e-2:
            raise ValueError(f"CircleOptions.fd_step: expected a number in (0, 0.01], got {v!r}")

    @classmethod
    def from_dict(cls, d: Mapping) -> "CircleOptions":
        """From a mapping; an unknown key raises ``ValueError`` naming it and the valid ones."""
        return from_mapping(cls, d)


def shift_matrix(n_points: int, rho: float, derivative: bool = False) -> np.ndarray:
    """``S_rho`` (module docstring), shape (N, N); with ``derivative`` its derivative in ``rho``.

    ``S_0`` is the identity; ``S_rho`` maps the values of a trigonometric
    polynomial of degree ``(N - 1) / 2`` at ``theta_j`` to its values at
    ``theta_j + 2 pi rho``.
    """
    N = int(n_points)
    K = (N - 1) // 2
    theta = 2.0 * math.pi * np.arange(N) / N
    d = theta[:, None] - theta[None, :] + 2.0 * math.pi * float(rho)  # (N, N)
    k = np.arange(1, K + 1)[:, None, None]
    if derivative:
        return -(2.0 / N) * np.sum(2.0 * math.pi * k * np.sin(k * d), axis=0)
    return (1.0 + 2.0 * np.sum(np.cos(k * d), axis=0)) / N


class InvariantCircleProblem:
    """``R(u, lam)`` of the invariant circle of the stroboscopic map, for the continuation engine (module docstring).

    Parameters
    ----------
    model : Model
        A forced model (its excitation's frequency parameter sets ``T``).
    parameter : str
        The continuation parameter.
    params : dict, optional
        The other parameter overrides.
    options : CircleOptions
    anchor : array_like, shape (N, 2n), optional
        The reference circle of the phase condition (default: set by
        :meth:`set_anchor`, for example from the start).

    Attributes
    ----------
    n : int
        Dofs of the model.
    points : int
        ``N``.
    size : int
        Unknowns ``2 n N + 1``: the points (row-major, point by point) and ``rho``.
    winding : int
        The integer added to ``rho`` for the torus' second frequency ``w2 = |rho + winding| w``: the circle
        fixes ``rho`` modulo 1 only, and the line a system's self-excited motion shows is one of
        ``(rho + m) w`` (:func:`circle_start` takes the strongest line of the mode it starts from; 0 by default).
    """

    winding = 0
    #: the torus is a branch of the one-period map: order 1 in a branch's rows
    nu = 1

    #: a linearisation costs one variational flow per point against one plain flow per point
    jacobian_cost = VARIATIONAL_COST

    def __init__(self, model, parameter: str, params: Mapping[str, float] | None = None,
                 options: CircleOptions = CircleOptions(), anchor=None):
        self.options = options
        self.map = ShootingProblem(model, parameter, params,
                                   ShootingOptions(steps_per_period=options.steps_per_period, fd_step=options.fd_step))
        self.model, self.parameter = model, parameter
        self.n = model.n_dof
        self.points = options.points
        self.size = 2 * self.n * self.points + 1
        self._anchor = self._danchor = None
        if anchor is not None:
            self.set_anchor(anchor)

    # ------------------------------------------------------------ the circle
    def blocks(self, u) -> tuple[np.ndarray, float]:
        """``(U, rho)``: the points (N, 2n) and the rotation number from the unknowns (size,)."""
        u = np.asarray(u, dtype=float)
        if u.shape != (self.size,):
            raise ValueError(f"the unknowns must have shape ({self.size},) = {self.points} points of (x, x') of "
                             f"model '{self.model.name}' and the rotation number, got {u.shape}")
        return u[:-1].reshape(self.points, 2 * self.n), float(u[-1])

    def unknowns(self, U, rho: float) -> np.ndarray:
        """The unknowns from the points ``U`` (N, 2n) and ``rho``."""
        U = np.asarray(U, dtype=float)
        if U.shape != (self.points, 2 * self.n):
            raise ValueError(f"U must have shape ({self.points}, {2 * self.n}), got {U.shape}")
        return np.r_[U.ravel(), float(rho)]

    def set_anchor(self, U) -> None:
        """Take the points ``U`` (N, 2n) (or unknowns of size ``size``) as the phase condition's reference circle."""
        U = np.asarray(U, dtype=float)
        if U.shape == (self.size,):
            U = self.blocks(U)[0]
        if U.shape != (self.points, 2 * self.n):
            raise ValueError(f"the anchor must have shape ({self.points}, {2 * self.n}), got {U.shape}")
        self._anchor = U.copy()
        # d/dtheta of the interpolant at theta_j: d S_rho / d rho at 0 over 2 pi
        self._danchor = shift_matrix(self.points, 0.0, derivative=True) @ U / (2.0 * math.pi)

    def _phase(self, U) -> float:
        if self._anchor is None:
            raise ValueError("InvariantCircleProblem: no anchor for the phase condition; call set_anchor(U) first")
        return float(np.sum((U - self._anchor) * self._danchor))

    # ------------------------------------------------------------ the engine's protocol
    def residual(self, u, lam: float) -> np.ndarray:
        """``(r_0, ..., r_{N-1}, r_phase)``, shape (size,)."""
        U, rho = self.blocks(u)
        # phi(z) - z + z: the rounding of the map's residual, as the linearisation's images below
        images = (self.map.flows_many(U, lam, checked=False)[:, 0] - U) + U
        return np.r_[(images - shift_matrix(self.points, rho) @ U).ravel(), self._phase(U)]

    def linearize(self, u, lam: float):
        """Residual (size,), ``dR/du`` (size, size, dense) and ``dR/dlam`` (size,) (module docstring)."""
        U, rho = self.blocks(u)
        N, m = self.points, 2 * self.n
        S = shift_matrix(N, rho)
        Ju = np.zeros((self.size, self.size))
        Jlam = np.zeros(self.size)
        images = np.empty((N, m))
        # phi(z) - z, Phi - I, dphi/dlam of every point, their flows in threads
        for j, (r, Phi, dlam) in enumerate(self.map.linearize_many(U, lam)):
            images[j] = r + U[j]
            Ju[j * m:(j + 1) * m, j * m:(j + 1) * m] = Phi + np.eye(m)
            Jlam[j * m:(j + 1) * m] = dlam
        Ju[:-1, :-1] -= np.kron(S, np.eye(m))
        Ju[:-1, -1] = -(shift_matrix(N, rho, derivative=True) @ U).ravel()
        R = np.r_[(images - S @ U).ravel(), self._phase(U)]
        Ju[-1, :-1] = self._danchor.ravel()
        return R, Ju, Jlam

    # ------------------------------------------------------------ what a point says
    def frequency_at(self, lam: float) -> float:
        """The forcing frequency ``w`` at ``lam``."""
        return self.map.frequency_at(lam)

    def params_at(self, lam: float) -> dict:
        """Parameter overrides at ``lam``."""
        return self.map.params_at(lam)

    def period_at(self, lam: float) -> float:
        """The forcing period ``T`` the map integrates over."""
        return self.map.period_at(lam)

    def solve(self, u0, lam: float, tol: float = 1e-11, max_iter: int = 6) -> np.ndarray:
        """The circle near ``u0`` at fixed ``lam`` by Newton (the phase condition closes the system).

        Raises
        ------
        ArithmeticError
            If ``max |R| <= tol max(1, max |u|)`` is not reached in ``max_iter`` steps.
        """
        return solve_at(self, u0, lam, tol=tol, max_iter=max_iter, what="invariant circle")

    def second_frequency(self, u, lam: float) -> float:
        """The torus' second frequency ``w2 = |rho + winding| w`` (class docstring)."""
        return abs(self.blocks(u)[1] + self.winding) * self.frequency_at(lam)

    def points_on_circle(self, u, theta) -> np.ndarray:
        """The interpolated circle at the angles ``theta`` (shape (K,)): states, shape (K, 2n)."""
        U, _ = self.blocks(u)
        N = self.points
        th = np.atleast_1d(np.asarray(theta, dtype=float))
        rows = np.stack([shift_matrix(N, t / (2.0 * math.pi))[0] for t in th])  # row 0 of S_t: the value at t
        return rows @ U


def circle_start(model, parameter: str, z, lam: float, params: Mapping[str, float] | None = None,
                 options: CircleOptions = CircleOptions(), eps: float = 1e-2):
    """The first point of the torus branch born at a Neimark-Sacker point of a periodic orbit.

    At a Neimark-Sacker point the monodromy ``Phi`` of the orbit through
    ``z`` has a pair of multipliers ``exp(+-2 pi i rho0)`` on the unit circle;
    the invariant circle that grows out of it is, to first order, the ellipse
    ``z + eps Re(v exp(i theta))`` of the eigenvector ``v`` of
    ``exp(2 pi i rho0)``, turned by ``rho0`` per period (Kuznetsov,
    *Elements of Applied Bifurcation Theory*, 3rd ed., 2004, sec. 4.6). Pass
    the returned point and tangent to
    :func:`contin.engine.continuation.continuation` with ``solve_start=False``:
    the engine corrects the point on the hyperplane through it normal to the
    tangent (the circle's amplitude), with ``lam`` free, so the side of the
    point the torus lies on need not be known.

    Parameters
    ----------
    model : Model
    parameter : str
    z : array_like, shape (2n,)
        The state at ``t = 0`` of the periodic orbit at the Neimark-Sacker point (forcing period).
    lam : float
    params : dict, optional
    options : CircleOptions
    eps : float
        The ellipse's size, relative to ``max(1, max |z|)``.

    Returns
    -------
    problem : InvariantCircleProblem
        Its anchor the ellipse; its ``winding`` that of the strongest line of the ellipse's trajectories
        (:func:`contin.timedomain.circle_measures.strongest_winding`): the mode's dominant frequency.
    u0 : ndarray, shape (problem.size,)
    tangent : ndarray, shape (problem.size + 1,)
        Along the ellipse's amplitude, 0 in ``rho`` and ``lam``; unit length.

    Raises
    ------
    ValueError
        If no complex pair of multipliers lies within 1e-2 of the unit circle.
    """
    problem = InvariantCircleProblem(model, parameter, params, options)
    z = np.asarray(z, dtype=float)
    _, Ju, _ = problem.map.linearize(z, lam)
    mu, V = np.linalg.eig(Ju + np.eye(z.size))
    pair = np.flatnonzero(mu.imag > 1e-12 * np.abs(mu))
    if not pair.size:
        raise ValueError(f"no complex multiplier at {parameter} = {lam:.10g}: not a Neimark-Sacker point")
    j = int(pair[np.argmin(np.abs(np.abs(mu[pair]) - 1.0))])
    if abs(abs(mu[j]) - 1.0) > 1e-2:
        raise ValueError(f"no complex multiplier within 1e-2 of the unit circle at {parameter} = {lam:.10g} "
                         f"(closest {complex(mu[j]):.6g}): not a Neimark-Sacker point")
    v = V[:, j] / np.linalg.norm(V[:, j])
    theta = 2.0 * math.pi * np.arange(problem.points) / problem.points
    ellipse = np.real(v[None, :] * np.exp(1j * theta)[:, None])  # (N, 2n)
    scale = eps * max(1.0, float(np.max(np.abs(z))))
    U = z[None, :] + scale * ellipse
    problem.set_anchor(U)
    rho0 = float(np.angle(mu[j])) / (2.0 * math.pi)
    u0 = problem.unknowns(U, rho0)
    problem.winding = strongest_winding(problem, u0, lam)
    tangent = np.r_[ellipse.ravel(), 0.0, 0.0]
    return problem, u0, tangent / np.linalg.norm(tangent)


#: a normal exponent within this (per forcing period) of zero gives no verdict, nor one within twice the
#: tangential exponent's distance to zero or within 1 / iterations (the averages' own error)
EXPONENT_TOL = 1e-3
#: the floor of that tolerance with the Jacobians interpolated along the circle (thousands of periods averaged)
INTERPOLATED_TOL = 1e-4
#: periods carried before the averages start, with the Jacobians interpolated (:func:`circle_lyapunov`)
TRANSIENT = 1000


@dataclasses.dataclass(frozen=True)
class CircleLyapunov:
    """Lyapunov exponents of the map along an invariant circle (:func:`circle_lyapunov`).

    Attributes
    ----------
    exponents : ndarray, shape (2n,)
        Per forcing period, in decreasing order.
    tangent : int
        Index of the tangential exponent (the circle's own direction, zero up to the error of the data).
    largest_normal : float
        The largest of the others.
    stable : bool or None
        ``largest_normal < -tol`` (True), ``> tol`` (False), else None (undecided), with ``tol`` the
        largest of ``EXPONENT_TOL`` (``INTERPOLATED_TOL`` from interpolated Jacobians), twice the
        tangential exponent's modulus and ``1 / iterations``.
    iterations : int
    """

    exponents: np.ndarray
    tangent: int
    largest_normal: float
    stable: bool | None
    iterations: int


def point_jacobians(problem: "InvariantCircleProblem", u, lam: float, Ju=None, midpoints: bool = False) -> np.ndarray:
    """The map's Jacobians ``DP`` at the circle's points, shape (N, 2n, 2n), or (2N, 2n, 2n) with ``midpoints``.

    At the points ``u_j`` they are read off the diagonal blocks of the circle's Jacobian ``Ju``
    (``Phi_j - S_rho[j, j] I``, see :meth:`InvariantCircleProblem.linearize`) when it is given dense, else
    one variational flow per point. ``midpoints`` adds those at the interpolant's points halfway between
    (one variational flow each), in the order of their angles ``2 pi j / (2N)``.
    """
    U, rho = problem.blocks(u)
    N, m = problem.points, 2 * problem.n
    if isinstance(Ju, np.ndarray) and Ju.shape == (problem.size, problem.size):
        diag = float(shift_matrix(N, rho)[0, 0])  # S_rho is circulant: one diagonal value
        out = np.stack([Ju[j * m:(j + 1) * m, j * m:(j + 1) * m] for j in range(N)])
        out[:, range(m), range(m)] += diag
    else:
        out = problem.map.flow_jacobians(U, lam)[1]
    if not midpoints:
        return out
    between = problem.points_on_circle(u, 2.0 * math.pi * (np.arange(N) + 0.5) / N)
    both = np.empty((2 * N, m, m))
    both[0::2], both[1::2] = out, problem.map.flow_jacobians(between, lam)[1]
    return both


def circle_lyapunov(problem: InvariantCircleProblem, u, lam: float, iterations: int = 200,
                    jacobians=None, transient: int | None = None) -> CircleLyapunov:
    """The torus' stability from the Lyapunov exponents of the map restricted to its circle.

    A perturbation ``v`` of the circle at ``theta`` is carried by ``DP(u(theta))`` to
    ``theta + 2 pi rho``. The circle's own direction is exact: on an invariant
    circle ``DP(u(theta)) u'(theta) = u'(theta + 2 pi rho)``, so the tangential
    exponent, the mean of ``log |DP t_k|`` over the unit tangents ``t_k`` at
    the points ``u(2 pi k rho)`` of the circle's interpolant, telescopes to zero
    and what it shows is the error of the data. The normal exponents are those
    of the map on the normal bundle (the quotient by the tangent): a basis
    orthogonal to ``t_k`` carried by ``DP``, the component along ``t_{k+1}``
    removed, orthonormalised at every step (QR; Benettin et al., *Meccanica* 15
    (1980) 9), the logarithms of ``|R_ii|`` averaged after ``transient``
    periods that only carry the basis: the first one, the complement of the
    tangent, is not the normal bundle's own splitting, and the stretches that
    turn it there would bias the averages by about ``log(1 / angle) /
    iterations``, enough to read a torus near its Neimark-Sacker point
    stable that the normal form says is not (docs/theory/quasi-periodic.md).
    The torus is stable when the normal exponents are negative.

    Parameters
    ----------
    problem : InvariantCircleProblem
    u : array_like, shape (problem.size,)
        A converged circle.
    lam : float
    iterations : int
        Periods of the map averaged.
    jacobians : array_like, shape (K, 2n, 2n), optional
        ``DP`` at ``K`` equally spaced angles ``2 pi j / K`` of the circle (:func:`point_jacobians`: its
        points, ``K = N``, or with the midpoints, ``K = 2N``): then ``DP`` along the circle is their
        trigonometric interpolant, as smooth in ``theta`` as the flow map, and no flow is integrated (the
        products cost a few microseconds a period, so ``iterations`` can be large; the verdict's floor is
        then :data:`INTERPOLATED_TOL`). Without it, one variational flow a period from the interpolated point.
    transient : int, optional
        Periods carried before the averages (default :data:`TRANSIENT` with ``jacobians``, none without: there
        each period is a flow).

    Returns
    -------
    CircleLyapunov
    """
    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)) or iterations < 1:
        raise ValueError(f"iterations: expected a positive integer, got {iterations!r}")
    skip = (TRANSIENT if jacobians is not None else 0) if transient is None else transient
    if isinstance(skip, bool) or not isinstance(skip, (int, np.integer)) or skip < 0:
        raise ValueError(f"transient: expected a non-negative integer, got {transient!r}")
    U, rho = problem.blocks(u)
    m, N = 2 * problem.n, problem.points
    theta = 2.0 * math.pi * ((np.arange(skip + iterations + 1) * rho) % 1.0)
    # u'(theta_k) from the interpolant's rows (a_0, a_1, b_1, ...): sum k (b_k cos k theta - a_k sin k theta)
    rows = fourier_rows(U)
    k = np.arange(1, (N - 1) // 2 + 1)
    tangents = (np.cos(np.outer(theta, k)) * k) @ rows[2::2] - (np.sin(np.outer(theta, k)) * k) @ rows[1::2]
    tangents /= np.linalg.norm(tangents, axis=1)[:, None]
    # a basis of the normal space at theta_0: the complement of the tangent
    Q = np.linalg.qr(np.c_[tangents[0], np.eye(m)])[0][:, 1:m]
    sums = np.zeros(m - 1)
    if jacobians is not None:
        J = np.asarray(jacobians, dtype=float)
        if J.ndim != 3 or J.shape[1:] != (m, m) or J.shape[0] < 3:
            raise ValueError(f"jacobians: expected shape (K, {m}, {m}) with K >= 3 equally spaced angles, "
                             f"got {J.shape}")
        rows_J, Q = fourier_rows(J), np.array(Q)
        if skip:  # the basis carried (in place), its stretches dropped
            normal_products(rows_J, theta[:skip + 1], np.ascontiguousarray(tangents[:skip + 1]), Q, np.zeros(m - 1))
        tangential = normal_products(rows_J, theta[skip:], np.ascontiguousarray(tangents[skip:]), Q, sums)
    else:
        tangential = 0.0
        for i in range(skip + iterations):
            if i == skip:  # the averages start here
                sums[:], tangential = 0.0, 0.0
            z = problem.points_on_circle(u, theta[i])[0]
            _, Phi = problem.map.flow_jacobian(z, lam)
            tangential += math.log(float(np.linalg.norm(Phi @ tangents[i])))
            A = Phi @ Q
            A -= np.outer(tangents[i + 1], tangents[i + 1] @ A)
            Q, R = np.linalg.qr(A)
            sums += np.log(np.abs(np.diag(R)))
    normal = np.sort(sums / iterations)[::-1]
    tangential /= iterations
    exps = np.sort(np.r_[normal, tangential])[::-1]
    tangent = int(np.flatnonzero(exps == tangential)[0])
    largest = float(normal[0]) if m > 1 else -math.inf
    floor = EXPONENT_TOL if jacobians is None else INTERPOLATED_TOL
    tol = max(floor, 2.0 * abs(tangential), 1.0 / iterations)
    stable = True if largest < -tol else (False if largest > tol else None)
    return CircleLyapunov(exps, tangent, largest, stable, int(iterations))
