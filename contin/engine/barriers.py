"""Barriers: events whose zero the branch may be unable to pass.

A barrier event (:attr:`contin.engine.events.Event.barrier`, e.g. grazing:
the boundary of the problem's smooth domain) is located from the near side
when the steps fail short of where its distance predicts it
(:meth:`Barriers.ahead`). Once the branch is at a barrier's point (located
so, or between two stored points), the following steps must show that it
passes: over ``PASS_POINTS`` points a step of ``PASS_FRACTION`` of the one
that reached it, fewer than ``PASS_FAILURES`` failed steps and no second
change of the event (:meth:`Barriers.after_store`,
:meth:`Barriers.after_failure`); otherwise the branch ends there with
``BOUNDARY``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from contin.engine.branch import SpecialPoint
from contin.engine.corrector import Candidate, Corrector, StepFailed, format_parameter
from contin.engine.events import Event, PointInfo, narrow, predicted_zero
from contin.engine.newton import NUMERICAL_ERRORS
from contin.engine.predictor import predict
from contin.engine.problem import point_info

__all__ = ["Barrier", "Barriers", "near_side_point"]

#: A barrier event is located from the current point when its predicted zero lies within the failed
#: step (times BARRIER_REACH) and within BARRIER_AHEAD last steps.
BARRIER_REACH = 1.0
BARRIER_AHEAD = 2.0
#: The located bracket reaches this many times the predicted distance to the zero (not beyond the step).
BARRIER_MARGIN = 1.5
#: Solves spent locating a barrier, and its accuracy (relative to its distance where the steps failed).
BARRIER_SOLVES = 12
BARRIER_GTOL = 1e-9
#: Past a barrier's point the branch passes it when, over the next PASS_POINTS points, a step of
#: PASS_FRACTION of the step that reached it is taken again, fewer than PASS_FAILURES steps fail and
#: the event does not change again; otherwise it cannot pass it and ends there. A single grazing
#: with a corner (a stop's contact onset) is passed in a step or two of the corner machinery; a
#: bouncing cascade, each tangential touch opening the next, is not.
PASS_FRACTION = 1.0 / 16.0
PASS_POINTS = 8
PASS_FAILURES = 8
#: Two locations of a barrier within this many ``locate_tol`` (relative) are the same point.
SAME_POINT = 1e3


@dataclasses.dataclass
class Barrier:
    """A located point of a barrier event that the branch has yet to show it passes."""

    event: Event
    parameter: float
    reach: float  # the step that reached it
    index: int  # the stored point at it (near side) or just past it
    near_side: bool = False
    later: int = 0  # more of them located before the branch showed it passes the first
    last_parameter: float = math.nan
    failures: int = 0  # failed steps since
    recovered: bool = False  # a step of PASS_FRACTION of the reaching one was taken since


class Barriers:
    """The barrier the branch is at, and the location of barriers ahead of it.

    Parameters
    ----------
    corrector : Corrector
    events : list of Event
        All the engine's events (the barriers among them are used).
    options : ContinuationOptions

    Attributes
    ----------
    at_barrier : Barrier or None
        A barrier's point the branch has not yet shown it passes.
    barrier_tried : int
        Branch length at the last location ahead (tried once per stored point).
    """

    def __init__(self, corrector: Corrector, events: list, options):
        self.corrector = corrector
        self.events = events
        self.opt = options
        self.at_barrier: Barrier | None = None
        self.barrier_tried = -1

    def reached(self, ev: Event, lam: float, h: float, index: int, ds_free: float, near_side: bool = False) -> None:
        """The branch reached ``ev``'s point at ``lam`` (stored point ``index``, a step ``h`` from the previous one).

        ``ds_free``: the step the step control wanted there (not one an
        event cut short); ``near_side``: located from the near side, the
        point stored at it.
        """
        bar = self.at_barrier
        if bar is None:
            # judged against the step the step control wanted there, not one an event cut short
            self.at_barrier = Barrier(ev, lam, max(h, ds_free), index, near_side)
            return
        bar.index, bar.near_side = index, near_side
        last = bar.last_parameter if bar.later else bar.parameter
        if abs(lam - last) <= SAME_POINT * self.opt.locate_tol * max(1.0, abs(lam)):
            return  # the same point again (located from both sides)
        # a cascade (more contact arcs opening one after the other): judged against the step that
        # reached the first one
        bar.later += 1
        bar.last_parameter = lam

    def skips(self, ev: Event, index: int) -> bool:
        """Whether ``ev``'s change on the step to the stored point ``index`` is the barrier already
        recorded at ``index - 1`` (located from its near side)."""
        bar = self.at_barrier
        return bar is not None and bar.near_side and ev is bar.event and bar.index == index - 1

    def after_failure(self, reason: str) -> str | None:
        """Count a failed step beyond the barrier; why the branch cannot pass it, or None."""
        bar = self.at_barrier
        if bar is None:
            return None
        bar.failures += 1
        if bar.failures >= PASS_FAILURES:
            return f"{PASS_FAILURES} steps beyond it failed (the last: {reason})"
        return None

    def after_store(self, ds_try: float, h: float, last: int) -> str | None:
        """After a stored point ``last`` (a step ``h``, attempted as ``ds_try``): why the branch cannot pass
        the barrier, or None (it may yet, or it did: the barrier is forgotten)."""
        bar = self.at_barrier
        if bar is None or bar.index >= last:
            return None
        if bar.later:
            return f"it changed again within {PASS_POINTS} points (a cascade)"
        bar.recovered = bar.recovered or max(ds_try, h) >= PASS_FRACTION * bar.reach
        if last - bar.index >= PASS_POINTS:
            if not bar.recovered:
                return (f"{PASS_POINTS} points beyond it the steps had not recovered "
                        f"{PASS_FRACTION:.3g} of the step that reached it, {bar.reach:.2g}")
            self.at_barrier = None  # passed
        return None

    def finish_message(self, why: str, name: str, lam: float) -> str:
        """The ``BOUNDARY`` message: the branch cannot pass the barrier (``why``); its last point is at ``lam``."""
        bar = self.at_barrier
        more = (f"; {bar.later} more located after it, the last at {format_parameter(name, bar.last_parameter)}"
                if bar.later else "")
        return (f"the branch cannot pass the {bar.event.kind.value} point at {format_parameter(name, bar.parameter)} "
                f"({bar.event.name}{more}): {why}; last point at {format_parameter(name, lam)}")

    def ahead(self, ds: float, pos, n_points: int) -> Candidate | None:
        """A barrier event's point located ahead of the current one, as a candidate, or None.

        Called when a step of length ``ds`` from ``pos`` (the engine's
        :class:`~contin.engine.state.Position`; ``n_points`` stored so far)
        failed. A barrier event whose distance, extrapolated from the last
        two stored points, reaches zero within that step and within
        ``BARRIER_AHEAD`` last steps is located by
        :func:`contin.engine.bracketing.narrow` on its distance, solving on the
        hyperplanes normal to the current tangent; a solve that fails counts
        as beyond the barrier, and the point is taken on the near side.
        Tried once per stored point.
        """
        if self.barrier_tried == n_points or pos.prev_info is None or n_points < 2:
            return None
        self.barrier_tried = n_points
        h_last = float(pos.s - pos.prev_info.s)
        for ev in self.events:
            if not ev.barrier or (self.at_barrier is not None and ev is self.at_barrier.event):
                continue  # not a barrier, or the branch is at (or just past) its point already
            try:
                g_prev, g0 = float(ev.distance(pos.prev_info)), float(ev.distance(pos.info))
            except NUMERICAL_ERRORS:
                continue
            ahead = predicted_zero(g_prev, g0, h_last)
            if not (ahead <= BARRIER_REACH * ds and ahead <= BARRIER_AHEAD * h_last):
                continue  # not predicted there, or too far for the solves from here: shorter steps first
            cand = self._locate_ahead(ev, g0, (g0 - g_prev) / h_last, min(BARRIER_MARGIN * ahead, ds), pos)
            if cand is not None:
                return cand
        return None

    def _locate_ahead(self, ev: Event, g0: float, rate: float, s_end: float, pos) -> Candidate | None:
        """Locate ``ev``'s zero in ``(0, s_end]`` ahead of ``pos`` (``g0``, ``rate``: its distance
        there and its rate of change per arclength); a candidate on the near side, or None."""
        corrector = self.corrector
        x, t = pos.x, pos.t
        solved = {}

        def point_at(sigma):
            xp = predict(x, t, sigma)
            try:
                res = corrector.bordered_solve(xp.copy(), x, t, sigma, quick=True)
            except NUMERICAL_ERRORS as exc:
                return None, f"{type(exc).__name__}: {exc}"
            if not res.converged or res.lu is None:
                return None, "no solution"
            try:
                cand = corrector.check(x, t, res.x, xp, sigma, res.lu, res.rcond, res.iterations)
            except StepFailed as exc:
                return None, exc.reason
            info = point_info(cand.u, cand.lam, cand.tangent, cand.lu, cand.Ju, cand.Jlam, pos.s + cand.h, {})
            solved[id(info)] = (info, cand)
            return info, ""

        # the far end is not solved: its distance is the one predicted there
        far = dataclasses.replace(pos.info, lam=pos.lam + s_end * float(t[-1]) * corrector.sp.sl)
        loc = narrow(point_at, 0.0, s_end, pos.info, far, g0, g0 + rate * s_end, s_end,
                     side=lambda info, v: math.isfinite(v) and (v < 0) == (g0 < 0), value=ev.distance,
                     tol=self.opt.locate_tol, max_iter=BARRIER_SOLVES, vtol=BARRIER_GTOL, failed_beyond=True)
        if not loc.located or id(loc.point) not in solved:
            return None
        cand = solved[id(loc.point)][1]
        cand.barrier = ev
        return cand


def near_side_point(ev: Event, info: PointInfo, lam_prev: float, index: int) -> SpecialPoint:
    """The special point of a barrier located from the near side and stored as point ``index``."""
    try:
        data = dict(ev.describe(info))
    except NUMERICAL_ERRORS as exc:
        data = {"describe_error": f"{type(exc).__name__}: {exc}"}
    return SpecialPoint(
        kind=ev.kind, parameter=float(info.lam), unknowns=info.u.copy(), interval=(lam_prev, info.lam),
        index=index, s=float(info.s), located=True, data=data, event=ev.name,
        message=f"{ev.name}: located from the near side, where the steps failed", tangent=info.tangent.copy(),
        point_data={k: np.array(v) for k, v in info.data.items()},
    )
