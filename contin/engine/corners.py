"""Corners: where the tangent of a non-smooth branch jumps.

A non-smooth problem (a contact that opens or closes, grazing) has branches
whose tangent jumps. A smooth curve's turn shrinks with the step
(``angle ~ curvature * ds``); a corner's does not. :class:`Corners` keeps
the failed steps from the current point and, once the step has shrunk
``corner_ratio`` times, tells a corner from a tight smooth turn and steps
across it; the candidate beyond carries ``kink`` and is recorded as a
``kink`` special point (:func:`kink_point`).
"""

from __future__ import annotations

import math

import numpy as np

from contin.engine.branch import Branch, SpecialKind, SpecialPoint
from contin.engine.corrector import Candidate, Corrector, StepFailed
from contin.engine.newton import NUMERICAL_ERRORS
from contin.engine.predictor import orient_along_secant

__all__ = ["Corners", "kink_point"]

#: Below this parameter component the tangent is vertical: the branch is no graph over the parameter.
VERTICAL_TANGENT = 1e-3
#: The unknown dominating the tangent must have at least this component to step across a corner at fixed value.
DOMINANT_COMPONENT = 0.1
#: A corner's turn over a step ``corner_ratio`` times shorter stays at least this fraction of the earlier one.
PERSISTENT_TURN = 0.5


class Corners:
    """The failed steps from the current point, and the steps across a corner.

    Parameters
    ----------
    corrector : Corrector
    options : ContinuationOptions
    lam_range : (float, float)
        A step across a corner must stay within it.

    Attributes
    ----------
    turns : list of (float or None, float)
        ``(angle, ds)`` of the failed steps from the current point (the angle
        of a step whose only fault was its turn, else None).
    """

    def __init__(self, corrector: Corrector, options, lam_range: tuple[float, float]):
        self.corrector = corrector
        self.opt = options
        self.lo, self.hi = lam_range
        self.turns: list = []

    def settle(self, cand: Candidate, ds_try: float) -> None:
        """After a successful step of ``ds_try``: healthy again (or past the corner), forget the failures."""
        if not self.turns or cand.kink is not None or ds_try >= self.turns[0][1] / self.opt.corner_ratio:
            self.turns.clear()

    def corner(self, failed: StepFailed, ds: float, x: np.ndarray, t: np.ndarray) -> Candidate | None:
        """A step across a corner of the branch after the step ``ds`` from ``x`` along ``t`` failed, or None.

        Two signs of a corner once the step has shrunk ``corner_ratio``
        times since the first failure near the current point (failures are
        forgotten once a step of at least that scale succeeds again): the turn of a
        converged step does not shrink with it, or the bordered corrector,
        whose Newton iterates straddle the corner, fails; then a step at
        fixed parameter (``lam`` advanced by ``ds``, in scaled units, in the
        tangent's direction) is tried, as across a corner the branch is
        locally a graph over ``lam`` unless the corner is a fold; then one
        at a fixed value of the unknown dominating the tangent (a corner
        that is also a fold). A turned candidate at a step within
        ``corner_ratio`` of ``ds_min`` is a corner as well.
        """
        opt = self.opt
        angle = failed.turn[0] if failed.turn is not None else None
        if not self.turns:
            self.turns.append((angle, ds))
            return None
        first_angle, first_ds = self.turns[0]
        self.turns.append((angle, ds))
        if first_ds < opt.corner_ratio * ds:
            return None
        if angle is not None and any(a is not None and angle >= PERSISTENT_TURN * a for a, d in self.turns[:-1]
                                     if d >= opt.corner_ratio * ds):
            cand = orient_along_secant(failed.turn[2], x)
            cand.kink = (angle, ds, first_angle or angle, first_ds)
            return cand
        cand = self._across_fixed_parameter(ds, x, t)
        if cand is None:
            cand = self._across_fixed_component(ds, x, t)
        if cand is None:
            if angle is not None and ds <= opt.corner_ratio * opt.ds_min:
                # a turn beyond max_angle_deg over a step this short would need a radius of
                # curvature below the smallest step: the step control cannot resolve it, so
                # it is a corner (the candidate lies within ds of the current point)
                cand = orient_along_secant(failed.turn[2], x)
                cand.kink = (angle, ds, first_angle or angle, first_ds)
            return cand
        cand = orient_along_secant(cand, x)
        turn = math.degrees(math.acos(float(np.clip(t @ cand.tangent, -1.0, 1.0))))
        if turn > opt.max_angle_deg:
            cand.kink = (turn, ds, first_angle or turn, first_ds)
        return cand

    def _across_fixed_parameter(self, ds: float, x: np.ndarray, t: np.ndarray) -> Candidate | None:
        """A step at fixed ``lam`` advanced by ``ds`` (scaled), or None."""
        sl, t_lam = self.corrector.sp.sl, t[-1]
        if abs(t_lam) < VERTICAL_TANGENT:
            return None  # a vertical tangent: not a graph over lam
        guess = x.copy()  # the unknowns as they are: the slope beyond the corner is unknown
        guess[-1] += math.copysign(ds, t_lam)
        try:
            cand = self.corrector.land(x, t, float(guess[-1] * sl), ds / abs(t_lam), guess, landed=False, across=True)
        except StepFailed as exc:
            if exc.turn is None:
                return None
            cand = exc.turn[2]
        if not (self.lo <= cand.lam <= self.hi):
            return None
        return cand

    def _across_fixed_component(self, ds: float, x: np.ndarray, t: np.ndarray) -> Candidate | None:
        """A step with the unknown of the largest tangent component advanced by ``ds``, or None.

        At a corner that is also a fold of the discretised problem (near a
        fold the tangent is so sensitive to the Jacobian that one AFT sample
        entering the contact can turn the branch back), there is no
        solution beyond the corner at fixed ``lam``; the branch is still a
        graph over the unknown that dominates the tangent.
        """
        i = int(np.argmax(np.abs(t[:-1])))
        ti = float(t[i])
        if abs(ti) < DOMINANT_COMPONENT:
            return None
        normal = np.zeros(x.size)
        normal[i] = 1.0
        offset = math.copysign(ds, ti)
        guess = x.copy()
        guess[i] += offset
        try:
            res = self.corrector.bordered_solve(guess, x, normal, offset)
            if not res.converged:
                return None
            cand = self.corrector.check(x, t, res.x, guess, ds / abs(ti), res.lu, res.rcond, res.iterations,
                                        across=True)
        except StepFailed as exc:
            if exc.turn is None:
                return None
            cand = exc.turn[2]
        except NUMERICAL_ERRORS:
            return None
        if not (self.lo <= cand.lam <= self.hi):
            return None
        return cand


def kink_point(cand: Candidate, branch: Branch) -> SpecialPoint:
    """The ``kink`` special point of a corner candidate just stored as the branch's last point."""
    angle, ds, first_angle, first_ds = cand.kink
    i = len(branch) - 1
    lam_a, lam_b = float(branch.parameter[i - 1]), float(branch.parameter[i])
    return SpecialPoint(SpecialKind.KINK, lam_b, cand.u.copy(), (lam_a, lam_b), i - 1,
                        float(branch.arclength[i]), located=True, event="corner",
                        message=(f"the tangent jumps by {angle:.1f} deg over a step of {ds:.1e} "
                                 f"({first_angle:.1f} deg over {first_ds:.1e}): a corner of the branch, "
                                 "where the problem is not smooth (a contact opening or closing: grazing)"),
                        data={"angle_deg": angle, "ds": ds}, tangent=cand.tangent.copy())
