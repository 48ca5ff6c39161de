"""Grazing along a branch of harmonic-balance orbits: a contact arc appearing or vanishing tangentially.

A force element with switching functions ``h_i(x, x')`` (contact where
``h_i > 0``, :class:`contin.model.base.Switching`) switches its law where the
orbit crosses ``h_i = 0``. Along a branch the number of these crossings per
period changes by two wherever a local extremum of ``h_i`` along the orbit
passes through zero: a flight arc opens inside a contact arc (a minimum
falling below zero), or a contact arc appears (a maximum rising above it).
That is grazing (Leine & Nijmeijer, *Dynamics and Bifurcations of
Non-Smooth Mechanical Systems*, Springer 2004, ch. 7; di Bernardo et al.,
*Piecewise-smooth Dynamical Systems*, Springer 2008, ch. 4). The harmonic
balance's residual is only continuous there (its Fourier coefficients have
a square-root singularity), so a branch either passes with a corner or
cannot be continued at all: the truncated series of a bouncing motion is
not a solution of the same quality.

:class:`GrazingEvent` makes it an event of the continuation engine:

- its test is the number of switches per period, counted on the AFT samples
  (what the harmonic balance itself resolves);
- its continuous distance is the value of ``h_i`` at the extremum nearest
  to zero, refined on the trigonometric series (Newton on
  ``dh/dtheta = 0``), so that it is a smooth function of the coefficients:
  the engine narrows a bracket with it in a few solves and predicts, from
  the last two points, how far ahead the next grazing lies;
- it is a *barrier*: where steps fail short of the predicted grazing, the
  engine locates it from the near side, records it as a ``grazing`` special
  point and ends the branch there (status ``boundary``) if no step passes
  it, instead of shrinking its steps to ``ds_min``.
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from contin.hb import aft
from contin.engine.branch import SpecialKind
from contin.hb.crossings import series_at
from contin.engine.events import Event, PointInfo, narrow
from contin.hb.harmonics import coefficient_blocks

__all__ = ["GrazingEvent", "OrbitContacts", "orbit_contacts", "grazing_events"]

#: Newton iterations refining an extremum of a switching function on the series.
_REFINE_ITER = 8
#: Extrema refined: those whose sampled value lies within this factor of the smallest |h| (and the sample error).
_CANDIDATE_SPREAD = 4.0
#: A grazing point is located where the extremum is this small relative to its values at the bracket's ends.
GTOL = 1e-9


class OrbitContacts:
    """Contact switches along one orbit.

    Attributes
    ----------
    switches : int
        Sign changes of all switching functions over one period: on the AFT samples, plus two
        for each extremum near zero that lies beyond zero between samples of the other sign
        (so that the count changes exactly where :attr:`extremum` changes sign).
    extremum : float
        ``h`` at the extremum (of any switching function) nearest to zero, refined on the
        series; NaN if no switching function has an extremum.
    phase : float
        Base phase ``theta`` of that extremum.
    function : tuple
        ``(element index, function index)`` of that extremum (None if none).
    """

    def __init__(self, switches, extremum, phase, function):
        self.switches, self.extremum, self.phase, self.function = int(switches), float(extremum), float(phase), function


def _switching_elements(model):
    n = model.n_dof
    p = model.parameter_vector()
    out = []
    for e, el in enumerate(model.forces):
        sw = el.switching_functions(np.zeros((0, n)), np.zeros((0, n)), np.zeros(0), p)
        if sw is not None:
            out.append((e, el))
    return out


def _h_and_slope(el, i, U, Omega, nu, phi, p):
    """``h_i`` and ``dh_i/dtheta`` on the series at the phases ``phi`` (K,)."""
    x, x1, x2 = series_at(U, phi)
    sw = el.switching_functions(x, Omega * x1, nu * phi, p)
    slope = np.einsum("kq,kq->k", sw.grad_x[:, i], x1) + Omega * np.einsum("kq,kq->k", sw.grad_xd[:, i], x2)
    return sw.value[:, i], slope


def orbit_contacts(hb, u: np.ndarray, lam: float) -> OrbitContacts:
    """Switches and the extremum of a switching function nearest to zero along an HB orbit.

    Parameters
    ----------
    hb : HarmonicBalance
    u : ndarray, shape (hb.size,)
        The orbit's coefficients (:mod:`contin.hb.harmonics` ordering).
    lam : float

    Returns
    -------
    OrbitContacts
    """
    p = hb.params_at(lam)
    Omega = hb.base_frequency(p)
    U = np.ascontiguousarray(coefficient_blocks(np.asarray(u, dtype=float), hb.n))
    N = hb.N
    x, xp = aft.synthesize(U, N)
    theta = 2.0 * np.pi * np.arange(N) / N
    switches = 0
    best = (math.inf, math.nan, math.nan, None)
    for e, el in _switching_elements(hb.model):
        sw = el.switching_functions(x, Omega * xp, hb.nu * theta, p)
        h = sw.value
        pos = h > 0.0
        switches += int(np.count_nonzero(pos != np.roll(pos, -1, axis=0)))
        prev, nxt = np.roll(h, 1, axis=0), np.roll(h, -1, axis=0)
        ext = ((h <= prev) & (h < nxt)) | ((h >= prev) & (h > nxt))
        for i in range(h.shape[1]):
            j = np.flatnonzero(ext[:, i])
            if not j.size:
                continue
            hv = np.abs(h[j, i])
            # the sampled extremum is off the true one by up to the change over half a sample
            err = 0.5 * np.abs(nxt[j, i] - prev[j, i])
            keep = hv <= _CANDIDATE_SPREAD * hv.min() + 2.0 * err
            phi = theta[j[keep]].copy()
            val, slope = _h_and_slope(el, i, U, Omega, hb.nu, phi, p)
            d = 2.0 * np.pi / N * 1e-3
            for _ in range(_REFINE_ITER):
                _, s2 = _h_and_slope(el, i, U, Omega, hb.nu, phi + d, p)
                curv = (s2 - slope) / d
                with np.errstate(divide="ignore", invalid="ignore"):
                    step = np.where(curv != 0.0, -slope / curv, 0.0)
                step = np.clip(step, -np.pi / N, np.pi / N)  # stay near the sampled extremum
                phi = phi + step
                val, slope = _h_and_slope(el, i, U, Omega, hb.nu, phi, p)
                if np.all(np.abs(step) < 1e-13):
                    break
            # an extremum of the series beyond zero between two samples of the other sign is a
            # contact (or flight) arc that the samples do not see: two switches more
            switches += 2 * int(np.count_nonzero((val > 0.0) != (h[j[keep], i] > 0.0)))
            k = int(np.argmin(np.abs(val)))
            if abs(val[k]) < best[0]:
                best = (abs(val[k]), float(val[k]), float(phi[k] % (2.0 * np.pi)), (e, i))
    return OrbitContacts(switches, best[1], best[2], best[3])


class GrazingEvent(Event):
    """Grazing of the orbits of a harmonic-balance branch (see the module docstring).

    Parameters
    ----------
    problem : HarmonicBalance
        Or a problem that wraps one (``problem.full``, with
        ``problem.expand(u, lam)`` giving the full coefficients).
    """

    kind = SpecialKind.GRAZING
    name = "grazing"
    integer_valued = True
    barrier = True

    def __init__(self, problem):
        self.problem = problem
        self.hb = problem.full
        self._expand = problem.expand if problem.condensed else None
        self._cache: OrderedDict = OrderedDict()

    def contacts(self, point: PointInfo) -> OrbitContacts:
        key = (np.asarray(point.u).tobytes(), float(point.lam))
        hit = self._cache.get(key)
        if hit is None:
            u = self._expand(point.u, point.lam) if self._expand is not None else point.u
            hit = orbit_contacts(self.hb, u, point.lam)
            self._cache[key] = hit
            if len(self._cache) > 16:
                self._cache.popitem(last=False)
        return hit

    def test(self, point: PointInfo) -> float:
        return float(self.contacts(point).switches)

    def distance(self, point: PointInfo) -> float:
        return self.contacts(point).extremum

    def locate(self, component, point_at, h, a, b, ga, gb, *, tol=1e-10, max_iter=60):
        n_a = self.contacts(a).switches
        # beyond the grazing the residual is only continuous (Newton may fail there): the point is
        # found on the near side, where the distance is smooth, to GTOL of it
        loc = narrow(point_at, 0.0, h, a, b, self.distance(a), self.distance(b), h,
                     side=lambda info, v: self.contacts(info).switches == n_a, value=self.distance,
                     tol=tol, max_iter=max_iter, vtol=GTOL, failed_beyond=True)
        loc.value = self.test(loc.point)
        return [loc]

    def describe(self, point: PointInfo) -> dict:
        c = self.contacts(point)
        out = {"switches": c.switches, "extremum": c.extremum, "phase": c.phase}
        if c.function is not None:
            el = self.hb.model.forces[c.function[0]]
            out["element"] = getattr(el, "label", None) or el.kind
            out["function"] = c.function[1]
        return out


def grazing_events(problem) -> list[Event]:
    """``[GrazingEvent(problem)]`` when the problem's model has switching force elements, else ``[]``."""
    hb = problem.full
    model = getattr(hb, "model", None)
    if model is None or not hasattr(hb, "N") or getattr(hb, "H", 0) < 1 or not _switching_elements(model):
        return []
    return [GrazingEvent(problem)]
