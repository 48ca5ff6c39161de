"""Branches of the integrated flow in a bifurcation diagram: their stability monitor and the switch at a period doubling.

A :class:`contin.timedomain.shooting.ShootingProblem` branch gets its
multipliers from the flow (:class:`ShootingMonitor`, the monitor interface of
:class:`contin.stability.StabilityMonitor` that the diagram reads), and a
period doubling on it starts the branch of twice the period by
:func:`contin.timedomain.shooting.period_doubling_start` (:func:`shooting_pd_start`).
A branch of twice the period that comes back to the branch it was born on
(at its other period doubling) ends there as a closed loop, the return
located (:class:`ReturnEvent`), never run on as the same orbits shifted by a
forcing period.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from contin.bifurcation.switching import BranchStart
from contin.engine.branch import BranchStatus, SpecialKind, SpecialPoint
from contin.engine.events import Event, PointInfo
from contin.model.periodic import is_shooting
from contin.stability.options import StabilityMethod, StabilityOptions
from contin.timedomain.shooting import ShootingProblem, ShootingStability, period_doubling_start

__all__ = ["ReturnEvent", "ShootingMonitor", "finish_return", "is_shooting", "return_events", "shooting_pd_start",
           "watch_return"]


class ShootingMonitor(ShootingStability):
    """:class:`ShootingStability` with what a diagram asks of a stability monitor (statistics, a report)."""

    def __init__(self, problem: ShootingProblem, options: StabilityOptions | None = None):
        if options is not None and options.method is not StabilityMethod.FLOQUET:
            # the flow's monodromy is the only method a shooting branch has: keep the tolerances
            options = dataclasses.replace(options, method=StabilityMethod.FLOQUET)
        super().__init__(problem, options)
        self._evaluations = 0

    def __call__(self, u, lam, Ju=None, Jlam=None) -> dict:
        self._evaluations += 1
        return super().__call__(u, lam, Ju, Jlam)

    def statistics(self) -> dict:
        """What ``summary.json`` says of the stability of the branch."""
        return {"method": "shooting", "evaluations": self._evaluations}

    def report(self, branch) -> str:
        """Nothing replaced: the multipliers are the flow's at every point."""
        return ""


def shooting_pd_start(problem: ShootingProblem, point: SpecialPoint) -> BranchStart:
    """The first point of the branch of twice the period at the period doubling ``point`` of a shooting branch.

    Raises
    ------
    ValueError
        If the monodromy at ``point`` has no multiplier near ``-1``.
    ArithmeticError
        If the flow blows up there.
    """
    lam = float(point.parameter)
    doubled, u0, tangent = period_doubling_start(problem, np.asarray(point.unknowns, dtype=float), lam)
    v = np.asarray(tangent[:-1], dtype=float)
    z = np.asarray(point.unknowns, dtype=float)
    u0 = np.asarray(u0, dtype=float)
    # the offset along the eigenvector at the orbit's start (the doubled problem may have more segments)
    eps = float(np.linalg.norm(u0[:z.size] - z))
    return BranchStart(doubled, u0, lam, np.asarray(tangent, dtype=float), SpecialKind.PD, v, eps, 1, (z, lam))


class ReturnEvent(Event):
    """Where a branch of ``nu`` (even) forcing periods returns to the branch of ``nu / 2``: a period doubling.

    The orbit is ``nu/2``-periodic there: ``d = phi_{nu T0 / 2}(z) - z`` (``T0 = 2 pi / w``) goes to zero and
    changes its direction (beyond, the branch retraces its orbits shifted by ``nu / 2`` forcing periods: it has
    come back as a closed loop). The test is ``d`` projected on its value at the last stored point (set by
    :meth:`advance` after each point), which changes sign exactly where ``d`` passes through zero; a sign
    change is a return only where ``|d|`` fell below :attr:`RELATIVE` of its largest value on the branch
    (:meth:`returned`), not where ``d`` merely turned.
    """

    kind = SpecialKind.PD
    name = "returns_to_half_period"
    integer_valued = False
    #: ``|d|`` at the located point, relative to the largest on the branch, below which it is a return
    RELATIVE = 1e-3

    def __init__(self, problem: ShootingProblem):
        self.problem = problem
        half = problem.options.subharmonic // 2
        # the half period's grid has the same section (its steps counted modulo the half period)
        opts = dataclasses.replace(problem.options, subharmonic=half, segments=1,
                                   start_step=problem.options.start_step % (half * problem.options.steps_per_period))
        self.half = ShootingProblem(problem.model, problem.parameter, problem.base, opts)
        self.n2 = 2 * problem.model.n_dof
        self.reference = None
        self.largest = 0.0
        self.done = 0  # special points of the branch already judged

    def distance_vector(self, u, lam: float) -> np.ndarray:
        """``phi_{nu T0 / 2}(z) - z`` of the orbit's state ``z`` at ``t = 0``."""
        return np.asarray(self.half.residual(np.asarray(u, dtype=float)[:self.n2], lam), dtype=float)

    def test(self, point: PointInfo) -> float:
        d = self.distance_vector(point.u, point.lam)
        if self.reference is None:
            return float(np.linalg.norm(d))
        return float(d @ self.reference)

    def describe(self, point: PointInfo) -> dict:
        return {"half_period_distance": float(np.linalg.norm(self.distance_vector(point.u, point.lam))),
                "note": f"the orbit is {self.half.options.subharmonic}T-periodic: the branch of order "
                        f"{self.problem.options.subharmonic} returns to that of order {self.half.options.subharmonic}"}

    def advance(self, branch, i: int) -> None:
        """After the branch's point ``i`` is stored: its ``d`` becomes the reference of the next step's test."""
        d = self.distance_vector(branch.unknowns[i], float(branch.parameter[i]))
        size = float(np.linalg.norm(d))
        self.largest = max(self.largest, size)
        self.reference = d / size if size > 0 else None

    def returned(self, branch) -> SpecialPoint | None:
        """The located return among the branch's new special points, or None."""
        new, self.done = branch.special_points[self.done:], len(branch.special_points)
        for sp in new:
            if sp.event == self.name and sp.located and \
                    sp.data.get("half_period_distance", np.inf) <= self.RELATIVE * max(self.largest, 1e-300):
                return sp
        return None


def return_events(problem) -> list:
    """``[ReturnEvent(problem)]`` for a shooting branch of an even order, else ``[]``."""
    if is_shooting(problem) and problem.options.subharmonic % 2 == 0:
        return [ReturnEvent(problem)]
    return []


def watch_return(callback, events):
    """``callback`` that also stops the branch at a located :class:`ReturnEvent` (None: none to watch)."""
    ev = next((e for e in events if isinstance(e, ReturnEvent)), None)
    if ev is None:
        return callback

    def watched(branch, i):
        ev.advance(branch, i)
        go_on = True if callback is None else callback(branch, i)
        if ev.returned(branch) is not None:
            ev.stopped = True
            return False
        return go_on

    return watched


def finish_return(branch, events, monitors, checkpoint) -> None:
    """A branch stopped at its return (:func:`watch_return`) ends as a closed loop, saying where and why; its
    end is then checkpointed as the engine does for any finished branch."""
    ev = next((e for e in events if isinstance(e, ReturnEvent) and getattr(e, "stopped", False)), None)
    if ev is None or branch.status is not BranchStatus.INTERRUPTED:
        return
    sp = next(s for s in reversed(branch.special_points) if s.event == ev.name)
    half = ev.half.options.subharmonic
    branch.status = BranchStatus.CLOSED_LOOP
    branch.message = (f"returned to the branch of order nu={half} at its period doubling at "
                      f"{branch.parameter_name}={sp.parameter:.10g} (the orbit is {half}T-periodic there, "
                      f"|x(t + {half}T) - x(t)| = {sp.data.get('half_period_distance', float('nan')):.1e}); beyond "
                      f"it the branch retraces its orbits shifted by {half} forcing period(s): a closed loop")
    branch.info["returned"] = {"parameter": float(sp.parameter), "order": half}
    if checkpoint is not None:
        checkpoint(branch, {"monitors": [m.state() if hasattr(m, "state") else None for m in monitors]})
