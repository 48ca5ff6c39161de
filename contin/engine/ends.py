"""How a branch ends by itself: on a range end (reached as asked, or after turning back) or on a loop.

- :func:`attempt`: a step that would leave the parameter range lands on its
  end exactly (Newton at the fixed end value);
- :func:`finish_at_range_end`: ``RANGE_END`` if the end is the one the branch
  set out towards (:func:`toward`), else ``TURNED_BACK`` with the interval it
  left uncovered (:func:`uncovered`);
- :func:`left_at_start`: a branch that leaves the range where it started, without covering any of it,
  though asked into it, has not reached a range end (the engine ends it as a shortfall);
- :func:`closed` and :func:`revisited`: a branch passing again through its
  start stops with ``CLOSED_LOOP`` instead of going round until
  ``max_points``; one passing again through an earlier point in the same
  direction stops too, with ``RETRACED`` (no smooth branch does: a step
  jumped back onto an earlier part of it), or ``CLOSED_LOOP`` where that
  point is one of the first :data:`NEAR_START` after the start (a loop closed
  a step late).

Points ``x`` and tangents ``t`` are scaled, of shape (m+1,).
"""

from __future__ import annotations

import math

import numpy as np

from contin.engine.branch import Branch, BranchBuilder, BranchStatus, SpecialKind, SpecialPoint
from contin.engine.corrector import Candidate, Corrector, StepFailed, format_parameter
from contin.engine.predictor import predict

__all__ = ["NEAR_START", "attempt", "closed", "finish_at_range_end", "left_at_start", "revisit_end", "revisited",
           "toward", "uncovered"]

#: A chord passing through an earlier point must be within this angle of it (and of the start tangent).
MAX_PASSING_ANGLE_DEG = 89.0
#: Stored points before a branch can revisit one (the start and the last few are never revisited).
MIN_REVISIT_POINTS = 6
#: Distance (relative to the chord) within which a chord passes through an earlier point, or the start.
REVISIT_DISTANCE = 0.1
START_DISTANCE = 0.25
#: The branch must have gone this many chord lengths away from its start before it can return to it.
WENT_AWAY = 2.0
#: Stored points before a branch can close on its start.
MIN_LOOP_POINTS = 4
#: A branch that passes again through one of its first points after the start closed its loop (the start
#: itself passed between two points without being seen); through a later one, it retraced itself.
NEAR_START = 2


def attempt(corrector: Corrector, pos, ds: float, lam_range: tuple[float, float]) -> Candidate | None:
    """One step of ``ds`` from ``pos`` (the engine's :class:`~contin.engine.state.Position`), landing on the end
    of ``lam_range`` it would cross; None if ``pos`` is on that end already and the branch leaves the range."""
    lo, hi = lam_range
    sl = corrector.sp.sl
    x, t = pos.x, pos.t
    chord = (pos.info.Ju, pos.info.Jlam)  # a lazy Jacobian's first chord steps (corrector.bordered_solve)
    t_lam = t[-1]
    lam_pred = (x[-1] + ds * t_lam) * sl
    if lam_pred > hi or lam_pred < lo:
        end = hi if lam_pred > hi else lo
        if pos.lam == end:
            return None
        # shorten the prediction to reach the end exactly, then land on it
        ds_cut = (end / sl - x[-1]) / t_lam
        guess = predict(x, t, ds_cut)
        guess[-1] = end / sl
        try:
            return corrector.land(x, t, end, ds_cut, guess, chord=chord)
        except StepFailed as failed_landing:
            # the branch may turn back before the end (a fold close to it)
            try:
                cand = corrector.step(x, t, ds, chord=chord)
            except StepFailed:
                raise failed_landing from None
            if lo <= cand.lam <= hi:
                return cand
            raise
    cand = corrector.step(x, t, ds, chord=chord)
    if cand.lam > hi or cand.lam < lo:
        end = hi if cand.lam > hi else lo
        theta = (end - pos.lam) / (cand.lam - pos.lam)
        guess = x + theta * (cand.x - x)
        guess[-1] = end / sl
        return corrector.land(x, t, end, ds, guess, chord=(cand.Ju, cand.Jlam))
    return cand


def toward(t_start: np.ndarray | None, direction: int, lam_range: tuple[float, float]) -> float:
    """The end of the range the branch set out towards (its start tangent's parameter direction)."""
    lo, hi = lam_range
    up = direction > 0 if t_start is None or t_start[-1] == 0 else t_start[-1] > 0
    return hi if up else lo


def uncovered(branch: Branch, end: float, lam_range: tuple[float, float],
              lam0: float) -> tuple[float, tuple[float, float]]:
    """The furthest parameter reached towards ``end`` and the interval beyond it, left uncovered.

    Also stored as ``branch.info["uncovered"]``; ``lam0``: the start
    parameter (for a branch without points).
    """
    hi = lam_range[1]
    lams = [float(v) for v in branch.parameter] + [sp.parameter for sp in branch.special_points
                                                   if sp.kind is SpecialKind.FOLD]
    lams = lams or [lam0]
    furthest = max(lams) if end == hi else min(lams)
    gap = (furthest, end) if end == hi else (end, furthest)
    branch.info["uncovered"] = gap
    return furthest, gap


def left_at_start(branch: Branch, lam_range: tuple[float, float], lam0: float, direction: int) -> bool:
    """Does ``branch`` end on the range end it started on, every point at ``lam0``, though asked into the range?

    ``direction`` (+1 or -1): the sign of the parameter's change asked at
    the start. Such a branch covered nothing: its start tangent pointed out
    of the range against the direction asked (a parameter component too
    small to orient, at a fold or a branch point on the range end), so
    "reached the end of the range" would be false.
    """
    lo, hi = lam_range
    into = (direction > 0 and lam0 == lo < hi) or (direction < 0 and lam0 == hi > lo)
    return into and len(branch) > 0 and bool(np.all(branch.parameter == lam0))


def finish_at_range_end(builder: BranchBuilder, index: int, end: float, lam_range: tuple[float, float], lam0: float,
                        name: str) -> None:
    """End the branch on a range end at its stored point ``index``; ``end``: the one it set out towards."""
    branch = builder.branch
    lam = float(branch.parameter[index])
    builder.add_special(
        SpecialPoint(SpecialKind.END, lam, branch.unknowns[index].copy(), (lam, lam), index,
                     float(branch.arclength[index]), located=True,
                     message="end of the parameter range", event="end",
                     tangent=branch.tangents[index].copy())
    )
    if lam == end:
        builder.finish(BranchStatus.RANGE_END,
                       f"reached the end of the parameter range at {format_parameter(name, lam)}")
        return
    furthest, gap = uncovered(branch, end, lam_range, lam0)
    builder.finish(
        BranchStatus.TURNED_BACK,
        f"turned back: it set out towards {format_parameter(name, end)} but reached the other end of the range at "
        f"{format_parameter(name, lam)}; its furthest point is at {format_parameter(name, furthest)}, so "
        f"[{gap[0]:.10g}, {gap[1]:.10g}] is not covered by this branch")


def revisited(branch: Branch, a: np.ndarray, x1: np.ndarray, su: np.ndarray, sl: float,
              max_angle_deg: float) -> int | None:
    """Index of an earlier stored point (not the start, not the last few) that the
    last chord, from ``a`` to ``x1``, passes through in the same direction, or None.

    Without it, a branch that jumped back onto an earlier part of itself
    would go round the same loop until ``max_points``. The stored points are
    compared in the scales ``su`` (m,), ``sl``.
    """
    b = branch
    n = len(b) - 1  # the new point is stored
    if n < MIN_REVISIT_POINTS:
        return None
    seg = x1 - a
    L = float(np.linalg.norm(seg))
    if L == 0.0:
        return None
    m = su.size
    X = np.empty((n - 3, m + 1))  # points 1 .. n-3 in the current scales
    X[:, :m] = b.unknowns[1:n - 2] / su
    X[:, m] = b.parameter[1:n - 2] / sl
    p = (X - a) @ seg / (L * L)
    near = (p >= 0.0) & (p <= 1.0)
    if not near.any():
        return None
    dist = np.linalg.norm(a + np.outer(p, seg) - X, axis=1)
    cand_idx = np.flatnonzero(near & (dist <= REVISIT_DISTANCE * L))
    cos_min = math.cos(math.radians(min(2 * max_angle_deg, MAX_PASSING_ANGLE_DEG)))
    for j in cand_idx:
        k = int(j) + 1
        d = np.empty(m + 1)
        d[:m] = (b.unknowns[k + 1] - b.unknowns[k]) / su
        d[m] = (b.parameter[k + 1] - b.parameter[k]) / sl
        nd = float(np.linalg.norm(d))
        if nd > 0 and float(d @ seg) >= cos_min * nd * L:
            return k
    return None


def revisit_end(branch: Branch, k: int, fmt) -> tuple[BranchStatus, str]:
    """How a branch that passed again through its point ``k`` (:func:`revisited`) ends: ``(status, message)``;
    ``fmt(lam)`` names a parameter value."""
    lam_k = fmt(branch.parameter[k])
    if k <= NEAR_START:
        return BranchStatus.CLOSED_LOOP, (f"the branch returned to its start {fmt(branch.parameter[0])} (it passed "
                                          f"again through its point {k} at {lam_k})")
    return BranchStatus.RETRACED, (
        f"the branch passed again through its point {k} at {lam_k}, in the same direction, at "
        f"{fmt(branch.parameter[-1])}: it retraces itself, which no smooth branch does away from its start (a step "
        "jumped back onto an earlier part of it, or onto another branch through it: lower ds_max)")


def closed(pos, x1: np.ndarray, n_points: int, max_angle_deg: float) -> bool:
    """Did the last step, from ``pos.prev_x`` to ``x1``, pass the start point (after having gone away)?

    Updates ``pos.max_dist``, the largest distance from the start so far.
    """
    x0, a = pos.x_start, pos.prev_x
    seg = x1 - a
    L = float(np.linalg.norm(seg))
    went_away = pos.max_dist > WENT_AWAY * L
    pos.max_dist = max(pos.max_dist, float(np.linalg.norm(x1 - x0)))
    if n_points < MIN_LOOP_POINTS or not went_away or L == 0:
        return False
    p = float((x0 - a) @ seg) / (L * L)
    if not (0.0 <= p <= 1.0):
        return False
    dist = float(np.linalg.norm(a + p * seg - x0))
    # same direction as the start tangent (not a crossing of a figure eight)
    cos_min = math.cos(math.radians(min(2 * max_angle_deg, MAX_PASSING_ANGLE_DEG)))
    return dist <= START_DISTANCE * L and float(pos.t_start @ seg) >= cos_min * L
