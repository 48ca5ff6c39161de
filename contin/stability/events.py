"""Stability events for the continuation engine: multipliers crossing the unit circle, located and classified.

:class:`MultiplierCrossingEvent` fires where a multiplier crosses at ``+1``
(``fold`` or ``bp``), at ``-1`` (``pd``) or as a complex pair (``ns``), by the
counts of unstable multipliers of :mod:`contin.stability.verdict`, and
locates the crossing on a continuous test; :class:`StabilityChangeEvent`
fires on any change of ``n_unstable`` and classifies it afterwards;
:func:`stability_events` gives the classified set the engine uses;
:func:`describe_crossing` is the data of a located point (the critical
multiplier and Hill's eigenvector).

Location accuracy
-----------------
The events locate where a count changes, i.e. where ``|mu| = 1 + tolerance``.
For a transversal crossing that is ``tolerance / |d|mu|/dlambda|`` away from
the bifurcation (it grows where the multiplier moves slowly with the
parameter); for the tangential crossings of conservative systems it is
``O(tolerance^2)``. Hill's method alone allows a smaller margin for
dissipative systems; the RK4 monodromy needs a margin above its drift
``~ (w_eff h)^4 T / 120``. The engine's own branch-point test (sign of the
bordered determinant) is exact and is preferred by
:func:`contin.bifurcation.diagram.follow` when both report the same point.
Measured location errors: docs/validation/stability-notes.md.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from contin.engine.branch import SpecialKind
from contin.engine.events import Event, FunctionEvent, Location, PointInfo, locate, narrow
from contin.stability.hill import hill_spectrum
from contin.stability.monitor import StabilityMonitor
from contin.stability.multiplier_pairing import pair_multipliers, multiplier_step_limit
from contin.stability.options import StabilityMethod
from contin.stability.point_verdicts import (HeldVerdict, branch_turns, counts_of, evaluated_only, mark_before,
                                             multipliers_of)
from contin.stability.verdict import FloquetResult

__all__ = ["MultiplierCrossingEvent", "StabilityChangeEvent", "describe_crossing", "stability_events"]


_CROSSING_COUNT = {"+1": "n_plus", "-1": "n_minus", "complex": "n_complex"}


def _kind_mask(mu: np.ndarray, crossing: str, real_angle_tol: float) -> np.ndarray:
    ang = np.abs(np.angle(mu))
    if crossing == "+1":
        return ang <= real_angle_tol
    if crossing == "-1":
        return ang >= np.pi - real_angle_tol
    return (ang > real_angle_tol) & (ang < np.pi - real_angle_tol)


class MultiplierCrossingEvent(Event):
    """A multiplier crossing the unit circle at ``+1``, at ``-1`` or as a complex pair.

    The counts of unstable multipliers (``|mu| > 1 + tolerance``) by type,
    ``n_plus`` (real positive), ``n_minus`` (real negative) and ``n_complex``,
    decide whether a crossing happened between two points, by what each
    crossing changes and what it does not:

    - a real multiplier crossing ``+1`` (``-1``) flips the parity of
      ``n_plus`` (``n_minus``);
    - a complex pair crossing changes ``n_unstable`` by 2 and neither parity;
    - two complex multipliers colliding on the real axis (or two real ones
      leaving it) outside the circle change ``n_complex`` by 2 and
      ``n_minus`` (``n_plus``) by 2: no parity and not ``n_unstable``. Such a
      collision is not a bifurcation and is never reported.

    So ``pd`` is reported where the parity of ``n_minus`` changes (a real
    multiplier crossing -1), ``ns`` where ``n_unstable`` changes by more
    than the real crossings account for, and the ``+1`` kinds where the
    parity of ``n_plus`` changes.

    Location: the counts keep the bracket (bisection); the modulus of the
    crossing multiplier, followed from one end of the bracket to the other
    (the pairing of the two ends' multipliers that moves them least, then at
    each solved point the multiplier nearest to where it is expected),
    minus ``1 + tolerance``, is the continuous test that the Illinois
    iteration of :func:`contin.engine.events.narrow` solves, so a point costs a few
    solves instead of the bisection's dozens. :meth:`step_limit` extrapolates
    each multiplier's distance to the circle from the last two points: the
    engine keeps the next step near where the closest one is predicted to
    cross, so that two crossings close together (a narrow stable window) are
    not taken in one step.

    A point without a verdict (``evaluated`` False) stands for the last
    evaluated one before it (see :func:`stability_events`): the counts, the
    multipliers that start the continuous test, and the tangent that tells
    ``fold`` from ``bp``.

    Parameters
    ----------
    monitor : StabilityMonitor
        Supplies the counts when they are not in the point data, and Hill's
        eigenvectors for :meth:`describe`.
    crossing : {'+1', '-1', 'complex'}
    kind : SpecialKind or str, optional
        Default ``bp`` for ``+1``, ``pd`` for ``-1``, ``ns`` for ``complex``.
        For ``+1`` with kind ``fold`` the event fires only where the
        parameter component of the tangent changes sign; with kind ``bp``
        only where it does not (the engine's own fold event covers folds).
    """

    integer_valued = True

    def __init__(self, monitor: StabilityMonitor, crossing: str, kind: SpecialKind | str | None = None):
        if crossing not in _CROSSING_COUNT:
            raise ValueError(f"crossing must be one of {list(_CROSSING_COUNT)}, got {crossing!r}")
        default = {"+1": SpecialKind.BP, "-1": SpecialKind.PD, "complex": SpecialKind.NS}[crossing]
        self.kind = SpecialKind(kind) if kind is not None else default
        if crossing != "+1" and self.kind in (SpecialKind.FOLD, SpecialKind.BP):
            raise ValueError(f"kind {self.kind.value!r} needs crossing '+1'")
        self.monitor = monitor
        self.crossing = crossing
        self.key = _CROSSING_COUNT[crossing]
        self.name = f"stability {crossing} ({self.kind.value})"
        #: whether this event gives the monitor's step limit (one of a set of events on one monitor does)
        self.predicts = True
        self._held = HeldVerdict()

    # -- counts -----------------------------------------------------------
    def _count(self, d: dict | None) -> float:
        if d is None:
            return math.nan  # no verdict yet on this branch: no change into or out of it
        return float(d["n_unstable"] if self.crossing == "complex" else d[self.key])

    def _data(self, point: PointInfo):
        """:func:`~contin.stability.point_verdicts._standing` for a stored point, or None.

        See :class:`~contin.stability.point_verdicts.HeldVerdict`.
        """
        return self._held.at(point, counts_of(point, self.monitor))

    def test(self, point: PointInfo) -> float:
        own = counts_of(point, self.monitor)
        self._held.see(point, own)
        held = self._held.at(point, own)
        return self._count(None if held is None else held[1])

    def _crossed(self, da: dict, db: dict) -> bool:
        flip_plus = (int(da["n_plus"]) - int(db["n_plus"])) % 2
        flip_minus = (int(da["n_minus"]) - int(db["n_minus"])) % 2
        if self.crossing == "+1":
            return bool(flip_plus)
        if self.crossing == "-1":
            return bool(flip_minus)
        return abs(int(db["n_unstable"]) - int(da["n_unstable"])) - flip_plus - flip_minus >= 2

    def triggered(self, ga, gb, a, b):
        da, db = self._data(a), self._data(b)
        crossed = da is not None and db is not None and self._crossed(da[1], db[1])
        if crossed and self.crossing == "+1":
            # a turn anywhere since the evaluated point standing for a (a fold where nothing was evaluated)
            turned = branch_turns(da[3], db[3])
            crossed = turned if self.kind is SpecialKind.FOLD else not turned
        return np.full(np.shape(ga), crossed)

    # -- location ---------------------------------------------------------
    def _threshold(self) -> float:
        return 1.0 + self.monitor.options.tolerance

    def _product(self, mu: np.ndarray) -> float:
        """``prod (c -+ mu_i)``, ``c = 1 + tolerance``: the real crossings' continuous test.

        Its sign flips exactly where a real multiplier crosses ``+c`` (``-c``),
        that is where the parity of ``n_plus`` (``n_minus``) flips; conjugate
        pairs contribute ``|c -+ mu|^2 > 0``, so a collision on the real axis
        leaves it alone. It is smooth in the parameter even where the
        multipliers sit on the circle until they meet at ``+-1`` (a
        conservative system), where a modulus stays flat. (The determinant
        tests ``det(Phi -+ I)`` of AUTO; Doedel et al., AUTO-07p manual.)
        """
        c = self._threshold()
        terms = c - mu if self.crossing == "+1" else c + mu
        mag = np.abs(terms)
        if np.any(mag == 0.0):
            return 0.0
        sign = np.prod(terms / mag)  # unit complex; real up to rounding for a conjugate-closed set
        return float(np.sign(sign.real) * math.exp(min(float(np.sum(np.log(mag))), 700.0)))

    def _tracked(self, mu_a: np.ndarray, mu_b: np.ndarray):
        """``(mu_a, mu_b)`` of the multiplier that crosses between two points with these multipliers, or None."""
        pair = pair_multipliers(mu_a, mu_b)
        if (pair < 0).any():
            return None
        tol, thr = self.monitor.options.real_angle_tol, self._threshold()
        best = None
        for i, j in enumerate(pair):
            ma, mb = mu_a[i], mu_b[j]
            if (abs(ma) > thr) == (abs(mb) > thr):
                continue
            if not (_kind_mask(np.array([ma]), "complex", tol)[0] and _kind_mask(np.array([mb]), "complex", tol)[0]):
                continue
            if ma.imag < 0:
                ma, mb = ma.conjugate(), mb.conjugate()
            size = abs(mb - ma)
            if best is None or size < best[2]:
                best = (complex(ma), complex(mb), size)
        return None if best is None else best[:2]

    def locate(self, component, point_at, h, a, b, ga, gb, *, tol=1e-10, max_iter=60):
        held_a, held_b = self._data(a), self._data(b)
        if held_a is None or held_b is None:
            return [Location(h, b, float(gb), False, 0, "no stability verdict at an end", (a.lam, b.lam))]
        # an end without a verdict is represented by the held one (of the last evaluated point before it):
        # its counts give the side, and its multipliers start the continuous test on the right sign
        da = held_a[1]
        mu_a = np.asarray(da["multipliers"], dtype=complex)
        mu_b = np.asarray(held_b[1]["multipliers"], dtype=complex)
        point_at = evaluated_only(point_at, self.monitor)
        thr = self._threshold()
        if self.crossing == "complex":
            tracked = self._tracked(mu_a, mu_b)
            span = b.s - a.s if math.isfinite(b.s - a.s) and b.s != a.s else h

            def value(info):
                # the modulus of the crossing multiplier, found near where it is expected
                if tracked is None:
                    return math.nan
                q = (info.s - a.s) / span if math.isfinite(info.s) else 0.5
                target = tracked[0] + q * (tracked[1] - tracked[0])
                mu = multipliers_of(info, self.monitor)
                if mu is None:
                    return math.nan
                mu = np.concatenate([mu, mu.conjugate()])
                return abs(mu[int(np.argmin(np.abs(mu - target)))]) - thr

            v_a, v_b = (abs(tracked[0]) - thr, abs(tracked[1]) - thr) if tracked is not None else (math.nan, math.nan)
        else:
            def value(info):
                mu = multipliers_of(info, self.monitor)
                return math.nan if mu is None else self._product(mu)

            v_a, v_b = self._product(mu_a), self._product(mu_b)

        def side(info, v):
            d = counts_of(info, self.monitor)
            if d is None:
                raise ArithmeticError(f"no stability verdict at {info.lam:.10g}")
            return not self._crossed(da, d)

        loc = narrow(point_at, 0.0, h, a, b, v_a, v_b, h, side=side, value=value, tol=tol, max_iter=max_iter)
        end = self._data(loc.point)
        loc.value = self._count(None if end is None else end[1])
        return [mark_before(loc, a, held_a, self.monitor)]

    def step_limit(self, a: PointInfo, b: PointInfo, h: float) -> float:
        """The step limit of :func:`multiplier_step_limit`, from evaluated points only.

        Where ``a`` has no verdict the last evaluated point before it stands
        in (``h`` measured from it); none where ``b`` has none.
        """
        if not self.predicts:
            return math.inf
        mu_b = multipliers_of(b, self.monitor)
        if mu_b is None:
            return math.inf
        mu_a = multipliers_of(a, self.monitor)
        if mu_a is None:
            held = self._data(a)
            if held is None or not (math.isfinite(held[0]) and math.isfinite(b.s) and b.s > held[0]):
                return math.inf
            h, mu_a = float(b.s) - held[0], np.asarray(held[1]["multipliers"], dtype=complex)
        return multiplier_step_limit(mu_a, mu_b, h, self._threshold())

    def describe(self, point: PointInfo) -> dict:
        return describe_crossing(self.monitor, point, self.crossing, self.kind)


class StabilityChangeEvent(Event):
    """Integer-valued event on ``n_unstable`` (kind ``stability``), unclassified.

    The located point's data holds the classification (``"classification"``:
    ``fold``/``bp``/``pd``/``ns``) made from the multiplier closest to the
    unit circle; ``fold`` versus ``bp`` is decided by whether the parameter
    component of the tangent changed sign between the two evaluated points
    that bracket the change (recorded by :meth:`triggered`, which the engine
    calls just before locating). Points without a verdict are taken as in
    :func:`stability_events`.
    """

    integer_valued = True
    kind = SpecialKind.STABILITY
    name = "stability change"

    def __init__(self, monitor: StabilityMonitor):
        self.monitor = monitor
        self._turned = False
        self._held = HeldVerdict()

    def test(self, point: PointInfo) -> float:
        own = counts_of(point, self.monitor)
        self._held.see(point, own)
        held = self._held.at(point, own)  # a point without a verdict holds the last one (see HeldVerdict)
        return math.nan if held is None else float(held[1]["n_unstable"])

    def triggered(self, ga, gb, a, b):
        da, db = self._held.at(a, counts_of(a, self.monitor)), self._held.at(b, counts_of(b, self.monitor))
        self._turned = branch_turns(a.tangent[-1] if da is None else da[3], b.tangent[-1] if db is None else db[3])
        return ga != gb

    def locate(self, component, point_at, h, a, b, ga, gb, *, tol=1e-10, max_iter=60):
        """Bisection on ``n_unstable`` (:func:`contin.engine.events.locate`); a point without a verdict ends it."""
        def count(info):
            d = counts_of(info, self.monitor)
            if d is None:
                raise ArithmeticError(f"no stability verdict at {info.lam:.10g}")
            return float(d["n_unstable"])

        counter = FunctionEvent(count, name=self.name, kind=self.kind, integer_valued=True)
        locs = locate(counter, component, evaluated_only(point_at, self.monitor), h, a, b, ga, gb, tol=tol,
                      max_iter=max_iter)
        held = self._held.at(a, counts_of(a, self.monitor))
        return [mark_before(loc, a, held, self.monitor) for loc in locs]

    def describe(self, point: PointInfo) -> dict:
        mu = multipliers_of(point, self.monitor)
        if mu is None:
            return {"evaluated": False}
        i = int(np.argmin(np.abs(np.log(np.maximum(np.abs(mu), 1e-300)))))
        ang = abs(np.angle(mu[i]))
        tol = self.monitor.options.real_angle_tol
        crossing = "+1" if ang <= tol else "-1" if ang >= np.pi - tol else "complex"
        kind = {"-1": SpecialKind.PD, "complex": SpecialKind.NS}.get(
            crossing, SpecialKind.FOLD if self._turned else SpecialKind.BP
        )
        return describe_crossing(self.monitor, point, crossing, kind)


def describe_crossing(monitor: StabilityMonitor, point: PointInfo, crossing: str, kind: SpecialKind) -> dict:
    """Data of a located stability change: the critical multiplier and Hill eigenvector.

    The multipliers are those of the point's monitored data (the verdict the
    engine used) when present.

    Returns
    -------
    dict
        ``classification`` (str), ``crossing`` (str), ``multiplier``
        (complex), ``multiplier_abs``, ``multiplier_arg`` (float),
        ``exponent`` (complex), ``eigenvector`` (ndarray (m,) complex,
        coefficient space, unit 2-norm; Hill's, even when the monodromy's
        multipliers are reported; absent for a monitor without a
        harmonic-balance problem, ``monitor.hb`` None, and for method
        ``floquet`` unless ``StabilityOptions.eigenvectors``), ``n_unstable``,
        ``disagreement``.
    """
    opts = monitor.options
    d = counts_of(point, monitor)
    if d is None:
        return {"classification": kind.value, "crossing": crossing, "evaluated": False}
    mu_all = np.asarray(d["multipliers"], dtype=complex)
    n_unstable = int(d["n_unstable"])
    disagreement = bool(d.get("disagreement", False))
    probe = FloquetResult(
        multipliers=mu_all, exponents=mu_all, stable=True, n_unstable=0, n_plus=0, n_minus=0, n_complex=0,
        max_multiplier=0.0, method=StabilityMethod.HILL, period=0.0, real_angle_tol=opts.real_angle_tol,
    )
    mu = complex(mu_all[probe.critical(crossing)])
    data: dict[str, Any] = {
        "classification": kind.value,
        "crossing": crossing,
        "multiplier": mu,
        "multiplier_abs": abs(mu),
        "multiplier_arg": float(np.angle(mu)),
        "n_unstable": n_unstable,
        "disagreement": disagreement,
    }
    if kind is SpecialKind.BP or kind is SpecialKind.FOLD:
        data["turns"] = kind is SpecialKind.FOLD
    if getattr(monitor, "hb", None) is None or (opts.method is StabilityMethod.FLOQUET and not opts.eigenvectors):
        return data  # Hill's eigenproblem costs more than the monodromy at high H: only when asked for
    try:
        spec = hill_spectrum(monitor.hb, point.u, point.lam, vectors=True, shift_tol=opts.shift_tol)
        j = int(np.argmin(np.abs(spec.multipliers - mu)))
        data["exponent"] = complex(spec.exponents[j])
        data["eigenvector"] = spec.vectors[:, j].copy()
        data["hill_multiplier"] = complex(spec.multipliers[j])
    except (np.linalg.LinAlgError, ValueError) as exc:
        data["eigenvector_error"] = f"{type(exc).__name__}: {exc}"
    return data


def stability_events(monitor: StabilityMonitor, *, folds: bool = False, branch_points: bool = True,
                     period_doubling: bool = True, neimark_sacker: bool = True) -> list[Event]:
    """The classified stability events for the engine.

    Parameters
    ----------
    monitor : StabilityMonitor
        Must also be passed to the engine in ``monitors`` (the events read
        its values from the point data).
    folds : bool
        Add a ``+1`` event of kind ``fold`` (only useful when the engine's
        own fold detection is off).
    branch_points, period_doubling, neimark_sacker : bool

    Returns
    -------
    list of MultiplierCrossingEvent

    Notes
    -----
    A point without a verdict (``evaluated`` False, see
    :class:`~contin.stability.monitor.StabilityMonitor`) gives no information: it holds the test value
    of the last evaluated point before it, so no change is detected into or
    out of it, and a change across it triggers at the next evaluated point
    and is located between the two (a change that the location puts at the
    point without a verdict, or where a solved point on the way has none,
    is recorded unlocated, with its bracket). Step limits come from
    evaluated points only.
    """
    evs: list[Event] = []
    if folds:
        evs.append(MultiplierCrossingEvent(monitor, "+1", SpecialKind.FOLD))
    if branch_points:
        evs.append(MultiplierCrossingEvent(monitor, "+1", SpecialKind.BP))
    if period_doubling:
        evs.append(MultiplierCrossingEvent(monitor, "-1", SpecialKind.PD))
    if neimark_sacker:
        evs.append(MultiplierCrossingEvent(monitor, "complex", SpecialKind.NS))
    for ev in evs[1:]:
        ev.predicts = False  # the multipliers' prediction is made once
    return evs
