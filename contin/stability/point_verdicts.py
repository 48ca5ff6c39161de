"""The stability verdicts the events read off a branch's points, and what stands in for a point without one.

A point's verdict is its monitored data (or, where the data lack it, the
monitor's analysis). A point without one (``evaluated`` False) gives no
information: :class:`HeldVerdict` lets the last evaluated stored point before it
stand in, :func:`evaluated_only` makes the location stop at a solved point
without one, and :func:`mark_before` says where a change lies that could not
be located past such a point.
"""

from __future__ import annotations

import numpy as np

from contin.engine.events import PointInfo
from contin.engine.newton import NUMERICAL_ERRORS
from contin.stability.monitor import StabilityMonitor

__all__ = ["HeldVerdict", "branch_turns", "counts_of", "evaluated_only", "mark_before", "multipliers_of"]

_VERDICT_KEYS = ("n_plus", "n_minus", "n_complex", "n_unstable", "multipliers")


def counts_of(point: PointInfo, monitor: StabilityMonitor) -> dict | None:
    """The stability data of ``point`` (its monitored data, else the monitor's verdict), or None without a verdict.

    A point without one (``evaluated`` False, or the monitor failing there)
    gives no information: None, never its placeholders.
    """
    d = point.data
    if not all(k in d for k in _VERDICT_KEYS):
        try:
            d = monitor.analyze(point.u, point.lam).monitor_data()
        except NUMERICAL_ERRORS:
            return None
    return d if bool(d.get("evaluated", True)) else None


def multipliers_of(point: PointInfo, monitor: StabilityMonitor) -> np.ndarray | None:
    """The multipliers of ``point``, or None without a verdict (see :func:`counts_of`)."""
    d = counts_of(point, monitor)
    return None if d is None else np.asarray(d["multipliers"], dtype=complex)


class HeldVerdict:
    """The verdict of the last evaluated stored point, for the stored points without one.

    The engine tests each stored point once, in order along the branch (a new
    branch from its start, at arclength 0). A point without a verdict takes
    that of the last evaluated point before it: no change is detected into
    or out of it, and a change across it is taken between the evaluated
    points around it (located between it and the next one, where the
    engine solves).
    """

    def __init__(self):
        self.latest = None  # the stored point tested last
        self.current = None  # _standing() of the last evaluated stored point up to it
        self.before = None  # the same up to the stored point before it

    def see(self, point: PointInfo, own: dict | None) -> None:
        """Record a stored point as the engine tests it (``own``: its data, None without a verdict)."""
        if point is self.latest:
            return
        if point.s == 0.0:
            self.current = None  # the start of a branch
        self.before = self.current
        if own is not None:
            self.current = _standing(point, own)
        self.latest = point

    def at(self, point: PointInfo, own: dict | None):
        """:func:`_standing` for ``point``: its own where it has a verdict, else the held one (or None)."""
        if own is not None:
            return _standing(point, own)
        return self.current if point is self.latest else self.before


def _standing(point: PointInfo, own: dict) -> tuple:
    """``(s, data, lam, dlam)`` of an evaluated point: arclength, verdict, parameter, parameter component
    of the tangent (what the events read of the point standing for one without a verdict)."""
    return float(point.s), own, float(point.lam), float(point.tangent[-1])


def mark_before(loc, a: PointInfo, held, monitor):
    """Say where a change lies that the location could not put beyond a point without a verdict.

    Where ``a`` has no verdict, the change lies between the evaluated point
    standing for it (``held``) and the far end of the final bracket.
    Bisection onto ``a`` itself (every solved point on the far side) puts it
    between ``held`` and ``a``, or just after ``a``: not resolved where
    nothing could be evaluated, so it is not located either.
    """
    if held is None or counts_of(a, monitor) is not None:
        return loc
    if loc.located and loc.bracket[0] == a.lam:
        loc.located = False
    if not loc.located:
        loc.message = (f"the change lies between {held[2]:.10g} and {loc.bracket[1]:.10g} (no stability verdict at "
                       f"{a.lam:.10g}); {loc.message}")
    return loc


def evaluated_only(point_at, monitor):
    """``point_at`` of the engine, with a solved point without a stability verdict counted as a failed solve.

    Such a point cannot tell on which side of a change it lies: the location
    ends there (unlocated, with the reason) rather than taking it for one side.
    """
    def wrapped(sigma):
        info, why = point_at(sigma)
        if info is None:
            return info, why
        try:
            own = counts_of(info, monitor)
        except NUMERICAL_ERRORS as exc:
            return None, f"no stability verdict ({type(exc).__name__}: {exc})"
        if own is None:
            reasons = getattr(monitor, "unevaluated", None)
            reason = f": {reasons[-1][1]}" if reasons else ""
            return None, f"no stability verdict at {info.lam:.10g}{reason}"
        return info, why

    return wrapped


def branch_turns(fa: float, fb: float) -> bool:
    """Whether the parameter components ``fa``, ``fb`` of two tangents say that the branch turned between."""
    return bool((fa < 0 <= fb) or (fa > 0 >= fb))
