"""A torus of a system with contact by plain steps in the parameter: Newton at fixed ``lam``, circle by circle.

The invariant circle of a system with contact (:mod:`contin.timedomain.invariant_circle`)
has corners where its points cross the switching surfaces of the flow map, and
every crossing of a grid point puts a corner into the discretised branch: the
branch turns by tens of degrees at corners close together in ``lam``, however
short the step (the rotor's large torus: docs/theory/quasi-periodic.md). A
pseudo-arclength branch, whose corrector and step control read the tangent,
crawls there; a step at fixed ``lam`` does not see the corners, as the circle
at each ``lam`` is still the solution of a Newton problem in ``U`` and ``rho``
with one solution nearby. Plain steps also step
over the thin resonance tongues of large ``q`` that a discretised circle
cannot cross smoothly (docs/theory/quasi-periodic.md). They cannot turn at a
fold: where Newton fails at every step down to ``min_step``, the steps end and
say where, with the rational of small denominator nearest ``rho`` (a locking
tongue, or the fold or breakdown of the torus: which one, the rows before it
tell). Past a Neimark-Sacker point Newton converges onto the periodic orbit
itself (all points on it solve the equations at any ``rho``): a circle whose
size falls below :data:`COLLAPSED` of the largest so far is not kept but
taken as a failed step, and steps that end so end as a collapse, located to
``min_step``.

:func:`step_circle` takes the circle from ``lam0`` towards ``end``; the
predictor is the line through the last two circles, the step halved where
Newton fails and grown by half again after a success, up to the first step.
Newton's Jacobian is lazy (:func:`contin.engine.newton.newton`): the iterates
are evaluated by plain flows, and chord steps with the factorisation of the
last circle's updates go on while they contract; a variational flow per point
only where an update factorises; a solve whose residual grows to :data:`DIVERGED`
times its first is given up. (Giving up a Newton solve after a few updates
without progress saves time at the ends but stops steps that a few more
updates would finish: the residual has corners too.)
"""

from __future__ import annotations

import dataclasses
from fractions import Fraction

import numpy as np

from contin.bifurcation.circle_branch import circle_spread
from contin.engine.linalg import factorize
from contin.engine.newton import solve_at_parameter
from contin.engine.options import ContinuationOptions

__all__ = ["COLLAPSED", "DIVERGED", "CircleStepper", "CircleSteps", "step_circle"]

#: a circle this small against the largest of the steps (peak-to-peak range of a state component) has collapsed
COLLAPSED = 1e-3
#: the denominators considered for the rational nearest ``rho`` where the steps end
NEAREST_DENOMINATOR = 12
#: a step's Newton is given up once its residual exceeds this factor times the first one: the steps that fail
#: diverge far beyond it, those that converge stay well within it (docs/theory/quasi-periodic.md)
DIVERGED = 100.0


@dataclasses.dataclass
class CircleSteps:
    """The circles of :func:`step_circle`.

    Attributes
    ----------
    parameter : ndarray, shape (K,)
        ``lam`` of each circle, the start first.
    unknowns : ndarray, shape (K, problem.size)
    iterations : ndarray of int, shape (K,)
        Newton's iterations (0 at the start).
    reached : bool
        Whether the steps got to ``end``.
    message : str
        Where and why they stopped.
    rows : list of dict
        ``measure(u, lam)`` at each circle (empty without ``measure``).
    """

    parameter: np.ndarray
    unknowns: np.ndarray
    iterations: np.ndarray
    reached: bool
    message: str
    rows: list


class CircleStepper:
    """The loop of :func:`step_circle`, one step at a time, with the state that resumes it exactly.

    ``lams`` and ``us`` hold the circles so far (the predictor reads the last
    two); ``step`` is the next step, ``largest`` the largest circle so far.
    The chord factorisation passed from circle to circle is kept with the point
    its Jacobian was evaluated at (``lu_at``), so :meth:`restore` rebuilds it
    and a resumed run takes the steps the uninterrupted one would have.
    """

    def __init__(self, problem, u0, lam0: float, step: float, end: float, *, min_step: float = 1e-5,
                 max_step: float | None = None, options: ContinuationOptions | None = None):
        step, lam0, end = float(step), float(lam0), float(end)
        if step == 0.0 or (end - lam0) * step < 0.0:
            raise ValueError(f"step_circle: step {step:g} must point from {lam0:g} towards {end:g}")
        if not min_step > 0.0:
            raise ValueError(f"step_circle: min_step must be positive, got {min_step!r}")
        self.problem, self.end, self.min_step = problem, end, float(min_step)
        self.max_step = abs(step) if max_step is None else float(max_step)
        self.sign = float(np.sign(step))
        self.opts = options or ContinuationOptions(newton_tol=1e-8, newton_max_iter=20)
        self.lams, self.us = [lam0], [np.asarray(u0, dtype=float)]
        self.step = step
        self.largest = circle_spread(problem, self.us[0])
        self.collapsed = None  # (lam, spread) of the last circle refused as collapsed
        self.lu = self.lu_at = None  # the chord factorisation and (u, lam) where its Jacobian was evaluated
        self.failures = 0

    @property
    def lam(self) -> float:
        return self.lams[-1]

    def going(self) -> bool:
        """Whether another step is to be tried."""
        return (self.end - self.lam) * self.sign > 1e-12 * max(1.0, abs(self.end)) and abs(self.step) >= self.min_step

    def attempt(self):
        """One step: the converged Newton result (the circle appended), or None (the step halved)."""
        problem, lam = self.problem, self.lam
        h = self.step
        target = self.end if (self.end - lam - h) * self.sign <= 0.0 else lam + h
        guess = self.us[-1]
        if len(self.lams) > 1:
            guess = self.us[-1] + (self.us[-1] - self.us[-2]) * (target - lam) / (lam - self.lams[-2])
        seen = _Linearizations(problem)
        # a lazy Jacobian: iterates by plain flows, the factorisation of the last circle's updates first
        r = solve_at_parameter(seen, guess, target, self.opts, lu0=self.lu,
                               residual=lambda x: problem.residual(x, target), jacobian_at_solution=False,
                               divergence_factor=DIVERGED)
        spread = circle_spread(problem, r.x) if r.converged else 0.0
        if r.converged and spread < COLLAPSED * self.largest:  # as a failure: the step shrinks towards the point
            self.collapsed = (target, spread)
        if not r.converged or spread < COLLAPSED * self.largest:
            self.step /= 2.0
            self.failures += 1
            return None
        if r.lu is not self.lu:
            self.lu, self.lu_at = r.lu, (None if r.lu is None else seen.last)
        self.largest, self.collapsed = max(self.largest, spread), None
        self.lams.append(target)
        self.us.append(r.x)
        self.step = self.sign * min(abs(h) * 1.5, self.max_step)
        return r

    def reached(self) -> bool:
        return self.collapsed is None and not (self.end - self.lam) * self.sign > 1e-12 * max(1.0, abs(self.end))

    def message(self) -> str:
        """Where and why the steps stopped (module docstring)."""
        name, lam = self.problem.parameter, self.lam
        if self.collapsed is not None:
            return (f"the circle collapses onto a periodic orbit between {name}={lam:.10g} and "
                    f"{self.collapsed[0]:.10g} (size {self.collapsed[1]:.3g} there against {self.largest:.3g}): "
                    "a Neimark-Sacker point")
        if self.reached():
            return f"reached {name}={self.end:.10g}"
        rho = float(self.problem.blocks(self.us[-1])[1]) % 1.0
        near = Fraction(rho).limit_denominator(NEAREST_DENOMINATOR)
        return (f"Newton at fixed {name} failed at every step down to {self.min_step:g} beyond {name}={lam:.10g}: "
                f"rho = {rho:.6f}, {rho - float(near):+.1e} from {near}")

    def state(self) -> dict:
        """What :meth:`restore` needs besides the circles (JSON-able but for arrays)."""
        at = self.lu_at
        return {"step": self.step, "largest": self.largest, "failures": self.failures,
                "lu_u": None if at is None else at[0], "lu_lam": None if at is None else at[1]}

    def restore(self, lams, us, state: dict) -> None:
        """Go on from the circles ``lams``, ``us`` (the last two at least, where there are two) and ``state``."""
        self.lams, self.us = [float(v) for v in lams], [np.asarray(u, dtype=float) for u in us]
        self.step, self.largest = float(state["step"]), float(state["largest"])
        self.failures = int(state["failures"])
        self.lu = self.lu_at = None
        if state["lu_u"] is not None:  # the same factorisation again: the same Jacobian, the same LAPACK call
            u, lam = np.asarray(state["lu_u"], dtype=float), float(state["lu_lam"])
            self.lu, self.lu_at = factorize(self.problem.linearize(u, lam)[1]), (u, lam)


class _Linearizations:
    """``problem`` with the point of its last ``linearize`` call kept (where the chord's Jacobian was taken)."""

    def __init__(self, problem):
        self.problem, self.last = problem, None

    def linearize(self, u, lam):
        self.last = (np.array(u, dtype=float), float(lam))
        return self.problem.linearize(u, lam)


def step_circle(problem, u0, lam0: float, step: float, end: float, *, min_step: float = 1e-5,
                options: ContinuationOptions | None = None, measure=None, callback=None) -> CircleSteps:
    """Circles at ``lam0 + step``, ``+ 2 step``, ... up to ``end`` (module docstring).

    Parameters
    ----------
    problem : InvariantCircleProblem
    u0 : array_like, shape (problem.size,)
        The circle at ``lam0`` (solved).
    lam0, end : float
    step : float
        The first and largest step; its sign must point from ``lam0`` to ``end``.
    min_step : float
        The steps end where Newton fails at every step down to this.
    options : ContinuationOptions, optional
        ``newton_tol`` and ``newton_max_iter`` (default 1e-8 and 20: the lazy Jacobian takes more, cheaper, updates).
    measure : callable, optional
        ``measure(u, lam) -> dict``, kept for every circle (the start included).
    callback : callable, optional
        ``callback(lam, u, iterations, row)`` after each circle.

    Raises
    ------
    ValueError
        If ``step`` is zero or points away from ``end``, or ``min_step`` is not positive.
    """
    stepper = CircleStepper(problem, u0, lam0, step, end, min_step=min_step, options=options)
    its = [0]
    rows = [measure(stepper.us[0], stepper.lam)] if measure is not None else []
    while stepper.going():
        r = stepper.attempt()
        if r is None:
            continue
        its.append(r.iterations)
        if measure is not None:
            rows.append(measure(r.x, stepper.lam))
        if callback is not None:
            callback(stepper.lam, r.x, r.iterations, rows[-1] if rows else None)
    return CircleSteps(np.asarray(stepper.lams), np.asarray(stepper.us), np.asarray(its, dtype=int),
                       stepper.reached(), stepper.message(), rows)
