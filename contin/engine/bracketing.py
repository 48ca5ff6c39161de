"""Narrowing a bracket of pseudo-arclength around a change: the engine's root finder for special points.

:func:`narrow` takes the points solved on the arc between two stored points
(``point_at(sigma)``, supplied by the engine) and narrows ``[s_lo, s_hi]``
until the change is located (:mod:`contin.engine.events` states the
tolerances). Which side of the change a point lies on is given by the caller
(a sign, a count); a continuous test, where there is one, gives the next
point by the Illinois variant of regula falsi, kept near the bracket's
midpoint by the projection step of ITP, or, for a test with a corner at the
change, by a one-sided secant. It knows nothing of events or problems.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

__all__ = ["JUMP", "KINK_FLOOR", "Location", "narrow"]


@dataclasses.dataclass(eq=False)
class Location:
    """Result of locating one change of one test component.

    Attributes
    ----------
    sigma : float
        Pseudo-arclength from the earlier stored point.
    point : PointInfo
        The located (or best) point; a converged solution.
    value : float
        Test value there.
    located : bool
    iterations : int
        Number of points solved during the location.
    message : str
    bracket : tuple of float
        Final ``(lam_lo, lam_hi)``.
    """

    sigma: float
    point: Any  # contin.engine.events.PointInfo
    value: float
    located: bool
    iterations: int
    message: str
    bracket: tuple


_EPS = np.finfo(float).eps


class _Budget:
    """The projection step of ITP (Oliveira & Takahashi, ACM Trans. Math. Softw. 47 (2021) 5): how far from
    the bracket's midpoint the next point may lie.

    Regula falsi (Illinois) on a test that is only piecewise smooth (the
    multipliers of a contact orbit, kinked where a contact changes) or
    steep at one end and flat at the other creeps from one end and can use
    up its iterations without closing the bracket. Kept within the radius
    ``eps 2^(n_max - j) - width / 2`` of the midpoint at iteration ``j``,
    the bracket is at most ``2 eps`` wide after ``n_max`` iterations,
    whatever the test. ``n_max`` is the most the iterations allowed leave,
    so the radius binds only where the iterations left would not otherwise
    suffice for bisection: a location that converges without it is
    unchanged, one that would not is finished by (nearly) bisecting.

    Parameters
    ----------
    s_lo, s_hi : float
        The initial bracket.
    eps : float
        The half width aimed at.
    max_iter : int
        The iterations allowed.
    """

    def __init__(self, s_lo: float, s_hi: float, eps: float, max_iter: int):
        width = s_hi - s_lo
        self.eps = eps
        n_half = math.ceil(math.log2(width / (2 * eps))) if width > 2 * eps else 0
        self.n_max = max(n_half + 1, max_iter - 1)  # one iteration kept for the far end's side

    def project(self, j: int, s: float, s_lo: float, s_hi: float) -> float:
        """``s`` moved towards the midpoint of ``(s_lo, s_hi)`` as far as iteration ``j`` requires."""
        mid = 0.5 * (s_lo + s_hi)
        radius = max(0.0, self.eps * 2.0 ** (self.n_max - j) - 0.5 * (s_hi - s_lo))
        return s if abs(s - mid) <= radius else mid + math.copysign(radius, s - mid)


#: A plain continuous test (``value_decides``) jumps at the change when its difference quotient across the
#: bracket has grown this many times over the one across the whole step (a smooth zero keeps it about the same).
JUMP = 64
#: At a jump the parameter is located once the steepest slope between solved points (at least ``h / JUMP`` apart),
#: times this margin, moves it by at most the tolerance across the bracket.
JUMP_MARGIN = 2.0

#: with ``kink``, a test value of the wrong sign but within this fraction of the bracket's values counts as
#: lying on its side's side of zero (:func:`narrow`)
KINK_FLOOR = 1e-6


def _one_sided(points, s_lo: float, s_hi: float, s_last: float, reach: float) -> float | None:
    """The next point by the secant through the two latest ``(s, value)`` of one side (``points``): its zero,
    moved towards the bracket's end farther from it by a hundredth of its distance from the latest point
    ``s_last``, and at least by ``reach``. Where the side is straight the ends come next to the zero in turn, a
    hundredfold closer each time; where the secant's side flattens towards the change (a dip past a grazing),
    its points crowd at the zero and ``reach`` brings the far end in. None without a secant."""
    if len(points) < 2:
        return None
    (s0, v0), (s1, v1) = points[-2], points[-1]
    if not (math.isfinite(v0) and math.isfinite(v1)) or v1 == v0 or s1 == s0:
        return None
    t = s1 - v1 / ((v1 - v0) / (s1 - s0))  # the arithmetic the measurements in docs/benchmarks.md ran
    far = s_lo if abs(t - s_lo) > abs(s_hi - t) else s_hi
    return t + math.copysign(max(0.01 * abs(t - s_last), reach), far - t)


def narrow(point_at, s_lo, s_hi, p_lo, p_hi, v_lo, v_hi, h, *, side, value=None, tol=1e-10, max_iter=60,
           vtol=1e-15, failed_beyond=False, value_decides=False, kink=False) -> Location:
    """Narrow a bracket ``[s_lo, s_hi]`` of pseudo-arclength around a change.

    Which side of the change a solved point lies on is decided by
    ``side(info, v)`` (True: the side of ``p_lo``). Where a continuous test
    ``value(info)`` is available and its values at the two ends of the
    current bracket have opposite signs, the next point is the Illinois
    variant of regula falsi on it (superlinear); otherwise the bracket is
    bisected. A continuous test may be undefined (NaN) or inconsistent with
    ``side`` at some points: the iteration then falls back to bisection
    there, so a count decides the bracket and the continuous test only
    speeds it up (how the stability and grazing events locate their points).

    Parameters
    ----------
    point_at : callable
        As for :func:`locate`.
    s_lo, s_hi : float
        The bracket, ``s_lo < s_hi``.
    p_lo, p_hi : PointInfo
        The points at its ends.
    v_lo, v_hi : float
        The continuous test at the ends (NaN if none).
    h : float
        Length of the whole step (for the tolerance on the arclength).
    side : callable
        ``side(info, v) -> bool``.
    value : callable, optional
        ``value(info) -> float`` (NaN where undefined).
    tol, max_iter
        As for :func:`locate`.
    vtol : float
        The change is located at a point where ``|value| <= vtol`` times the
        larger of its values at the two ends.
    failed_beyond : bool
        Count a point that cannot be solved as lying beyond the change (the
        far side of a grazing, where the residual is not smooth and Newton
        may fail), instead of ending the location there.
    value_decides : bool
        ``side`` is the sign of ``value`` (a plain continuous test), so a
        zero of ``value`` is the change. Where the test jumps at the change
        instead (its difference quotient across the bracket :data:`JUMP`
        times the one across the step: a fold at a corner of a non-smooth
        branch, where the tangent flips), the change is located once the
        steepest slope of the parameter between the solved points cannot move
        it by more than ``tol`` across the bracket, however wide in arclength.
    kink : bool
        The test may have a corner at the change (its slope differs on the
        two sides, as the turn of a switching function at a grazing): the
        next point is the zero of the secant of the two latest points on the
        side of the latest, moved towards the bracket's farther end
        (:func:`_one_sided`, at least a tenth of the half width the
        tolerance asks), where it falls inside the bracket; a secant across
        a corner (regula falsi) converges only linearly.

    Returns
    -------
    Location
        ``point`` is the end of the final bracket with the smaller ``|value|``
        when the continuous test is defined at both, else the end on the
        far side of the change (``p_hi``). ``value`` is the continuous test
        there (NaN without one).
    """
    w_lo, w_hi = v_lo, v_hi  # working values (Illinois halves a stale end)
    scale_v = max(abs(v_lo), abs(v_hi)) if math.isfinite(v_lo) and math.isfinite(v_hi) else math.nan
    # the sign the continuous test has on each side (none unless the ends have opposite signs)
    sign_lo = math.copysign(1.0, v_lo) if math.isfinite(scale_v) and (v_lo < 0) != (v_hi < 0) else math.nan
    last = 0
    stalls = 0
    iterations = 0
    message = ""
    located = False
    s_full = s_hi

    lam_rate = abs(p_hi.lam - p_lo.lam) / (s_hi - s_lo) if s_hi > s_lo else 0.0
    s_last = s_hi  # the latest point solved
    # the points solved on each side with their test values (kink)
    sides = {-1: [(s_lo, v_lo)], 1: [(s_hi, v_hi)]}
    lam_hi = p_hi.lam
    # (s, lam) of the solved points, and the test's difference quotient across the step (a jump: JUMP)
    solved = [(s_lo, p_lo.lam), (s_hi, p_hi.lam)]
    quotient = (abs(v_lo) + abs(v_hi)) / (s_hi - s_lo) if value_decides and math.isfinite(scale_v) else math.nan
    at_jump = False
    # the half width the tolerances ask (the parameter's part through the step's mean slope, with a
    # margin of two halvings for a slope steeper where the change is)
    eps = math.sqrt(tol) * h
    if lam_rate > 0:
        eps = min(eps, tol * max(1.0, abs(p_lo.lam), abs(p_hi.lam)) / lam_rate)
    budget = _Budget(s_lo, s_hi, 0.125 * max(eps, 64 * _EPS * max(1.0, s_full)), max_iter)

    def bracket_done():
        nonlocal at_jump
        width = s_hi - s_lo
        if width <= 64 * _EPS * max(1.0, s_full):
            return True
        # without a solved far end, the parameter's bracket is estimated from the step's mean slope
        dlam = abs(lam_hi - p_lo.lam) if lam_hi is not None else lam_rate * width
        lam_ref = max(1.0, abs(p_lo.lam), abs(p_hi.lam))
        if dlam > tol * lam_ref:
            return False
        if (math.isfinite(quotient) and math.isfinite(v_lo) and math.isfinite(v_hi)
                and abs(v_lo) + abs(v_hi) >= JUMP * width * quotient):
            # the test jumps at the change (a corner of a non-smooth branch, where a fold's tangent flips):
            # its values tell nothing of where the change lies in the bracket, but the parameter is known
            # once it cannot move by more than the tolerance across it, however wide the bracket
            # slopes between points at least h / JUMP apart: closer ones, down to the rounding of the
            # arclength, give the rounding (or Newton's tolerance) of lambda over a vanishing distance
            pts = sorted(solved)
            far = h / JUMP
            steepest = max((abs(l1 - l0) / (s1 - s0) for i, (s0, l0) in enumerate(pts) for s1, l1 in pts[i + 1:]
                            if s1 - s0 >= far), default=math.inf)
            at_jump = JUMP_MARGIN * steepest * width <= tol * lam_ref
            return at_jump
        return width <= math.sqrt(tol) * h

    while True:
        if bracket_done():
            located = True
            break
        if iterations >= max_iter:
            message = f"location did not converge in {max_iter} iterations"
            break
        s = 0.5 * (s_lo + s_hi)
        width = s_hi - s_lo
        interpolated = False
        one_sided = _one_sided(sides.get(last, []), s_lo, s_hi, s_last, 0.1 * eps) if kink and stalls < 3 else None
        if one_sided is not None and s_lo < one_sided < s_hi:
            s, interpolated = budget.project(iterations, one_sided, s_lo, s_hi), True
        elif (stalls < 3 and math.isfinite(w_lo) and math.isfinite(w_hi) and (w_lo < 0) != (w_hi < 0)
                and w_hi != w_lo):
            t = budget.project(iterations, (s_lo * w_hi - s_hi * w_lo) / (w_hi - w_lo), s_lo, s_hi)
            if s_lo < t < s_hi:
                s, interpolated = t, True
        iterations += 1
        s_last = s
        info, why = point_at(s)
        if info is None and failed_beyond and s > s_lo:
            s_hi, w_hi, stalls = s, math.nan, 0
            if last == 1 and math.isfinite(w_lo):
                w_lo *= 0.5
            last = 1
            lam_hi = None  # the bracket's far end has no solved point now
            continue
        if info is None:
            message = f"location failed: {why}"
            break
        solved.append((s, info.lam))
        try:
            v = value(info) if value is not None else math.nan
            lower = bool(side(info, v))
        except (ArithmeticError, ValueError) as exc:  # LinAlgError is a ValueError
            message = f"location failed: {type(exc).__name__}: {exc}"
            break
        # a zero of the test is the change itself only where the test decides the side, or on the
        # near side of a change whose far side cannot be solved; a hybrid narrows on
        if (math.isfinite(v) and math.isfinite(scale_v) and abs(v) <= vtol * scale_v
                and (lower if failed_beyond else value_decides)):
            s_lo = s_hi = s
            p_lo = p_hi = info
            v_lo = v_hi = v
            located = True
            break
        # the working value of this end: the test where its sign agrees with the side (an exact zero
        # counts with the side's sign), else none, so that the next point bisects
        expected = sign_lo if lower else -sign_lo
        w = math.nan
        if math.isfinite(v) and math.isfinite(expected):
            if v == 0.0:
                w = expected * 1e-15 * scale_v
            elif (v > 0) == (expected > 0):
                w = v
            elif kink and abs(v) <= KINK_FLOOR * scale_v:
                # a count that changes a hair after the test's zero (a switch seen once its arc is resolved)
                w = expected * abs(v)
        if not lower:
            lam_hi = info.lam
        if math.isfinite(w):
            sides[-1 if lower else 1].append((s, v))
        if lower:
            s_lo, p_lo, v_lo, w_lo = s, info, v, w
            if last == -1 and math.isfinite(w_hi):
                w_hi *= 0.5
            last = -1
        else:
            s_hi, p_hi, v_hi, w_hi = s, info, v, w
            if last == 1 and math.isfinite(w_lo):
                w_lo *= 0.5
            last = 1
        # interpolation that keeps failing to halve the bracket (a test flat on one side, such as the
        # modulus of multipliers sitting on the circle) gives way to a bisection
        stalls = stalls + 1 if interpolated and s_hi - s_lo > 0.5 * width else 0

    if failed_beyond and (lam_hi is None or (math.isfinite(v_lo) and (not math.isfinite(v_hi) or abs(v_lo) <= abs(v_hi)))):
        sigma, point, val = s_lo, p_lo, v_lo  # the near side: where the branch is smooth
    elif math.isfinite(v_lo) and math.isfinite(v_hi) and abs(v_lo) < abs(v_hi):
        sigma, point, val = s_lo, p_lo, v_lo
    else:
        sigma, point, val = s_hi, p_hi, v_hi
    if located:
        dlam = abs(lam_hi - p_lo.lam) if lam_hi is not None else lam_rate * (s_hi - s_lo)
        message = f"located in {iterations} iterations, |dlam| = {dlam:.1e}"
        if at_jump:
            message += (f"; the test jumps there (from {v_lo:.2g} to {v_hi:.2g} across {s_hi - s_lo:.1e} of "
                        "arclength: a corner of the branch)")
    return Location(sigma, point, val, located, iterations, message, (p_lo.lam, p_hi.lam))
