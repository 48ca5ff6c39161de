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
only where an update factorises. (Giving up a Newton solve after a few updates
without progress saves time at the ends but stops steps that a few more
updates would finish: the residual has corners too.)
"""

from __future__ import annotations

import dataclasses
from fractions import Fraction

import numpy as np

from contin.bifurcation.circle_branch import circle_spread
from contin.engine.newton import solve_at_parameter
from contin.engine.options import ContinuationOptions

__all__ = ["COLLAPSED", "CircleSteps", "step_circle"]

#: a circle this small against the largest of the steps (peak-to-peak range of a state component) has collapsed
COLLAPSED = 1e-3
#: the denominators considered for the rational nearest ``rho`` where the steps end
NEAREST_DENOMINATOR = 12


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
    step, lam0, end = float(step), float(lam0), float(end)
    if step == 0.0 or (end - lam0) * step < 0.0:
        raise ValueError(f"step_circle: step {step:g} must point from {lam0:g} towards {end:g}")
    if not min_step > 0.0:
        raise ValueError(f"step_circle: min_step must be positive, got {min_step!r}")
    opts = options or ContinuationOptions(newton_tol=1e-8, newton_max_iter=20)
    lams, us, its = [lam0], [np.asarray(u0, dtype=float)], [0]
    rows = [measure(us[0], lam0)] if measure is not None else []
    h, lam = step, lam0
    largest = circle_spread(problem, us[0])
    collapsed = lu = None
    while (end - lam) * step > 1e-12 * max(1.0, abs(end)) and abs(h) >= min_step:
        target = end if (end - lam - h) * step <= 0.0 else lam + h
        guess = us[-1]
        if len(lams) > 1:
            guess = us[-1] + (us[-1] - us[-2]) * (target - lams[-1]) / (lams[-1] - lams[-2])
        # a lazy Jacobian: iterates by plain flows, the factorisation of the last circle's updates first
        r = solve_at_parameter(problem, guess, target, opts, lu0=lu, residual=lambda x: problem.residual(x, target),
                               jacobian_at_solution=False)
        if not r.converged:
            h /= 2.0
            continue
        spread = circle_spread(problem, r.x)
        if spread < COLLAPSED * largest:  # as a failure: the step shrinks towards the point
            collapsed = (target, spread)
            h /= 2.0
            continue
        largest, collapsed, lu = max(largest, spread), None, r.lu
        lam = target
        lams.append(lam)
        us.append(r.x)
        its.append(r.iterations)
        if measure is not None:
            rows.append(measure(r.x, lam))
        if callback is not None:
            callback(lam, r.x, r.iterations, rows[-1] if rows else None)
        h = float(np.sign(step)) * min(abs(h) * 1.5, abs(step))
    reached = collapsed is None and not (end - lam) * step > 1e-12 * max(1.0, abs(end))
    name = problem.parameter
    if collapsed is not None:
        message = (f"the circle collapses onto a periodic orbit between {name}={lam:.10g} and {collapsed[0]:.10g} "
                   f"(size {collapsed[1]:.3g} there against {largest:.3g}): a Neimark-Sacker point")
    elif reached:
        message = f"reached {name}={end:.10g}"
    else:
        rho = float(problem.blocks(us[-1])[1]) % 1.0
        near = Fraction(rho).limit_denominator(NEAREST_DENOMINATOR)
        message = (f"Newton at fixed {name} failed at every step down to {min_step:g} beyond {name}={lam:.10g}: "
                   f"rho = {rho:.6f}, {rho - float(near):+.1e} from {near}")
    return CircleSteps(np.asarray(lams), np.asarray(us), np.asarray(its, dtype=int), reached, message, rows)

