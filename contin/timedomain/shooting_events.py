"""Grazing along a branch of shooting orbits: a located event that the branch passes.

A contact element's switching function ``s(x, x')`` is positive where its
force law is active. Along a branch of periodic orbits a contact arc
appears (or a flight arc opens inside a contact arc) where a local extremum
of ``s`` along the orbit passes through zero: grazing (Leine & Nijmeijer,
*Dynamics and Bifurcations of Non-Smooth Mechanical Systems*, Springer 2004,
ch. 7). The flow map of the integrator, whose switches are located in time,
stays continuous there and only its derivative jumps (the branch has a
corner), so unlike a harmonic-balance branch (:mod:`contin.hb.grazing`, a
barrier that ends the branch as ``boundary``) a shooting branch goes on: the
grazing point is located and stored as a ``grazing`` special point.

The test of :class:`ShootingGrazingEvent` is, for each switching function,
the signed value of its local extremum nearest to zero along the orbit (the
problem's ``graze``, the turn of the cubic through the function's values and
slopes at the ends of each step); it changes sign at a grazing and is
continuous in the unknowns. It also changes sign where two extrema of
opposite signs trade the place nearest to zero (a contact that chatters
across its surface, each bounce a minimum below it and a maximum above):
that is no grazing, and the number of switches along the orbit tells them
apart, for a grazing adds or removes two. So a change is reported where the
sign and the count change together, and it is located by the count, the
turn's value giving the next point (it has a corner at the grazing: the
turn belongs to the contact law on one side and to the free flight on the
other, so the location extrapolates from one side,
:func:`contin.engine.bracketing.narrow` with ``kink``).
"""

from __future__ import annotations

import math

import numpy as np

from contin.engine.branch import SpecialKind
from contin.engine.events import Event, Location, PointInfo, narrow

__all__ = ["NO_GRAZE", "ShootingGrazingEvent", "graze_data", "grid_graze", "nearest_zero", "shooting_events",
           "start_graze"]


def grid_graze(s: np.ndarray, periodic: bool = True) -> np.ndarray:
    """For each switching function, the signed value of its sampled extremum nearest to zero.

    Each interior extremum of the samples is refined by the parabola through
    it and its two neighbours (error ``O(dt^3)`` on a smooth arc, which is
    where an extremum near zero lies: the law does not switch there).

    Parameters
    ----------
    s : ndarray, shape (K, n_switch)
        Switching-function values on an equally spaced grid.
    periodic : bool
        The grid covers one period (sample ``K`` would be sample 0).

    Returns
    -------
    ndarray, shape (n_switch,)
        ``+inf`` for a function without an extremum.
    """
    s = np.asarray(s, dtype=float)
    out = np.full(s.shape[1], math.inf)
    if s.shape[0] < 3:
        return out
    if periodic:
        prev, nxt, mid = np.roll(s, 1, axis=0), np.roll(s, -1, axis=0), s
    else:
        prev, mid, nxt = s[:-2], s[1:-1], s[2:]
    ext = ((mid <= prev) & (mid < nxt)) | ((mid >= prev) & (mid > nxt))
    for j in range(s.shape[1]):
        k = np.flatnonzero(ext[:, j])
        if not k.size:
            continue
        a, b, c = prev[k, j], mid[k, j], nxt[k, j]
        curv = a - 2.0 * b + c
        with np.errstate(divide="ignore", invalid="ignore"):
            peak = np.where(curv != 0.0, b - (c - a) ** 2 / (8.0 * curv), b)
        i = int(np.argmin(np.abs(peak)))
        out[j] = float(peak[i])
    return out


def start_graze(s: np.ndarray) -> np.ndarray:
    """The extremum at the first sample of a run, which the run itself cannot see (no sample before it).

    The parabola through the samples ``s[0], s[1], s[2]`` (shape (3, n_switch)); its vertex is taken when
    it lies within one step of ``s[0]`` (an extremum that the samples of the run before this one would
    have centred there).

    Returns
    -------
    ndarray, shape (n_switch,)
        ``+inf`` where the vertex lies elsewhere.
    """
    s = np.asarray(s, dtype=float)
    a, b, c = s[0], s[1], s[2]
    curv = a - 2.0 * b + c  # second difference
    out = np.full(s.shape[1], math.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(curv != 0.0, 0.5 - (b - a) / curv, np.inf)  # vertex, in steps from s[0]
        val = a + (b - a) * x + 0.5 * curv * x * (x - 1.0)
    near = np.isfinite(x) & (np.abs(x) <= 1.0)
    out[near] = val[near]
    return out


def nearest_zero(values) -> np.ndarray:
    """Componentwise, the entry of smallest modulus among rows of ``values`` (shape (R, n_switch)), sign kept."""
    v = np.atleast_2d(np.asarray(values, dtype=float))
    if v.shape[0] == 0:
        return np.full(v.shape[1], math.inf)
    i = np.argmin(np.abs(v), axis=0)
    return v[i, np.arange(v.shape[1])]


#: the monitored graze of an orbit along which no switching function has an extremum (the engine stores
#: finite values only; no grazing can be near)
NO_GRAZE = 1e300


def graze_data(problem, u, lam) -> dict:
    """``{"graze": the extremum nearest to zero over the switching functions}``; empty for a model without any."""
    if not problem.n_switch:
        return {}
    g = problem.graze(u, lam)
    g = g[np.isfinite(g)]
    return {"graze": float(g[np.argmin(np.abs(g))]) if g.size else NO_GRAZE}


class ShootingGrazingEvent(Event):
    """Grazing on a branch of a :class:`contin.timedomain.multiple_shooting.ShootingProblem` (module docstring).

    One test component per switching function of the model: the signed
    extremum nearest to zero (``problem.graze(u, lam)``: at a stored point
    from the linearisation the engine has just made, at the points solved
    while the grazing is located from one plain integration, for they are
    not linearised). Not a barrier: the branch passes the point.

    Parameters
    ----------
    problem : ShootingProblem
    """

    kind = SpecialKind.GRAZING
    name = "grazing"
    integer_valued = False
    barrier = False
    # the graze and the switch count come with the flow itself: the points solved while a grazing is
    # located need no variational integration (ShootingProblem.graze)
    needs_linearisation = False

    def __init__(self, problem):
        self.problem = problem

    def test(self, point: PointInfo) -> np.ndarray:
        return self.problem.graze(point.u, point.lam)

    def _count(self, point: PointInfo) -> int:
        return self.problem.switches(point.u, point.lam)

    def triggered(self, ga, gb, a, b):
        # a turn's sign changed and the switches along the orbit with it (module docstring)
        return super().triggered(ga, gb, a, b) & (self._count(a) != self._count(b))

    def locate(self, component, point_at, h, a, b, ga, gb, *, tol=1e-10, max_iter=60) -> list[Location]:
        n_a = self._count(a)

        def value(info):
            return float(self.test(info)[component])

        def side(info, v):
            return self._count(info) == n_a

        return [narrow(point_at, 0.0, h, a, b, float(ga), float(gb), h, side=side, value=value, tol=tol,
                       max_iter=max_iter, kink=True)]

    def distance(self, point: PointInfo) -> float:
        g = self.problem.graze(point.u, point.lam)
        g = g[np.isfinite(g)]
        return float(g[np.argmin(np.abs(g))]) if g.size else math.nan

    def describe(self, point: PointInfo) -> dict:
        g = self.problem.graze(point.u, point.lam)
        finite = np.isfinite(g)
        if not finite.any():
            return {}
        j = int(np.argmin(np.where(finite, np.abs(g), math.inf)))
        return {"graze": float(g[j]), "function": j}


def shooting_events(problem) -> list[Event]:
    """``[ShootingGrazingEvent(problem)]`` when the problem's model has switching functions, else ``[]``."""
    return [ShootingGrazingEvent(problem)] if problem.n_switch > 0 else []
