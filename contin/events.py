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
variant of regula falsi for continuous tests, or by bisection for
integer-valued ones, until

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

from .branch import SpecialKind
from .newton import LUFactor

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
    located :class:`~contin.branch.SpecialPoint`).

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
    ):
        self.fun = fun
        self.name = name
        self.kind = SpecialKind(kind)
        self.integer_valued = bool(integer_valued)
        self._describe = describe

    def test(self, point: PointInfo):
        return self.fun(point)

    def describe(self, point: PointInfo) -> dict:
        return {} if self._describe is None else dict(self._describe(point))


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
    point: PointInfo
    value: float
    located: bool
    iterations: int
    message: str
    bracket: tuple


_EPS = np.finfo(float).eps


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
    results = []
    sig_a, pa, va = 0.0, a, float(ga)
    while True:
        loc = _locate_one(event, component, point_at, sig_a, h, pa, b, va, float(gb), tol, max_iter)
        results.append(loc)
        if not (event.integer_valued and loc.located):
            break
        # a later change in the remainder of the interval
        if loc.value == gb or loc.sigma >= h or loc.point is b:
            break
        sig_a, pa, va = loc.sigma, loc.point, loc.value
        if len(results) > 16:
            break
    return results


def _locate_one(event, component, point_at, s_lo, s_hi, p_lo, p_hi, g_lo, g_hi, tol, max_iter) -> Location:
    h = s_hi - s_lo
    true_lo, true_hi = g_lo, g_hi  # Illinois modifies the working values
    w_lo, w_hi = g_lo, g_hi
    ref = g_lo  # integer tests: value on the "before" side
    scale_g = max(abs(g_lo), abs(g_hi))
    side = 0
    iterations = 0
    s_full = s_hi
    message = ""
    located = False

    def bracket_done():
        width = s_hi - s_lo
        if width <= 64 * _EPS * max(1.0, s_full):
            return True
        lam_ref = max(1.0, abs(p_lo.lam), abs(p_hi.lam))
        return abs(p_hi.lam - p_lo.lam) <= tol * lam_ref and width <= math.sqrt(tol) * h

    if not event.integer_valued and g_hi == 0.0:
        return Location(s_hi, p_hi, 0.0, True, 0, "test exactly zero at the stored point", (p_hi.lam, p_hi.lam))

    while True:
        if bracket_done():
            located = True
            break
        if iterations >= max_iter:
            message = f"location did not converge in {max_iter} iterations"
            break
        if event.integer_valued:
            s = 0.5 * (s_lo + s_hi)
        else:
            denom = w_hi - w_lo
            s = (s_lo * w_hi - s_hi * w_lo) / denom if denom != 0 else math.nan
            if not (s_lo < s < s_hi):
                s = 0.5 * (s_lo + s_hi)
        iterations += 1
        info, why = point_at(s)
        if info is None:
            message = f"location failed: {why}"
            break
        g_all = evaluate_test(event, info)
        g = float(g_all[component]) if component < g_all.size else math.nan
        if not math.isfinite(g):
            message = "location failed: non-finite test value"
            break
        if event.integer_valued:
            if g == ref:
                s_lo, p_lo, true_lo = s, info, g
            else:
                s_hi, p_hi, true_hi = s, info, g
            continue
        if g == 0.0 or abs(g) <= 1e-15 * scale_g:
            s_lo = s_hi = s
            p_lo = p_hi = info
            true_lo = true_hi = g
            located = True
            break
        if (g < 0) == (w_lo < 0):
            s_lo, p_lo, true_lo, w_lo = s, info, g, g
            if side == -1:
                w_hi *= 0.5
            side = -1
        else:
            s_hi, p_hi, true_hi, w_hi = s, info, g, g
            if side == 1:
                w_lo *= 0.5
            side = 1

    if event.integer_valued:
        sigma, point, value = s_hi, p_hi, true_hi
    elif abs(true_lo) <= abs(true_hi):
        sigma, point, value = s_lo, p_lo, true_lo
    else:
        sigma, point, value = s_hi, p_hi, true_hi
    if located:
        message = f"located in {iterations} iterations, |dlam| = {abs(p_hi.lam - p_lo.lam):.1e}"
    return Location(sigma, point, value, located, iterations, message, (p_lo.lam, p_hi.lam))
