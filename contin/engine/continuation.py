"""Pseudo-arclength continuation of ``R(u, lam) = 0`` for any problem object.

The engine knows nothing about the origin of ``R``: it only calls the
:class:`Problem` protocol. It traces a branch of solutions ``(u, lam)``,
``u`` of shape (m,), from a start point, passing folds, detecting and locating
special points (events) and ending with a :class:`~contin.engine.branch.BranchStatus`
instead of raising on numerical trouble.

Method
------
- Scaled variables ``x = (u / su, lam / sl)`` (see :class:`Scaling`); the step
  size, the arclength and the tangents are in these coordinates.
- Predictor: Euler step ``x_pred = x + ds t`` along the unit tangent.
- Corrector: Newton on the bordered system
  ``[R(u, lam) = 0; t . (x - x_pred) = 0]`` (LU of the (m+1)x(m+1) matrix).
- New tangent: ``[[Ju su, Jlam sl], [t_old^T]] z = [0, 1]``, ``t = z/|z|``,
  which keeps the orientation through folds. The same factorisation gives
  the sign of the bordered determinant (branch-point test) and a condition
  estimate.
- Step control: growth by ``grow`` after easy steps, shrinking by ``shrink``
  after a failure (no convergence, a corrector moving farther than ``ds``
  from the prediction, or a tangent turning by more than ``max_angle_deg``,
  which prevents jumping onto another branch); another rule may be given as
  ``step_control`` (:mod:`contin.engine.step_control`).
- Corners: a non-smooth problem (a contact that opens or closes, grazing)
  has branches whose tangent jumps. A smooth curve's turn shrinks with the
  step (``angle ~ curvature * ds``); a corner's does not. When the turn over
  a step ``corner_ratio`` times shorter than an earlier rejected one is still
  more than half as large, the step is accepted and a ``kink`` special point
  is recorded (``corners=True``); otherwise the step keeps shrinking.
- Range ends are landed on exactly (Newton at fixed ``lam = end``).
- Against jumps between neighbouring sheets closer than one step (a lightly
  damped resonance beside its backbone), a converged step is also rejected
  when its chord leans off the bisector of its end tangents by more than
  twice their turn, or when a variable moves against both end tangents; a
  branch that passes again through one of its earlier points, in the same
  direction, stops with ``RETRACED`` (a shortfall) and says so.
- Scaling: the automatic scalar scale follows the unknowns when they grow
  100-fold; dofs whose magnitudes differ by more than ``GROUP_SPREAD``
  (:mod:`contin.engine.stepsize`) are scaled separately
  (``problem.unknown_groups()``).
- Newton that cycles between two pieces of a piecewise-smooth residual is
  retried with step halving (:meth:`contin.engine.corrector.Corrector.newton`).
- ``Branch.info`` reports ``max_condition`` (where: ``max_condition_parameter``)
  and ``last_condition``, LAPACK ``gecon`` estimates of the scaled bordered
  Jacobian, ``n_backtracked`` and ``rescalings``;
  :func:`connection_report` checks a finished branch for jumps.

The parts, each in its module of :mod:`contin.engine`: ``options``
(:class:`ContinuationOptions`), ``problem`` (the :class:`Problem` protocol,
the scaled problem), ``predictor`` (tangents, orientation, the Hermite arc),
``corrector`` (the bordered Newton solve and the step's checks),
``step_control`` (the step-size rule), ``stepsize`` (the steps' bookkeeping
and the scales), ``corners``, ``location`` (events in a step), ``barriers``,
``ends`` (range ends, turning back, loops),
``state`` (what a checkpoint holds and a restart reads) and ``connection``
(:func:`connection_report`). This module holds the main loop that composes
them, :func:`continuation`.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Iterable, Mapping

import numpy as np

from contin.engine.barriers import Barriers, near_side_point
from contin.engine.branch import Branch, BranchBuilder, BranchStatus, PointRejected, SpecialKind, SpecialPoint
from contin.engine.connection import connection_report
from contin.engine.corners import Corners, kink_point
from contin.engine.corrector import Candidate, Corrector, Failure, StepFailed, format_parameter
from contin.engine.ends import (attempt, closed, finish_at_range_end, left_at_start, revisit_end, revisited, toward,
                                uncovered)
from contin.engine.events import BranchPointEvent, Event, FoldEvent, PointInfo
from contin.engine.location import EventLocation, test_values
from contin.engine.newton import NUMERICAL_ERRORS, SingularMatrixError, factorize
from contin.engine.options import ContinuationOptions, Scaling, as_options
from contin.engine.predictor import initial_tangent, unit_tangent
from contin.engine.problem import (
    Monitor,
    Problem,
    ScaledProblem,
    bordered_matrix,
    checked_start,
    evaluate_monitors,
    point_info,
    scaled_jacobian,
)
from contin.engine.state import Position, restore, save
from contin.engine.step_control import StepControl, as_step_control
from contin.engine.stepsize import ScaleControl, StepKeeper, condition, rescaled_direction, rescaled_point

__all__ = ["ContinuationOptions", "Monitor", "Problem", "Scaling", "StepControl", "connection_report", "continuation"]


class _Engine:
    """One continuation run: the main loop, composing the parts around the branch's position.

    The parts: :attr:`corrector` (:class:`~contin.engine.corrector.Corrector`),
    :attr:`step` (:class:`~contin.engine.stepsize.StepKeeper`, with the step rule), :attr:`scales`
    (:class:`~contin.engine.stepsize.ScaleControl`), :attr:`corners`,
    :attr:`barriers`, :attr:`location` (:class:`~contin.engine.location.EventLocation`);
    :attr:`pos` (:class:`~contin.engine.state.Position`) is where the branch is.
    """

    def __init__(self, problem, u0, lam0, lam_range, options, parameter_name, events, monitors, tangent, callback,
                 solve_start, checkpoint=None, step_control=None):
        self.problem = problem
        self.checkpoint = checkpoint
        self.opt = options
        self.name = parameter_name
        self.u0 = u0
        self.lam0 = lam0
        self.lo, self.hi = lam_range
        self.user_tangent = tangent
        self.callback = callback
        self.solve_start = solve_start
        self.monitors = list(monitors)
        evs = []
        if options.detect_folds:
            evs.append(FoldEvent())
        if options.detect_branch_points:
            evs.append(BranchPointEvent())
        evs.extend(events)
        self.events = evs
        self.m = u0.size
        self.builder = BranchBuilder(parameter_name, self.m)
        self.branch = self.builder.branch
        self.pos = Position()
        self.corrector = Corrector(options, parameter_name, self.m)
        self.step = StepKeeper(options, step_control)
        self.scales = ScaleControl(problem, options, self.m)
        self.corners = Corners(self.corrector, options, lam_range)
        self.barriers = Barriers(self.corrector, self.events, options)
        self.location = EventLocation(self.events, self.monitors, self.corrector, self.barriers, self.builder, options)
        # the worst and the last condition estimates of the stored points' bordered matrices
        self.min_rcond = math.inf
        self.min_rcond_index = -1
        self.last_rcond = math.nan
        self._options_dict = options.to_dict()

    @property
    def sp(self) -> ScaledProblem | None:
        """The problem in the current scales (None before the start)."""
        return self.corrector.sp

    @sp.setter
    def sp(self, value: ScaledProblem) -> None:
        self.corrector.sp = value

    def fmt(self, lam: float) -> str:
        """``name=value`` of a parameter value, for messages."""
        return format_parameter(self.name, lam)

    # -- start, resume ------------------------------------------------------
    def start(self) -> bool:
        """Solve (or take) the start point, choose the scales and the start tangent, store it; False if it failed."""
        opt, m, lam0 = self.opt, self.m, self.lam0
        corrector = self.corrector
        if self.solve_start:
            self.sp = ScaledProblem(self.problem, m, np.ones(m), 1.0)  # shape checks only
            res = corrector.fixed_solve(lam0, self.u0)
            if not res.converged:
                self.builder.finish(
                    BranchStatus.START_FAILED,
                    f"Newton did not converge at the start parameter {self.fmt(lam0)}: {res.message}",
                )
                return False
            u = res.x
            iterations = res.iterations
        else:
            u = self.u0.copy()
            iterations = 0
        calls = self.sp.calls if self.sp is not None else 0
        su, sl = self.scales.initial(u, lam0, self.lo, self.hi)
        self.sp = sp = ScaledProblem(self.problem, m, su, sl)
        sp.calls = calls
        x = np.empty(m + 1)
        x[:m] = u / su
        x[m] = lam0 / sl
        try:
            R, Ju, Jlam = sp.evaluate(u, lam0)  # exact lam0, not lam0 / sl * sl
            Jh = scaled_jacobian(Ju, Jlam, su, sl)
        except NUMERICAL_ERRORS as exc:
            return self._start_failed(f"evaluation failed at the start point ({type(exc).__name__}: {exc})")
        if not (np.all(np.isfinite(R)) and np.all(np.isfinite(Jh))):
            return self._start_failed("non-finite residual or Jacobian at the start point")
        t = initial_tangent(Jh, self.user_tangent, opt.direction)
        if t is None:
            return self._start_failed("could not compute the initial tangent (non-finite Jacobian)")
        lam = lam0
        if float(np.max(np.abs(R), initial=0.0)) > opt.newton_tol:
            # solve_start=False with an inexact guess: correct on the hyperplane
            # normal to the tangent (works at folds, where fixed-lam Newton fails)
            cres = corrector.bordered_solve(x.copy(), x.copy(), t, 0.0)
            if not cres.converged or cres.lu is None:
                return self._start_failed(
                    f"Newton did not converge near the start point {self.fmt(lam0)}: {cres.message}"
                )
            iterations = cres.iterations
            x = cres.x.copy()
            u, lam = sp.last[0].copy(), sp.last[1]
        u_, lam_, R, Ju, Jlam = sp.last
        try:
            lu = factorize(bordered_matrix(Ju, Jlam, su, sl, t))
        except SingularMatrixError as exc:
            return self._start_failed(
                f"the bordered Jacobian is singular at the start point {self.fmt(lam)} ({exc}); "
                "the start is a singular point of the branch: start nearby"
            )
        t = unit_tangent(lu, corrector.e_last)
        if t is None:
            return self._start_failed("non-finite tangent")
        pos = self.pos
        pos.x = x
        pos.u = np.array(u, dtype=float)
        pos.lam = float(lam)
        pos.t = t
        pos.s = 0.0
        pos.x_start = x.copy()
        pos.t_start = t.copy()
        self.step.jac_norm_start = float(np.max(np.abs(Ju * su), initial=0.0))
        pos.max_dist = 0.0
        try:
            data = evaluate_monitors(self.monitors, pos.u, pos.lam, Ju, Jlam)
        except NUMERICAL_ERRORS as exc:
            raise Failure(BranchStatus.START_FAILED,
                          f"a monitor failed at the start {self.fmt(pos.lam)} ({type(exc).__name__}: {exc})")
        pos.info = point_info(pos.u, pos.lam, t, lu, Ju, Jlam, 0.0, data)
        res_norm = float(np.max(np.abs(R), initial=0.0))
        self._store(pos.info, iterations, 0.0, res_norm)
        pos.g = test_values(self.events, pos.info)
        self.builder.add_special(
            SpecialPoint(SpecialKind.START, pos.lam, pos.u.copy(), (pos.lam, pos.lam), 0, 0.0,
                         located=True, message="start point", event="start", tangent=t.copy())
        )
        return self._after_store()

    def _start_failed(self, message: str) -> bool:
        """End the branch with ``START_FAILED``; False."""
        self.builder.finish(BranchStatus.START_FAILED, message)
        return False

    def state(self) -> dict:
        """What the main loop carries from the last stored point to the next step (:func:`contin.engine.state.save`)."""
        return save(self)

    def restart(self, branch: Branch, state: Mapping[str, Any]) -> None:
        """Take up ``branch`` where :meth:`state` left it (:func:`contin.engine.state.restore`)."""
        restore(self, branch, state)

    # -- bookkeeping -----------------------------------------------------
    def _store(self, info: PointInfo, iterations: int, step: float, res_norm: float) -> int:
        """Append the point to the branch (a point the branch refuses ends it); its index."""
        try:
            index = self.builder.append_point(
                u=info.u, lam=info.lam, tangent=info.tangent, s=info.s,
                newton_iterations=iterations, step_size=step, residual_norm=res_norm, data=info.data,
            )
        except PointRejected as exc:
            raise Failure(BranchStatus.NEWTON_FAILED, f"point at {self.fmt(info.lam)} not stored: {exc}")
        if info.rcond < self.min_rcond:
            self.min_rcond = info.rcond
            self.min_rcond_index = index
        self.last_rcond = info.rcond
        return index

    def _after_store(self) -> bool:
        """Callback; False if it asks to stop."""
        if self.callback is None:
            return True
        index = len(self.branch) - 1
        self._update_info()
        if self.callback(self.branch, index) is False:
            self.builder.finish(BranchStatus.INTERRUPTED, f"stopped by the callback at {self.fmt(self.pos.lam)}")
            return False
        return True

    def _update_info(self):
        """Write the scales, the condition estimates and the counters into ``branch.info``."""
        b = self.branch
        b.info.update(
            unknown_scale=self.sp.su.copy(),
            parameter_scale=self.sp.sl,
            lam_range=(self.lo, self.hi),
            min_rcond=self.min_rcond,
            min_rcond_index=self.min_rcond_index,
            # 1-norm condition estimates (LAPACK gecon on the LU each corrector makes anyway) of
            # the scaled, row-equilibrated bordered Jacobian [[Ju su, Jlam sl], [t]]
            max_condition=condition(self.min_rcond),
            max_condition_parameter=(float(b.parameter[self.min_rcond_index])
                                     if 0 <= self.min_rcond_index < len(b) else math.nan),
            last_condition=condition(self.last_rcond),
            n_rejected_steps=self.step.n_rejected,
            n_newton_iterations=self.corrector.n_newton,
            n_backtracked=self.corrector.n_backtracked,
            rescalings=list(self.scales.rescalings),
            n_linearizations=self.sp.calls,
            last_failure=self.step.last_failure,
            options=self._options_dict,
        )

    def _diagnosis(self) -> str:
        """What the last stored point says about a stop (:meth:`StepKeeper.diagnosis`)."""
        return self.step.diagnosis(self.pos.info, self.sp.su)

    # -- main loop -------------------------------------------------------
    def run(self) -> Branch:
        """Step until the branch ends (its status says how)."""
        opt, step = self.opt, self.step
        while True:
            if len(self.branch) >= opt.point_cap:
                self._finish_at_cap()
                return self.branch
            ds_try = step.trial()
            try:
                cand = attempt(self.corrector, self.pos, ds_try, (self.lo, self.hi))
            except StepFailed as exc:
                cand = exc
            except NUMERICAL_ERRORS as exc:
                cand = StepFailed(f"evaluation failed ({type(exc).__name__}: {exc})")
            if cand is None:
                self._finish_range_end(len(self.branch) - 1)
                return self.branch
            if isinstance(cand, StepFailed):
                cand = self._recover(cand, ds_try)
            if isinstance(cand, StepFailed):
                if not self._rejected(cand, ds_try):
                    return self.branch
                continue
            self.corners.settle(cand, ds_try)
            if not self._accept(cand) or not self._goes_on(cand, ds_try):
                return self.branch
            step.accepted(cand.h, cand.iterations)
            if self.checkpoint is not None:
                self.checkpoint(self.branch, self.state())

    def _finish_at_cap(self) -> None:
        """End the branch on its cap of stored points: ``MAX_POINTS`` if the caller set it, else a shortfall."""
        opt, where = self.opt, self.fmt(self.pos.lam)
        if opt.max_points is not None:
            self.builder.finish(BranchStatus.MAX_POINTS, f"stored max_points={opt.max_points} points; last at {where}")
            return
        # a cap nobody asked for: the branch did not reach where it was going
        self.builder.finish(
            BranchStatus.DEFAULT_MAX_POINTS,
            f"stored the default cap of {opt.point_cap} points (max_points was not set); last at {where}: "
            "raise max_points (continuation.max_points in a scene) to go on")

    def _recover(self, failed: StepFailed, ds_try: float) -> Candidate | StepFailed:
        """After a failed step: a barrier's point located ahead, or a step across a corner, else the failure."""
        cand = self.barriers.ahead(ds_try, self.pos, len(self.branch))
        if cand is not None:
            return cand
        if self.opt.corners:
            cand = self.corners.corner(failed, ds_try, self.pos.x, self.pos.t)
            if cand is not None:
                return cand
        return failed

    def _rejected(self, failed: StepFailed, ds_try: float) -> bool:
        """Count the failed step and shrink the next one; False if the branch ended at a barrier.

        Raises :class:`~contin.engine.corrector.Failure` when the step cannot shrink further.
        """
        self.step.rejected(failed)
        why = self.barriers.after_failure(failed.reason)
        if why is not None:
            self._finish_at_barrier(why)
            return False
        self.step.shrink(ds_try, failed, self.pos.info.rcond, self.fmt(self.pos.lam), self._diagnosis)
        return True

    def _accept(self, cand: Candidate) -> bool:
        """Store the candidate, locate the events on the step to it and move there; False if the callback stops."""
        pos = self.pos
        prev_x, prev_info, prev_g = pos.x, pos.info, pos.g
        pos.prev_x = prev_x
        s_new = pos.s + cand.h
        lam_new = cand.lam
        try:
            data = evaluate_monitors(self.monitors, cand.u, lam_new, cand.Ju, cand.Jlam)
        except NUMERICAL_ERRORS as exc:
            raise Failure(BranchStatus.NEWTON_FAILED,
                          f"a monitor failed at {self.fmt(lam_new)} ({type(exc).__name__}: {exc})")
        info = point_info(cand.u, lam_new, cand.tangent, cand.lu, cand.Ju, cand.Jlam, s_new, data)
        res_norm = float(np.max(np.abs(cand.R), initial=0.0))
        index = self._store(info, cand.iterations, cand.h, res_norm)
        g_new = test_values(self.events, info)
        # events on the arc between the previous and the new point
        t_prev = pos.t
        changed = self.location.on_step(prev_x, t_prev, prev_info, prev_g, cand, info, g_new, index,
                                        self.step.ds_free)
        if cand.barrier is not None:
            self.builder.add_special(near_side_point(cand.barrier, info, prev_info.lam, index))
            self.barriers.reached(cand.barrier, info.lam, cand.h, index, self.step.ds_free, near_side=True)
        self.step.event_cap = self.location.step_cap(changed, cand.barrier, prev_info, info, cand.h)
        pos.prev_info = prev_info
        pos.t_prev = t_prev  # the bordering row of the new point's Jacobian (for a restart)
        pos.x, pos.u, pos.lam, pos.t, pos.s = cand.x, cand.u, lam_new, cand.tangent, s_new
        pos.info, pos.g = info, g_new
        return self._after_store()

    def _goes_on(self, cand: Candidate, ds_try: float) -> bool:
        """The checks after a stored point; False if one of them ended the branch."""
        why = self.barriers.after_store(ds_try, cand.h, len(self.branch) - 1)
        if why is not None:
            self._finish_at_barrier(why)
            return False
        if self.step.crawled(ds_try):
            self.builder.finish(BranchStatus.STEP_TOO_SMALL,
                                self.step.crawl_message(self.fmt(self.pos.lam), self._diagnosis()))
            return False
        if cand.kink is not None:
            self.builder.add_special(kink_point(cand, self.branch))
        if cand.landed:
            self._finish_range_end(len(self.branch) - 1)
            return False
        self._rescale()
        if closed(self.pos, cand.x, len(self.branch), self.opt.max_angle_deg):
            self.builder.finish(BranchStatus.CLOSED_LOOP,
                                f"the branch returned to its start point {self.fmt(self.branch.parameter[0])}")
            return False
        k = revisited(self.branch, self.pos.prev_x, cand.x, self.sp.su, self.sp.sl, self.opt.max_angle_deg)
        if k is not None:
            self.builder.finish(*revisit_end(self.branch, k, self.fmt))
            return False
        return True

    def _rescale(self) -> None:
        """Grow the automatic scale with the unknowns (:meth:`ScaleControl.grow`) and convert the position to it."""
        pos = self.pos
        f = self.scales.grow(self.sp.su, pos.u, pos.lam)
        if f is None:
            return
        pos.x = rescaled_point(pos.x, f)
        pos.prev_x = rescaled_point(pos.prev_x, f)
        pos.x_start = rescaled_point(pos.x_start, f)
        pos.max_dist = float(np.linalg.norm(pos.x - pos.x_start))
        pos.t = rescaled_direction(pos.t, f)
        pos.t_start = rescaled_direction(pos.t_start, f)
        pos.info.tangent = pos.t
        self.corners.turns.clear()

    # -- ends ------------------------------------------------------------
    def _finish_at_barrier(self, why: str) -> None:
        """End the branch with ``BOUNDARY``: it cannot pass the barrier it is at."""
        self.builder.finish(BranchStatus.BOUNDARY, self.barriers.finish_message(why, self.name, self.pos.lam))

    def _finish_range_end(self, index: int) -> None:
        """End the branch on a range end at its stored point ``index``.

        Raises :class:`~contin.engine.corrector.Failure` (``ILL_CONDITIONED``) when the branch left the range
        where it started without covering any of it though asked into it (:func:`~contin.engine.ends.left_at_start`).
        """
        lam_start = float(self.branch.parameter[0])
        if self.user_tangent is None and left_at_start(self.branch, (self.lo, self.hi), lam_start, self.opt.direction):
            other = self.hi if lam_start == self.lo else self.lo
            raise Failure(
                BranchStatus.ILL_CONDITIONED,
                f"the branch left the parameter range at its start {self.fmt(lam_start)} without covering any of it, "
                f"though asked to go towards {self.fmt(other)}: the parameter component of its start tangent "
                f"({self.pos.t_start[-1]:.1e}) cannot tell the way into the range (a fold or a branch point at the "
                f"start, or a parameter scale, {self.sp.sl:.3g}, far larger than the branch's changes: set "
                "continuation.parameter_scale)")
        finish_at_range_end(self.builder, index, self._toward(), (self.lo, self.hi), self.lam0, self.name)

    def _toward(self) -> float:
        """The end of the range the branch set out towards (its start tangent's parameter direction)."""
        return toward(self.pos.t_start, self.opt.direction, (self.lo, self.hi))

    def _uncovered(self) -> tuple[float, tuple[float, float]]:
        """The furthest parameter reached towards :meth:`_toward` and the interval beyond it, left uncovered."""
        return uncovered(self.branch, self._toward(), (self.lo, self.hi), self.lam0)


def continuation(
    problem: Problem,
    u0,
    lam0: float,
    lam_range: tuple[float, float] = (-math.inf, math.inf),
    options: ContinuationOptions | Mapping[str, Any] | None = None,
    *,
    parameter_name: str = "lambda",
    events: Iterable[Event] = (),
    monitors: Iterable[Monitor] = (),
    tangent=None,
    callback: Callable[[Branch, int], Any] | None = None,
    solve_start: bool = True,
    checkpoint: Callable[[Branch, dict], Any] | None = None,
    restart: tuple[Branch, Mapping[str, Any]] | None = None,
    step_control: StepControl | None = None,
) -> Branch:
    """Trace the solution branch of ``R(u, lam) = 0`` through ``(u0, lam0)``.

    Parameters
    ----------
    problem : Problem
        Object with ``linearize(u, lam) -> (R, Ju, Jlam)`` (and optionally
        ``unknown_scale()``).
    u0 : array_like, shape (m,)
        Start guess (or exact start point).
    lam0 : float
        Start parameter, inside ``lam_range``.
    lam_range : (float, float)
        ``(lo, hi)``, ``lo < hi``; infinite bounds allowed. The branch stops
        exactly on a bound (status ``RANGE_END``).
    options : ContinuationOptions or mapping, optional
    parameter_name : str
        Used in messages and stored in the branch.
    events : iterable of Event
        Extra events (the fold and branch-point events are added according
        to the options).
    monitors : iterable of callables
        ``monitor(u, lam, Ju, Jlam) -> {name: value}`` evaluated at every
        stored and located point; stored in ``Branch.point_data`` and passed
        to events in ``PointInfo.data``.
    tangent : array_like, shape (m+1,), optional
        Start orientation (e.g. ``Branch.tangents[i]`` when resuming; only its
        orientation is used, it takes precedence over ``options.direction``).
    callback : callable, optional
        ``callback(branch, index)`` after each stored point; returning
        ``False`` (or raising ``KeyboardInterrupt``) stops with
        ``INTERRUPTED``.
    solve_start : bool
        If True, Newton at fixed ``lam0`` from ``u0`` first. If False,
        ``(u0, lam0)`` is taken as the start when it meets ``newton_tol``,
        otherwise it is corrected on the hyperplane through it normal to the
        tangent (usable at a fold).
    checkpoint : callable, optional
        ``checkpoint(branch, state)`` after each step that stored a point and
        did not end the branch, with the state the next step starts from
        (:func:`contin.engine.state.save`: arrays and plain values; with the
        branch's points it is everything a ``restart`` needs), and once more when the branch
        ends, with ``state = {"monitors": [...]}`` (the monitors' final states).
    restart : (Branch, dict), optional
        Continue ``branch`` (its points, point data and special points, as an
        interrupted run stored them) from a ``state`` given to ``checkpoint``
        at its last point: the run goes on exactly as the interrupted one
        would have (``u0``, ``lam0`` and ``tangent`` are then ignored; the
        same problem, options, events, monitors and step control must be given).
    step_control : StepControl, optional
        The step-size rule, with ``first``, ``accepted`` and ``rejected``
        (:mod:`contin.engine.step_control`); None: ``AdaptiveStep``, by the options.

    Returns
    -------
    Branch
        Never raises for numerical reasons: failures end the branch with a
        status and message (``START_FAILED`` gives an empty branch). Invalid
        arguments raise ``ValueError`` (a step control lacking a method:
        ``TypeError``). Other exceptions from the problem,
        monitors, events or callback propagate; the partial branch is then
        attached to the exception as ``exc.partial_branch``.
    """
    options = as_options(options)
    step_control = as_step_control(step_control)
    u0, lam0, (lo, hi), tangent, events = checked_start(u0, lam0, lam_range, tangent, events)
    eng = _Engine(problem, u0, lam0, (lo, hi), options, parameter_name, events, monitors, tangent, callback,
                  solve_start, checkpoint, step_control)
    if restart is not None:
        eng.restart(*restart)
    branch = eng.branch
    try:
        try:
            if restart is not None or eng.start():
                eng.run()
        except Failure as exc:
            eng.builder.finish(exc.status, exc.message)
        except KeyboardInterrupt:
            where = f" at {eng.fmt(eng.pos.lam)}" if len(branch) else ""
            eng.builder.finish(BranchStatus.INTERRUPTED, f"interrupted (KeyboardInterrupt){where}")
    except BaseException as exc:
        if branch.status is BranchStatus.RUNNING:
            branch.message = f"aborted by {type(exc).__name__}: {exc}"
        try:
            exc.partial_branch = branch
        except Exception:
            pass
        raise
    finally:
        if branch.status in (BranchStatus.MAX_POINTS, BranchStatus.DEFAULT_MAX_POINTS) or (
                branch.status not in (BranchStatus.RUNNING, BranchStatus.INTERRUPTED) and not branch.status.as_asked):
            eng._uncovered()
        if len(branch):
            eng._update_info()
        elif eng.sp is not None:
            branch.info.update(lam_range=(lo, hi), n_linearizations=eng.sp.calls,
                               n_newton_iterations=eng.corrector.n_newton)
    if checkpoint is not None and branch.status is not BranchStatus.INTERRUPTED:
        checkpoint(branch, {"monitors": [mon.state() if hasattr(mon, "state") else None for mon in eng.monitors]})
    return branch


