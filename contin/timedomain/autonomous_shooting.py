"""Periodic orbits of an autonomous model by shooting: the period is an unknown, fixed by a phase condition.

An autonomous model (a rotor in the frame turning with it,
:func:`contin.model.rotating_frame.rotating_frame`) has periodic orbits of a
period ``T_r`` that no forcing sets. The unknowns are the state at ``t = 0``
and the period, ``u = (z, T_r)`` of size ``2 n + 1``, and the residual is

    r = phi_{T_r}(z) - z,              (2n,)
    r_phase = z[n + j],                (the velocity of dof j)

with ``phi`` the flow map of the compiled integrator (RK4, contact switches
located in time, :mod:`contin.timedomain.integrator`) over ``S`` steps of
``T_r / S``. Any time shift of an orbit is another solution; the phase
condition picks the point where displacement ``j`` has an extremum (a
Poincare section ``x_j' = 0``, crossed by every orbit that moves dof ``j``;
the start from a Hopf point picks the dof that moves most). The step grid
spans the unknown period: the rotating-frame model's frequency parameter
:data:`~contin.model.rotating_frame.PERIOD_FREQUENCY` is set to
``2 pi / T_r``, and nothing else depends on it.

Jacobian
--------
``dr/dz = Phi - I`` with ``Phi`` the exact derivative of the discrete map
(:class:`contin.timedomain.variational.VariationalFlow`: variational
equations through the same RK4 stages, saltation at located switches);
``dr_phase/dz = e_{n+j}^T``. ``dr/dT_r = f(phi_{T_r}(z))``, the vector field
at the end state in its contact mode: the derivative of the exact flow in its
time. The discrete map's own derivative differs from it by the RK4 error of
the orbit, ``O((T_r/S)^4)`` where the step resolves the motion, more in a stiff
contact mode: on the rotor at ``w = 1.9`` (4096 steps, ``h |lambda| = 1.4`` for
the contact's 823 rad/s) 7.6e-3 of the column, in the bearing's radial speed.
Newton's fixed point is that of the residual all the same (the column enters
only the iteration's contraction): measured, 4 Newton steps from a 1e-3
perturbation with this column and with a central difference alike. ``dr/dlam`` is the central difference of the plain flow maps in
``lam``, as in :class:`contin.timedomain.multiple_shooting.ShootingProblem`
(the parameter enters the matrices and the constant forces nonlinearly).
``tests/timedomain/test_autonomous_shooting.py`` checks all three against
central differences of the residual.

The orbit's Floquet multipliers are the eigenvalues of ``Phi``; one of them
is 1 (the orbit's own direction, ``Phi f(z) = f(z)``), the others decide
its stability.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from contin.model.rotating_frame import PERIOD_FREQUENCY
from contin.timedomain.integrator import SimulationError
from contin.timedomain.variational import VariationalFlow
from contin.util.options import from_mapping
from contin.engine.problem import solve_at

__all__ = ["AutonomousOptions", "AutonomousShootingProblem", "hopf_orbit_start"]


@dataclasses.dataclass(frozen=True)
class AutonomousOptions:
    """Options of :class:`AutonomousShootingProblem`.

    Attributes
    ----------
    steps : int
        ``S``, RK4 steps per orbit period ``T_r`` (the step is ``T_r / S``).
    factors : int
        The derivative over the period is kept in this many factors (a
        divisor of ``steps``), multiplied out for Newton; the multipliers of
        a strongly contracting orbit come from them.
    fd_step : float
        Step of the central difference in the parameter, relative to ``max(1, |lam|)``.
    section : int or None
        ``j``: the phase condition ``x_j' = 0``; None: chosen by the start
        (:func:`hopf_orbit_start`), else dof 0.
    """

    steps: int = 4096
    factors: int = 8
    fd_step: float = 1e-6
    section: int | None = None

    def __post_init__(self):
        for name, lo in (("steps", 16), ("factors", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ValueError(f"AutonomousOptions.{name}: expected an integer >= {lo}, got {v!r}")
        if self.steps % self.factors:
            raise ValueError(f"AutonomousOptions.factors: expected a divisor of steps = {self.steps}, "
                             f"got {self.factors}")
        v = self.fd_step
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 < v <= 1e-2:
            raise ValueError(f"AutonomousOptions.fd_step: expected a number in (0, 0.01], got {v!r}")
        s = self.section
        if s is not None and (isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s < 0):
            raise ValueError(f"AutonomousOptions.section: expected a dof index >= 0 or None, got {s!r}")

    @classmethod
    def from_dict(cls, d: Mapping) -> AutonomousOptions:
        """From a mapping; an unknown key raises ``ValueError`` naming it and the valid ones."""
        return from_mapping(cls, d)


class AutonomousShootingProblem:
    """``R(u, lam)`` of periodic orbits of an autonomous model, ``u = (z, T_r)``, for the engine (module docstring).

    Parameters
    ----------
    model : Model
        Autonomous, with the frequency parameter :data:`PERIOD_FREQUENCY`
        (from :func:`contin.model.rotating_frame.rotating_frame`).
    parameter : str
        The continuation parameter (not the period's).
    params : dict, optional
        The other parameter overrides.
    options : AutonomousOptions

    Raises
    ------
    ValueError
        A model without the period parameter or with a time-dependent
        excitation, an unknown or structural parameter, a section outside the dofs.

    Attributes
    ----------
    n : int
    size : int
        ``2 n + 1``.
    section : int
        ``j`` of the phase condition.
    """

    def __init__(self, model, parameter: str, params: Mapping[str, float] | None = None,
                 options: AutonomousOptions = AutonomousOptions()):
        if model.frequency != PERIOD_FREQUENCY:
            raise ValueError(f"model '{model.name}' has no period parameter '{PERIOD_FREQUENCY}' as its frequency: "
                             f"build the autonomous model with contin.model.rotating_frame.rotating_frame")
        if parameter == PERIOD_FREQUENCY:
            raise ValueError(f"the period parameter '{PERIOD_FREQUENCY}' is an unknown, not a continuation parameter")
        model.parameter_index(parameter)
        model.check_variable(parameter, params)
        for el in model.excitations:
            if getattr(el, "order", 0.0) != 0.0:
                raise ValueError(f"model '{model.name}': excitation '{getattr(el, 'label', el.kind)}' varies in time; "
                                 f"autonomous shooting needs an autonomous model")
        self.model, self.parameter, self.options = model, parameter, options
        self.base = dict(params or {})
        self.base.pop(PERIOD_FREQUENCY, None)
        self.n = model.n_dof
        self.size = 2 * self.n + 1
        section = 0 if options.section is None else int(options.section)
        if not 0 <= section < self.n:
            raise ValueError(f"AutonomousOptions.section: expected a dof index below {self.n}, got {section}")
        self.section = section
        self.flow = VariationalFlow(model, steps_per_period=options.steps)
        self._kr = model.parameter_index(PERIOD_FREQUENCY)
        self._last = None

    # ------------------------------------------------------------ pieces
    def split(self, u) -> tuple[np.ndarray, float]:
        """``(z, T_r)`` from the unknowns (size,)."""
        u = np.asarray(u, dtype=float)
        if u.shape != (self.size,):
            raise ValueError(f"the unknowns must have shape ({self.size},) = (x, x') of model '{self.model.name}' "
                             f"and the period, got {u.shape}")
        return u[:-1], float(u[-1])

    def p_at(self, lam: float, period: float) -> np.ndarray:
        """The parameter vector at ``lam`` with the step grid over ``period``, shape (P,)."""
        if not (math.isfinite(period) and period > 0.0):
            raise ArithmeticError(f"the iterate has the period {period:g}: no positive period")
        p = self.model.parameter_vector({**self.base, self.parameter: float(lam)})
        p[self._kr] = 2.0 * math.pi / period
        return p

    def _run(self, z, p, jacobian: bool):
        try:
            return self.flow.run(z, p, 0, self.options.steps, jacobian=jacobian,
                                 factors=self.options.factors if jacobian else 1)
        except SimulationError as exc:
            raise ArithmeticError(str(exc)) from None

    def vector_field(self, y, p, mode=None) -> np.ndarray:
        """``f(y)`` of the compiled model in the contact ``mode`` (default: the state's own), shape (2n,)."""
        return self.flow.compiled.rhs(y, 0.0, p, mode)

    # ------------------------------------------------------------ the engine's protocol
    #: a linearisation: one variational flow and the two flows of dR/dlam, against one plain flow
    jacobian_cost = 9.0

    def residual(self, u, lam: float) -> np.ndarray:
        """``(phi_{T_r}(z) - z, z[n + j])``, shape (2n + 1,)."""
        z, T = self.split(u)
        end = self._run(z, self.p_at(lam, T), jacobian=False).state
        return np.r_[end - z, z[self.n + self.section]]

    def linearize(self, u, lam: float):
        """Residual (2n+1,), ``dR/du`` (2n+1, 2n+1) and ``dR/dlam`` (2n+1,) (module docstring)."""
        z, T = self.split(u)
        m = 2 * self.n
        p = self.p_at(lam, T)
        run = self._run(z, p, jacobian=True)
        Ju = np.zeros((self.size, self.size))
        Ju[:m, :m] = run.jacobian - np.eye(m)
        Ju[:m, m] = self.vector_field(run.state, p, run.mode)
        Ju[m, self.n + self.section] = 1.0
        step = self.options.fd_step * max(1.0, abs(float(lam)))
        ends = [self._run(z, self.p_at(lam + s, T), jacobian=False).state for s in (step, -step)]
        Jlam = np.r_[(ends[0] - ends[1]) / (2.0 * step), 0.0]
        R = np.r_[run.state - z, z[self.n + self.section]]
        if not (np.all(np.isfinite(Ju)) and np.all(np.isfinite(Jlam))):
            raise ArithmeticError(f"non-finite flow map at {self.parameter} = {lam:.10g}")
        self._last = (np.asarray(u, dtype=float).tobytes(), float(lam), run.factors.copy())
        return R, Ju, Jlam

    def solve(self, u0, lam: float, tol: float = 1e-11, max_iter: int = 20) -> np.ndarray:
        """The orbit near ``u0`` at fixed ``lam`` by Newton on the square system (the phase condition closes it).

        Raises
        ------
        ArithmeticError
            If ``max |R| <= tol max(1, max |u|)`` is not reached in ``max_iter`` steps.
        """
        return solve_at(self, u0, lam, tol=tol, max_iter=max_iter, what="autonomous shooting")

    # ------------------------------------------------------------ what a point says
    def multipliers(self, u, lam: float) -> np.ndarray:
        """Floquet multipliers (eigenvalues of ``Phi``, one of them 1), by decreasing modulus, shape (2n,)."""
        key = (np.asarray(u, dtype=float).tobytes(), float(lam))
        if self._last is None or self._last[:2] != key:
            self.linearize(u, lam)
        F = self._last[2]
        Phi = F[0]
        for f in F[1:]:
            Phi = f @ Phi
        mu = np.linalg.eigvals(Phi)
        return mu[np.argsort(-np.abs(mu), kind="stable")]

    def orbit(self, u, lam: float, samples: int | None = None) -> np.ndarray:
        """The orbit's states at ``t = k T_r / S`` for ``k = 0 .. S`` (or every ``S / samples``-th), shape (K, 2n)."""
        z, T = self.split(u)
        S = self.options.steps
        every = 1 if samples is None else max(1, S // int(samples))
        if S % every:
            raise ValueError(f"orbit: samples must divide the steps {S}, got {samples}")
        p = self.p_at(lam, T)
        out = [np.array(z, dtype=float)]
        y = np.array(z, dtype=float)
        mode = None
        for k in range(0, S, every):
            try:
                run = self.flow.run(y, p, k, k + every, jacobian=False, mode=mode)
            except SimulationError as exc:
                raise ArithmeticError(str(exc)) from None
            y, mode = run.state, run.mode
            out.append(y.copy())
        return np.array(out)


def hopf_orbit_start(model, hopf, params: Mapping[str, float] | None = None,
                     options: AutonomousOptions = AutonomousOptions(), eps: float = 1e-4):
    """The first point of the periodic orbits born at a Hopf point, and the engine's tangent.

    At a Hopf point with eigenvalue ``i omega_H`` and eigenvector ``v`` of the
    state matrix, the orbits are to first order ``z_eq + eps Re(v exp(i omega_H t))``
    with period ``2 pi / omega_H`` (Kuznetsov, *Elements of Applied
    Bifurcation Theory*, 3rd ed., 2004, sec. 3.5). The phase is chosen on the
    section ``x_j' = 0`` of the dof ``j`` whose velocity moves most in ``v``
    (unless ``options.section`` names one). Pass the point and the tangent to
    :func:`contin.engine.continuation.continuation` with ``solve_start=False``:
    the engine corrects the point on the hyperplane through it normal to the
    tangent (the orbit's amplitude), ``lam`` free.

    Parameters
    ----------
    model : Model
        The autonomous model.
    hopf : contin.bifurcation.hopf.HopfPoint
    params : dict, optional
        The other parameter overrides (as for the equilibria).
    options : AutonomousOptions
    eps : float
        The amplitude of the first orbit, relative to ``max(1, max |x_eq|)``.

    Returns
    -------
    problem : AutonomousShootingProblem
    u0 : ndarray, shape (2n + 1,)
    tangent : ndarray, shape (2n + 2,)
        Along the amplitude, 0 in the period and ``lam``; unit length.
    """
    n = model.n_dof
    v = np.asarray(hopf.eigenvector, dtype=complex)
    j = int(np.argmax(np.abs(v[n:]))) if options.section is None else int(options.section)
    problem = AutonomousShootingProblem(model, hopf.parameter, params, dataclasses.replace(options, section=j))
    theta = 0.5 * math.pi - float(np.angle(v[n + j]))  # Re(v_j exp(i theta)) = 0
    direction = np.real(v * np.exp(1j * theta))
    direction[n + j] = 0.0
    z_eq = np.r_[np.asarray(hopf.state, dtype=float), np.zeros(n)]
    scale = eps * max(1.0, float(np.max(np.abs(hopf.state))))
    u0 = np.r_[z_eq + scale * direction / np.linalg.norm(direction), 2.0 * math.pi / hopf.omega]
    tangent = np.r_[direction, 0.0, 0.0]
    return problem, u0, tangent / np.linalg.norm(tangent)
