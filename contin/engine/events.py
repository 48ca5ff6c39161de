"""Generic test-function events and their location along a branch.

An :class:`Event` maps a point of the branch (:class:`PointInfo`) to one or
several test values. A change between two consecutive stored points (a sign
change for a continuous test, any change for an integer-valued one) triggers
the location of the special point on the arc between them.

Location works on the arc parametrised by the pseudo-arclength ``sigma``
measured from the earlier point ``a`` along its unit tangent ``t_a``:
``point_at(sigma)`` must return the solution on the hyperplane
``t_a . (x - x_a) = sigma`` (the engine supplies it; ``sigma = h`` gives the
later point ``b``). The bracket ``[0, h]`` is narrowed by the Illinois
variant of regula falsi for continuous tests (its points kept close enough
to the bracket's midpoint that the iterations allowed always suffice: the
projection step of ITP), or by bisection for integer-valued ones, until

    |lam_hi - lam_lo| <= tol * max(1, |lam|)  and  sigma_hi - sigma_lo <= sqrt(tol) * h,

or the bracket is at rounding level, or the test is exactly zero. The second
condition matters where ``lam`` is stationary (folds): there ``|dlam|`` is
quadratically small in the arclength and alone would leave ``u`` poorly
located.
"""

from __future__ import annotations

import abc
import dataclasses
import math
from typing import Any, Callable

import numpy as np

from contin.engine.bracketing import Location, narrow
from contin.engine.branch import SpecialKind
from contin.engine.newton import LUFactor

__all__ = [
    "BranchPointEvent",
    "Event",
    "FoldEvent",
    "FunctionEvent",
    "Location",
    "PointInfo",
    "changed_components",
    "evaluate_test",
    "locate",
    "narrow",
    "predicted_zero",
]


@dataclasses.dataclass(eq=False)
class PointInfo:
    """Everything known about one converged point, passed to events.

    Attributes
    ----------
    u : ndarray, shape (m,)
    lam : float
    tangent : ndarray, shape (m+1,)
        Unit tangent in scaled coordinates ``(u / su, lam / sl)``.
    Ju : ndarray, shape (m, m)
        ``dR/du`` (unscaled).
    Jlam : ndarray, shape (m,)
        ``dR/dlam`` (unscaled).
    det_sign : int
        Sign of the determinant of the bordered Jacobian
        ``[[Ju su, Jlam sl], [t_ref^T]]`` (``t_ref`` is a reference tangent
        with ``t_ref . tangent > 0``, so the sign equals that of
        ``det [[Ju su, Jlam sl], [tangent^T]]``).
    data : dict
        Monitored values at this point.
    s : float
        Arclength.
    lu : LUFactor or None
        Factorisation of that bordered matrix (row-equilibrated).
    rcond : float
        Its reciprocal condition estimate.
    """

    u: np.ndarray
    lam: float
    tangent: np.ndarray
    Ju: np.ndarray
    Jlam: np.ndarray
    det_sign: int
    data: dict = dataclasses.field(default_factory=dict)
    s: float = float("nan")
    lu: LUFactor | None = None
    rcond: float = float("nan")


class Event(abc.ABC):
    """A test function whose changes along the branch mark special points.

    Subclasses implement :meth:`test`; they may override :meth:`triggered`
    (when does a change count) and :meth:`describe` (data stored in the
    located :class:`~contin.engine.branch.SpecialPoint`).

    Attributes
    ----------
    kind : SpecialKind
        Kind given to the located special points.
    name : str
    integer_valued : bool
        True for piecewise-constant tests (counts, signs): any change
        triggers and location is by bisection.
    """

    kind: SpecialKind = SpecialKind.USER
    name: str = "event"
    integer_valued: bool = False
    #: the branch may be unable to pass this event's zero (a boundary of the problem's smooth
    #: domain): when steps fail short of where :meth:`distance` predicts it, the engine locates
    #: it from the near side and ends the branch there if no step passes it
    barrier: bool = False
    #: the test reads the point's linearisation (its tangent, ``Ju``, ``Jlam``, or multipliers the problem
    #: computes from it). False: while the event is located, the points on the arc are solved without one
    #: when the problem's Jacobian is lazy (:mod:`contin.engine.location`); the located point gets its own
    needs_linearisation: bool = True

    @abc.abstractmethod
    def test(self, point: PointInfo) -> float | np.ndarray:
        """Test value(s) at ``point``: a float or a 1-D array."""

    def triggered(self, ga: np.ndarray, gb: np.ndarray, a: PointInfo, b: PointInfo) -> np.ndarray:
        """Boolean mask, shape like ``ga``: components that changed from ``a`` to ``b``.

        Default: any change for integer-valued tests; for continuous tests a
        sign change, where an exact zero at ``b`` counts as reached (so a
        zero is reported once, between the previous point and it).
        """
        if self.integer_valued:
            return ga != gb
        return ((ga < 0) & (gb >= 0)) | ((ga > 0) & (gb <= 0))

    def describe(self, point: PointInfo) -> dict[str, Any]:
        """Free data stored with a located special point."""
        return {}

    def distance(self, point: PointInfo) -> float:
        """A continuous signed distance to this event, zero where it triggers (NaN: none).

        Used to locate a :attr:`barrier` from one side, and by the default
        :meth:`step_limit`. The default has none.
        """
        return math.nan

    def step_limit(self, a: PointInfo, b: PointInfo, h: float) -> float:
        """The longest next step (from ``b``) this event allows (``inf``: no limit).

        The engine takes no longer step, so that two changes close together
        are not taken in one step (where a count would change and change back
        unseen). The default extrapolates :meth:`distance` linearly from
        ``a`` and ``b`` (``h`` apart) and allows ``OVERSHOOT`` times the
        arclength to its zero: the change then falls inside the step.
        """
        return OVERSHOOT * predicted_zero(self.distance(a), self.distance(b), h)

    def locate(self, component, point_at, h, a, b, ga, gb, *, tol=1e-10, max_iter=60) -> list["Location"]:
        """Locate the change of test ``component`` between ``a`` and ``b``.

        The default is the module-level :func:`locate` (Illinois or
        bisection); override for a dedicated method. Same arguments.
        """
        return locate(self, component, point_at, h, a, b, ga, gb, tol=tol, max_iter=max_iter)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, kind={self.kind.value})"


class FoldEvent(Event):
    """Limit point in the parameter: the parameter component of the tangent."""

    kind = SpecialKind.FOLD
    name = "fold"

    def test(self, point: PointInfo) -> float:
        return float(point.tangent[-1])


class BranchPointEvent(Event):
    """Simple branch point: sign of ``det [[Ju, Jlam], [t^T]]``.

    The sign is read from the LU factors (no overflow). It is flagged when it
    changes while the fold test (the parameter component of the tangent)
    keeps its sign; location is by bisection.
    """

    kind = SpecialKind.BP
    name = "branch point"
    integer_valued = True

    def test(self, point: PointInfo) -> float:
        return float(point.det_sign)

    def triggered(self, ga, gb, a, b):
        fold_a, fold_b = a.tangent[-1], b.tangent[-1]
        fold_changed = (fold_a < 0 <= fold_b) or (fold_a > 0 >= fold_b)
        return (ga != gb) & (not fold_changed)


class FunctionEvent(Event):
    """An event from a plain function ``fun(point_info) -> float or ndarray``.

    ``distance`` (optional) is a continuous signed distance to the event
    (see :meth:`Event.distance`): it gives the engine's step control a
    prediction and, with ``barrier=True``, makes the event a barrier.

    Examples
    --------
    >>> ev = FunctionEvent(lambda p: p.lam - 0.3, name="lam=0.3")
    """

    def __init__(
        self,
        fun: Callable[[PointInfo], float | np.ndarray],
        *,
        name: str = "user",
        kind: SpecialKind | str = SpecialKind.USER,
        integer_valued: bool = False,
        describe: Callable[[PointInfo], dict] | None = None,
        distance: Callable[[PointInfo], float] | None = None,
        barrier: bool = False,
    ):
        self.fun = fun
        self.name = name
        self.kind = SpecialKind(kind)
        self.integer_valued = bool(integer_valued)
        self._describe = describe
        self._distance = distance
        self.barrier = bool(barrier)
        if self.barrier and distance is None:
            raise ValueError("FunctionEvent: a barrier needs a distance function")

    def test(self, point: PointInfo):
        return self.fun(point)

    def distance(self, point: PointInfo) -> float:
        return math.nan if self._distance is None else float(self._distance(point))

    def describe(self, point: PointInfo) -> dict:
        return {} if self._describe is None else dict(self._describe(point))


#: A step limited by a predicted change goes this far past it, so that the change falls inside it.
OVERSHOOT = 1.25


def predicted_zero(ga: float, gb: float, h: float) -> float:
    """Arclength beyond ``b`` where the line through ``(0, ga)`` and ``(h, gb)`` reaches zero.

    ``inf`` when the values are not finite or do not approach zero.
    """
    if not (math.isfinite(ga) and math.isfinite(gb) and h > 0) or gb == 0.0:
        return math.inf
    rate = (gb - ga) / h
    if rate == 0.0 or (gb < 0) == (rate < 0):
        return math.inf
    return -gb / rate


def evaluate_test(event: Event, point: PointInfo) -> np.ndarray:
    """Test values of ``event`` at ``point`` as a 1-D float array."""
    return np.atleast_1d(np.asarray(event.test(point), dtype=float)).reshape(-1)


def changed_components(event: Event, ga: np.ndarray, gb: np.ndarray, a: PointInfo, b: PointInfo) -> list[int]:
    """Indices of the test components that changed between ``a`` and ``b``.

    Components that are non-finite at either end, or tests whose length
    changed, are ignored.
    """
    if ga.shape != gb.shape:
        return []
    finite = np.isfinite(ga) & np.isfinite(gb)
    mask = np.asarray(event.triggered(ga, gb, a, b), dtype=bool).reshape(-1) & finite
    return [int(i) for i in np.flatnonzero(mask)]


def locate(
    event: Event,
    component: int,
    point_at: Callable[[float], tuple[PointInfo | None, str]],
    h: float,
    a: PointInfo,
    b: PointInfo,
    ga: float,
    gb: float,
    *,
    tol: float = 1e-10,
    max_iter: int = 60,
) -> list[Location]:
    """Locate the change(s) of one test component between ``a`` and ``b``.

    Parameters
    ----------
    event : Event
    component : int
        Index into the event's test values.
    point_at : callable
        ``point_at(sigma) -> (PointInfo or None, message)``: the converged
        point on the hyperplane at pseudo-arclength ``sigma`` in ``(0, h)``
        from ``a``; ``None`` with a reason if the solve failed.
    h : float
        Pseudo-arclength of ``b`` from ``a`` (> 0).
    a, b : PointInfo
        The bracketing stored points.
    ga, gb : float
        Test values of this component at ``a`` and ``b``.
    tol : float
        Relative tolerance on the parameter.
    max_iter : int
        Maximum number of solved points per change.

    Returns
    -------
    list of Location
        One entry for a continuous test; for an integer-valued test, one per
        successive change (e.g. a count jumping by 2 in one step may give two
        located points).
    """
    ga, gb = float(ga), float(gb)
    if not event.integer_valued:
        if gb == 0.0:
            return [Location(h, b, 0.0, True, 0, "test exactly zero at the stored point", (b.lam, b.lam))]

        def value(info):
            g = evaluate_test(event, info)
            return float(g[component]) if component < g.size else math.nan

        def side(info, v):
            if not math.isfinite(v):
                raise ArithmeticError("non-finite test value")
            return (v < 0) == (ga < 0)

        return [narrow(point_at, 0.0, h, a, b, ga, gb, h, side=side, value=value, tol=tol, max_iter=max_iter,
                       value_decides=True)]

    counts = {id(b): (b, gb)}  # each solved point's count evaluated once (the point is kept: ids stay unique)

    def count(info):
        if id(info) not in counts:
            g = evaluate_test(event, info)
            counts[id(info)] = (info, float(g[component]) if component < g.size else math.nan)
        return counts[id(info)][1]

    results = []
    sig_a, pa, va = 0.0, a, ga
    while True:
        ref = va
        loc = narrow(point_at, sig_a, h, pa, b, math.nan, math.nan, h, side=lambda info, v, ref=ref: count(info) == ref,
                     value=None, tol=tol, max_iter=max_iter)
        loc.value = count(loc.point)
        results.append(loc)
        if not loc.located or loc.value == gb or loc.sigma >= h or loc.point is b or len(results) > 16:
            break
        # a later change in the remainder of the interval
        sig_a, pa, va = loc.sigma, loc.point, loc.value
    return results
