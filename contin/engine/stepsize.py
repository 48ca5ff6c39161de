"""Step control and the scales of the variables.

- :class:`StepKeeper`: the step the next attempt takes (the one the step
  rule wants, :mod:`contin.engine.step_control`, within ``[ds_min, ds_max]``
  and capped by the events' predictions), the stops for a step below
  ``ds_min``, a rule that does not shorten a failed step or an
  ill-conditioned bordered matrix, and the crawl test (``stall_points``
  stored points advancing less than ``ds_max`` in all);
- :class:`ScaleControl`: the scales ``su`` (m,) and ``sl`` of the scaled
  variables ``x = (u / su, lam / sl)``, chosen at the start (per group of
  unknowns when their magnitudes are far apart) and grown with the unknowns.
"""

from __future__ import annotations

import collections
import math
from typing import Callable

import numpy as np

from contin.engine.branch import BranchStatus
from contin.engine.corrector import Failure, StepFailed
from contin.engine.events import PointInfo
from contin.engine.options import Scaling
from contin.engine.step_control import AdaptiveStep, StepControl
from contin.util.naming import is_finite_real

__all__ = ["ScaleControl", "StepKeeper", "condition", "rescaled_direction", "rescaled_point"]

#: Below this reciprocal condition estimate the bordered matrix is ill-conditioned: a failed step
#: there ends the branch (``ILL_CONDITIONED``).
ILL_RCOND = 1e-15
#: Growth of the scaled Jacobian since the start that a stop message points out.
JACOBIAN_GROWTH = 1e3
#: A step capped by an event's prediction is never below this fraction of the uncapped step.
EVENT_FLOOR = 1e-3

#: Growth of ``||u||_inf`` (of a group) over its automatic scale that updates the scale.
RESCALE_FACTOR = 100.0
#: Spread of the groups' magnitudes at the start beyond which each group gets its own scale.
GROUP_SPREAD = 1e3
#: Smallest automatic scale of the unknowns (a start point of that size or smaller is taken as this).
TINY_SCALE = 1e-12


def condition(rcond: float) -> float:
    """Condition estimate from a reciprocal one (``inf`` for a singular matrix, NaN if none)."""
    if not math.isfinite(rcond):
        return math.nan
    return math.inf if rcond <= 0 else 1.0 / rcond


class StepKeeper:
    """The step the step rule wants, and what the engine does after a failed or a stored step.

    Parameters
    ----------
    options : ContinuationOptions
    rule : StepControl, optional
        The step-size rule (:mod:`contin.engine.step_control`); default
        :class:`~contin.engine.step_control.AdaptiveStep`. Its ``first`` is
        asked here.

    Attributes
    ----------
    rule : StepControl
    ds : float
        The step it wants next (events may cap the one taken).
    recent : deque of float
        Steps of the last ``stall_points`` stored points (the crawl test).
    event_cap : float
        The longest next step the events allow (``inf``: none).
    ds_free : float
        The step wanted at the latest attempt, before the events' cap.
    n_rejected : int
        Failed steps so far.
    last_failure : str
        Why the latest step failed.
    jac_norm_start : float
        ``max |Ju su|`` at the start (the stop messages say how much it grew).
    """

    def __init__(self, options, rule: StepControl | None = None):
        self.opt = options
        self.rule = AdaptiveStep() if rule is None else rule
        self.ds = self._bounded(self.rule.first(options), "first")
        self.recent = collections.deque((), maxlen=options.stall_points)
        self.event_cap = math.inf
        self.ds_free = self.ds
        self.n_rejected = 0
        self.last_failure = ""
        self.jac_norm_start = math.nan

    def _bounded(self, ds, method: str) -> float:
        """The step ``rule.<method>`` returned, within ``[ds_min, ds_max]``; ``ValueError`` if it is no step."""
        if not is_finite_real(ds) or not ds > 0:
            raise ValueError(f"step_control.{method} returned {ds!r}; expected a positive finite step")
        opt = self.opt
        return min(max(float(ds), opt.ds_min), opt.ds_max)

    def trial(self) -> float:
        """The step of the next attempt: the wanted one, cut to an event predicted within it."""
        opt, ds = self.opt, self.ds
        ds_try = self.ds_free = ds
        if self.event_cap < ds:  # an event predicted within the step
            ds_try = max(self.event_cap, opt.ds_min, EVENT_FLOOR * ds)
        return ds_try

    def rejected(self, failed: StepFailed) -> None:
        """Count a failed step."""
        self.n_rejected += 1
        self.last_failure = failed.reason

    def shrink(self, ds_try: float, failed: StepFailed, rcond_here: float, where: str,
               diagnosis: Callable[[], str]) -> None:
        """Shrink the step after a failed attempt of ``ds_try``, or end the branch with :class:`Failure`.

        It ends when the bordered matrix at the current point (``rcond_here``)
        is ill-conditioned, when the failed step was already at ``ds_min``, or
        when the rule's next step is not shorter than the failed one.
        ``where`` names the current point; ``diagnosis()`` adds what the
        Jacobian says to a ``STEP_TOO_SMALL`` message.
        """
        opt = self.opt
        if rcond_here < ILL_RCOND:
            raise Failure(
                BranchStatus.ILL_CONDITIONED,
                f"the bordered Jacobian is ill-conditioned at {where} "
                f"(rcond={rcond_here:.1e}) and the step failed: {failed.reason}",
            )
        if ds_try <= opt.ds_min:
            if failed.rcond < ILL_RCOND:
                raise Failure(
                    BranchStatus.ILL_CONDITIONED,
                    f"step size fell below ds_min={opt.ds_min:g} near {where} with an "
                    f"ill-conditioned Jacobian (rcond={failed.rcond:.1e}): {failed.reason}",
                )
            raise Failure(
                BranchStatus.STEP_TOO_SMALL,
                f"step size fell below ds_min={opt.ds_min:g} at {where}; "
                f"last failure: {failed.reason}{diagnosis()}",
            )
        wanted = self.rule.rejected(ds_try, failed.reason)
        if is_finite_real(wanted) and not wanted < ds_try:
            # the same step again would fail again, for ever
            raise Failure(
                BranchStatus.STEP_TOO_SMALL,
                f"the step of {ds_try:g} failed at {where} and the step control ({type(self.rule).__name__}) "
                f"did not shorten it (it asked for {wanted:g}); last failure: {failed.reason}{diagnosis()}",
            )
        self.ds = self._bounded(wanted, "rejected")

    def crawled(self, ds_try: float) -> bool:
        """Record the step of a stored point; whether the last ``stall_points`` advanced less than ``ds_max``."""
        opt, ds = self.opt, self.ds
        self.recent.append(ds if ds_try < ds else ds_try)  # a step cut short by an event is no crawl
        return len(self.recent) == opt.stall_points and sum(self.recent) < opt.ds_max

    def crawl_message(self, where: str, diagnosis: str) -> str:
        """The stop message of a crawl ending at ``where``."""
        opt = self.opt
        return (f"the branch crawled: {opt.stall_points} points advanced {sum(self.recent):.2g} in all "
                f"(ds_max={opt.ds_max:g}) up to {where}; last failure: {self.last_failure}{diagnosis}")

    def accepted(self, taken: float, iterations: int) -> None:
        """The next wanted step after a stored point: the rule's (the default grows it after a corrector that
        converged in at most ``newton_easy`` updates); ``taken`` is the stored step's length."""
        self.ds = self._bounded(self.rule.accepted(self.ds, taken, iterations), "accepted")

    def diagnosis(self, info: PointInfo | None, su: np.ndarray) -> str:
        """What the last stored point says about a stop: condition and growth of the Jacobian."""
        parts = []
        try:
            norm = float(np.max(np.abs(info.Ju * su)))
        except (AttributeError, ValueError):
            return ""
        if self.jac_norm_start > 0 and norm > JACOBIAN_GROWTH * self.jac_norm_start:
            parts.append(f"the scaled Jacobian grew {norm / self.jac_norm_start:.1e}-fold since the start "
                         "(the model blows up there?)")
        if math.isfinite(info.rcond):
            parts.append(f"condition estimate {condition(info.rcond):.1e}")
        return "; " + "; ".join(parts) if parts else ""


class ScaleControl:
    """The scales of the variables: chosen at the start, grown with the unknowns.

    Parameters
    ----------
    problem : Problem
        Asked for ``unknown_scale()`` and ``unknown_groups()`` (both optional).
    options : ContinuationOptions
    m : int

    Attributes
    ----------
    adaptive_scale : bool
        The unknowns' scale is a guess from the start point, grown by :meth:`grow`.
    groups : ndarray of int, shape (m,)
        Group of each unknown (all 0 unless grouped).
    rescalings : list of (float, float, float)
        ``(parameter, old largest scale, new largest scale)`` of each growth.
    """

    def __init__(self, problem, options, m: int):
        self.problem = problem
        self.opt = options
        self.m = m
        self.adaptive_scale = False
        self.groups = np.zeros(m, dtype=np.intp)
        self.rescalings: list = []

    def initial(self, u: np.ndarray, lam0: float, lo: float, hi: float) -> tuple[np.ndarray, float]:
        """``(su, sl)`` for the start point ``u`` (m,) at ``lam0`` and the range ``(lo, hi)`` (see :class:`Scaling`)."""
        opt, m = self.opt, self.m
        auto = opt.scaling is Scaling.AUTO
        if opt.parameter_scale is not None:
            sl = opt.parameter_scale
        elif auto and math.isfinite(hi - lo) and hi > lo:
            sl = hi - lo
        elif auto:
            sl = max(abs(lam0), 1.0)
        else:
            sl = 1.0
        su = None
        if opt.unknown_scale is not None:
            su = np.broadcast_to(np.asarray(opt.unknown_scale, dtype=float), (m,)).copy()
            if np.asarray(opt.unknown_scale).ndim == 1 and len(opt.unknown_scale) != m:
                raise ValueError(
                    f"ContinuationOptions.unknown_scale has {len(opt.unknown_scale)} values for {m} unknowns")
        elif auto:
            getter = getattr(self.problem, "unknown_scale", None)
            given = getter() if callable(getter) else None
            if given is not None:
                arr = np.asarray(given, dtype=float)
                if arr.ndim == 0:
                    arr = np.full(m, float(arr))
                if arr.shape != (m,) or not np.all(np.isfinite(arr)):
                    raise ValueError(f"problem.unknown_scale() must return {m} finite values or None")
                if np.any(arr > 0):
                    su = np.where(arr > 0, arr, arr.max())
            if su is None:
                norm = float(np.max(np.abs(u))) if m else 0.0
                su = np.full(m, max(norm, TINY_SCALE) if norm > 0 else 1.0)
                self.adaptive_scale = True  # a guess from one point: updated as the unknowns grow
                self.groups = np.zeros(m, dtype=np.intp)
                grouped = self._grouped_scale(u, norm)
                if grouped is not None:
                    su = grouped
        else:
            su = np.ones(m)
        return su, float(sl)

    def _grouped_scale(self, u: np.ndarray, norm: float):
        """One scale per group of unknowns when their magnitudes are far apart, else None.

        ``problem.unknown_groups()`` (optional) labels the unknowns that share
        a unit (for harmonic balance, the coefficients of one degree of
        freedom). When the groups' magnitudes at the start span more than
        ``GROUP_SPREAD``, a single scale would make the small ones invisible
        to the step control (a fold of a dof measured in micrometres next
        to one in kilometres is passed blindly), so each group gets its own.
        """
        getter = getattr(self.problem, "unknown_groups", None)
        groups = getter() if callable(getter) else None
        if groups is None or not norm > 0:
            return None
        groups = np.asarray(groups)
        if groups.shape != (self.m,):
            raise ValueError(f"problem.unknown_groups() must return {self.m} labels")
        _, groups = np.unique(groups, return_inverse=True)
        mags = np.zeros(groups.max() + 1)
        np.maximum.at(mags, groups, np.abs(u))
        if mags.size < 2 or not np.all(mags > 0) or norm <= GROUP_SPREAD * mags.min():
            return None
        self.groups = groups
        return mags[groups]

    def grow(self, su: np.ndarray, u: np.ndarray, lam: float) -> np.ndarray | None:
        """Grow the automatic scale ``su`` (m,, in place) with the unknowns ``u`` at ``lam``.

        The automatic scale comes from the start point alone. A lightly
        damped resonance starting from a tiny response (1e-6 at the start,
        0.5 at the peak) would otherwise need millions of steps of at most
        ``ds_max``. So the scale follows ``||u||_inf`` whenever it has grown
        by ``RESCALE_FACTOR``. It never shrinks: a scale following the
        response back down would magnify each small wiggle of the branch (a
        contact's corners) into steps that jump.

        Returns
        -------
        ndarray of shape (m,) or None
            The factor ``new su / old su`` by which the scaled points are to
            be divided (:func:`rescaled_point`), or None if nothing changed.
        """
        if not self.adaptive_scale:
            return None
        groups = self.groups
        mags = np.zeros(groups.max() + 1)
        np.maximum.at(mags, groups, np.abs(u))
        cur = np.zeros_like(mags)
        np.maximum.at(cur, groups, su)
        grow = mags > RESCALE_FACTOR * cur
        if not grow.any():
            return None
        new = np.where(grow, mags, cur)
        f = (new / cur)[groups]
        old_max = float(su.max())
        su[:] = new[groups]
        self.rescalings.append((lam, old_max, float(su.max())))
        return f


def rescaled_point(x: np.ndarray, f: np.ndarray) -> np.ndarray:
    """A scaled point (m+1,) in the unknowns' scale grown by the factors ``f`` (m,) (a copy)."""
    x = x.copy()
    x[:f.size] /= f
    return x


def rescaled_direction(t: np.ndarray, f: np.ndarray) -> np.ndarray:
    """A unit direction (m+1,) in the grown scale, normalised again (a positive diagonal change of
    variables keeps every orientation and sign the events use)."""
    t = rescaled_point(t, f)
    return t / np.linalg.norm(t)
