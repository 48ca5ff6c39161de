"""Events in a step: their detection between two stored points and the location of special points.

What an event is (its test, when a change counts, how its zero is narrowed)
lives in :mod:`contin.engine.events`; this module applies the events to the
engine's steps:

- :func:`test_values`: every event's test at a point;
- :meth:`EventLocation.on_step`: after a stored step, the events whose test
  changed from the previous point, each located on the arc between them
  (solves on the hyperplanes ``ta . (x - xa) = sigma`` normal to the earlier
  tangent, started on the cubic Hermite arc through both points) and
  recorded as a special point of the branch;
- :meth:`EventLocation.step_cap`: the longest next step the events allow.
"""

from __future__ import annotations

import math

import numpy as np

from contin.engine.barriers import Barriers
from contin.engine.branch import BranchBuilder, SpecialKind, SpecialPoint
from contin.engine.corrector import Candidate, Corrector
from contin.engine.events import (
    BranchPointEvent,
    Event,
    FoldEvent,
    Location,
    PointInfo,
    changed_components,
    evaluate_test,
)
from contin.engine.newton import NUMERICAL_ERRORS, SingularMatrixError, factorize
from contin.engine.predictor import HermiteArc, unit_tangent
from contin.engine.problem import LazyData, bordered_matrix, evaluate_monitors, point_info

__all__ = ["BP_DIP", "FOLD_NEAR", "EventLocation", "branch_point_artefact", "kernel_singular_values", "location_point", "test_values"]

#: Hyperplanes from the earlier point to the one asked when the Hermite guess is outside Newton's basin.
ARC_SUBSTEPS = 4
#: Smallest ``t . ta`` the substeps' predictor divides by (a tangent turned far from ``ta``).
MIN_ALIGNMENT = 0.1
#: At a located branch point the smallest singular value of ``[Ju Jlam]`` must have fallen below this
#: fraction of its larger value at the step's ends (it vanishes at a branch point, not at a fold).
BP_DIP = 0.1
#: A fold is beside a point where the smallest singular value of ``Ju`` is below this fraction of that of
#: ``[Ju Jlam]`` (which bounds it from above).
FOLD_NEAR = 0.2


def test_values(events: list, info: PointInfo) -> list[np.ndarray]:
    """Test values of all events at ``info``, 1-D arrays; a numerical failure gives NaN (ignored)."""
    out = []
    for ev in events:
        try:
            out.append(evaluate_test(ev, info))
        except NUMERICAL_ERRORS:
            out.append(np.full(1, np.nan))
    return out


def kernel_singular_values(info: PointInfo, su, sl: float) -> np.ndarray:
    """The singular values of the scaled ``[Ju su, Jlam sl]`` at ``info``, largest first (m of them).

    The matrix has a one-dimensional kernel (the tangent) at a regular point and at
    a fold, a two-dimensional one at a branch point: there its smallest value vanishes.
    """
    A = np.column_stack([np.asarray(info.Ju, float) * su, np.asarray(info.Jlam, float) * sl])
    return np.linalg.svd(A, compute_uv=False)


def branch_point_artefact(p: PointInfo, a: PointInfo, b: PointInfo, su, sl: float, *,
                          bordered: bool = False) -> tuple[str | None, dict]:
    """Whether a branch point located at ``p`` on the step from ``a`` to ``b`` is one.

    At a branch point ``[Ju Jlam]`` loses rank: its smallest singular value at
    ``p`` falls below :data:`BP_DIP` times the larger of its values at ``a`` and
    ``b``. Where it does not, the change that was taken for a branch point is
    explained otherwise:

    - a fold beside it: ``Ju`` nearly singular (its smallest singular value below
      :data:`FOLD_NEAR` times that of ``[Ju Jlam]``) while ``[Ju Jlam]`` is not. A
      multiplier crosses ``+1`` at a fold too, and the multipliers of a truncated
      series (the monodromy's, or Hill's) cross a little off the fold of the
      harmonic balance, in the step before or after it;
    - ``bordered``: the test is the sign of ``det [[Ju, Jlam], [t^T]]``, which
      flips without a rank drop only where the tangent's orientation does (a
      corner of a non-smooth branch) or at a fold.

    A multiplier crossing where neither matrix is singular is kept: nothing in
    the Jacobian tells what it is.

    Returns
    -------
    reason : str or None
        Why the point is no branch point (None: it is one, or the check could not be made).
    data : dict
        ``kernel_singular_values``: the two smallest singular values of ``[Ju Jlam]`` at ``p`` over
        the largest (one for a single unknown); ``kernel_dip``: the smallest over its value at the
        ends; ``fold_ratio``: the smallest of ``Ju`` over the smallest of ``[Ju Jlam]``.
    """
    try:
        sv = kernel_singular_values(p, su, sl)
        ends = max(float(kernel_singular_values(a, su, sl)[-1]), float(kernel_singular_values(b, su, sl)[-1]))
        ju = np.linalg.svd(np.asarray(p.Ju, float) * su, compute_uv=False)
    except (np.linalg.LinAlgError, ValueError):
        return None, {}
    if not (sv.size and np.all(np.isfinite(sv)) and np.all(np.isfinite(ju)) and math.isfinite(ends)):
        return None, {}
    top = float(sv[0]) if sv[0] > 0 else 1.0
    data = {"kernel_singular_values": [float(v) / top for v in sv[::-1][:2]]}
    if ends <= 0.0:
        return None, data  # both ends on the singular set: nothing to compare with
    dip = float(sv[-1]) / ends
    data["kernel_dip"] = dip
    if dip <= BP_DIP:
        return None, data
    fold = float(ju[-1]) / float(sv[-1])
    data["fold_ratio"] = fold
    rank = (f"[Ju Jlam] keeps full rank there (its smallest singular value is {dip:.2g} times its value at the "
            f"step's ends, > {BP_DIP:g})")
    if fold < FOLD_NEAR:
        return f"{rank} while Ju is nearly singular ({fold:.2g} times that): a fold beside it, not a branch point", data
    if bordered:
        return f"{rank}: the tangent's orientation flipped (a corner or a fold), not a branch point", data
    return None, data


def location_point(ev: Event, loc: Location, ga: float, gb: float, comp: int, vector: bool, lam_a: float,
                   lam_b: float, index: int) -> SpecialPoint:
    """The special point of ``ev`` located (``loc``) on the step from stored point ``index``.

    ``ga``, ``gb``: the test component ``comp`` at both ends (``vector``: the
    test has several components, stored as ``data["component"]``);
    ``lam_a``, ``lam_b``: the parameter at both ends.
    """
    p = loc.point
    try:
        data = dict(ev.describe(p))
    except NUMERICAL_ERRORS as exc:
        data = {"describe_error": f"{type(exc).__name__}: {exc}"}
    if vector:
        data.setdefault("component", comp)
    return SpecialPoint(
        kind=ev.kind, parameter=float(p.lam), unknowns=p.u.copy(), interval=(lam_a, lam_b),
        index=index, s=float(p.s), test_values=(float(ga), float(gb)), located=loc.located,
        data=data, message=f"{ev.name}: {loc.message}", event=ev.name, tangent=p.tangent.copy(),
        point_data={k: np.array(v) for k, v in p.data.items()},
    )


#: in a light location, the solved points next to ``sigma`` give the guess there once they lie within this
#: fraction of the step (closer, the chord between them is nearer the curve than the cubic through the step's
#: ends). Not in the others: a guess within Newton's tolerance is taken as it is, and a fold or a multiplier
#: crossing located from it would carry that tolerance where Newton's last update polishes the point further.
BETWEEN = 0.25


def _between(solved: list, sigma: float, h: float) -> np.ndarray | None:
    """The point at ``sigma`` on the chord between the nearest solved points either side, when they are within
    ``BETWEEN * h`` of each other (on the hyperplane: ``sigma`` is linear along the chord); else None."""
    lo = max((p for p in solved if p[0] <= sigma), key=lambda p: p[0], default=None)
    hi = min((p for p in solved if p[0] >= sigma), key=lambda p: p[0], default=None)
    if lo is None or hi is None or not 0.0 < hi[0] - lo[0] < BETWEEN * h:
        return None
    f = (sigma - lo[0]) / (hi[0] - lo[0])
    return lo[1] + f * (hi[1] - lo[1])


class EventLocation:
    """Detects and locates the events on each stored step.

    Parameters
    ----------
    events : list of Event
    monitors : list of Monitor
        Evaluated at the located points.
    corrector : Corrector
    barriers : Barriers
        Told of each located barrier point; a change on the step from a
        barrier's near-side point is the barrier already recorded.
    builder : BranchBuilder
        The located special points are added to its branch.
    options : ContinuationOptions
    """

    def __init__(self, events: list, monitors: list, corrector: Corrector, barriers: Barriers,
                 builder: BranchBuilder, options):
        self.events = events
        self.monitors = monitors
        self.corrector = corrector
        self.barriers = barriers
        self.builder = builder
        self.opt = options

    def on_step(self, xa: np.ndarray, ta: np.ndarray, info_a: PointInfo, ga_all: list, cand: Candidate,
                info_b: PointInfo, gb_all: list, index: int, ds_free: float) -> set:
        """Locate every event whose test changed on the step from ``info_a`` to the stored point ``index``.

        ``xa``, ``ta``: the earlier point and its tangent (scaled, (m+1,));
        ``ga_all``, ``gb_all``: the events' tests at both ends; ``ds_free``:
        the step the step control wanted (a located barrier is judged
        against it). Returns the events that changed.
        """
        changed = set()
        for ev, ga, gb in zip(self.events, ga_all, gb_all):
            if cand.kink is not None and isinstance(ev, (FoldEvent, BranchPointEvent)):
                continue  # the tangent's jump at a corner is neither a fold nor a branch point
            if self.barriers.skips(ev, index):
                continue  # the step from the barrier's point passes the barrier recorded there
            for comp in changed_components(ev, ga, gb, info_a, info_b):
                changed.add(ev)
                self._locate(ev, comp, xa, ta, info_a, cand, info_b, ga, gb, index - 1, ds_free)
        return changed

    def step_cap(self, changed: set, barrier: Event | None, info_a: PointInfo, info_b: PointInfo, h: float) -> float:
        """The longest next step from ``info_b`` the events allow (``inf``: none).

        Events that ``changed`` on the step (of length ``h``, from ``info_a``)
        and the ``barrier`` the new point was located on are skipped: located at
        or just behind the new point, there is nothing ahead to predict yet.
        """
        cap = math.inf
        for ev in self.events:
            if ev in changed or ev is barrier:
                continue  # located at or just behind the new point: nothing ahead to predict yet
            try:
                limit = float(ev.step_limit(info_a, info_b, h))
            except NUMERICAL_ERRORS:
                continue
            if limit > 0:
                cap = min(cap, limit)
        return cap

    def _solve_on_arc(self, arc: HermiteArc, xa: np.ndarray, ta: np.ndarray, sigma: float, chord=None,
                      light: bool = False, guess: np.ndarray | None = None):
        """The solution on the hyperplane ``ta . (x - xa) = sigma``: ``(NewtonResult, "")`` or ``(None, why)``.

        The cubic Hermite guess on the arc first (``O(h^4)`` off the curve,
        where the chord is ``O(h^2)`` off); where Newton's basin is smaller
        still (stiff contact), march from the earlier point in substeps
        along the family of hyperplanes normal to its tangent. ``chord``:
        the linearisation of a point nearby (see ``Corrector.bordered_solve``); ``light``: the first solve
        without a linearisation at the solution (the substeps, where it fails, linearise); ``guess``: the
        first solve's start, if not the arc's point.
        """
        corrector = self.corrector
        try:
            res = corrector.bordered_solve(arc.at(sigma) if guess is None else guess, xa, ta, sigma, chord=chord,
                                           light=light)
            if res.converged and res.lu is not None:
                return res, ""
            x, t, ok = xa, ta, True
            n_sub = ARC_SUBSTEPS
            for k in range(1, n_sub + 1):
                sk = sigma * k / n_sub
                res = corrector.bordered_solve(x + (sigma / n_sub) * t / max(float(t @ ta), MIN_ALIGNMENT), xa, ta,
                                               sk)
                if not res.converged or res.lu is None:
                    ok = False
                    break
                x = res.x
                z = res.lu.solve(corrector.e_last)
                t = z / np.linalg.norm(z)
                if float(t @ ta) < 0:
                    t = -t
            if ok:
                return res, ""
        except NUMERICAL_ERRORS as exc:
            return None, f"evaluation failed ({type(exc).__name__}: {exc})"
        if res.converged:
            return None, "singular bordered Jacobian"
        return None, f"Newton did not converge ({res.message})"

    def _linearised(self, info: PointInfo, normal: np.ndarray) -> PointInfo:
        """The point ``info``, solved without a linearisation (a light solve), with its own: ``Ju``, ``Jlam``,
        the bordered matrix with the arc's ``normal`` and the tangent from it (as the other points have)."""
        sp, monitors = self.corrector.sp, self.monitors
        try:
            _, Ju, Jlam = sp.evaluate(info.u, info.lam)
            lu = factorize(bordered_matrix(Ju, Jlam, sp.su, sp.sl, normal))
        except NUMERICAL_ERRORS + (SingularMatrixError,):
            return info  # it keeps the nearby point's linearisation; its location stands
        t = unit_tangent(lu, self.corrector.e_last)
        if t is None:
            return info
        u, lam = info.u, info.lam
        data = LazyData(lambda: evaluate_monitors(monitors, u, lam, Ju, Jlam))
        return point_info(u, lam, t, lu, Ju, Jlam, info.s, data)

    def _locate(self, ev: Event, comp: int, xa: np.ndarray, ta: np.ndarray, info_a: PointInfo, cand: Candidate,
                info_b: PointInfo, ga: np.ndarray, gb: np.ndarray, index: int, ds_free: float) -> None:
        """Locate component ``comp`` of ``ev`` between stored points ``index`` and ``index + 1``; record it."""
        sp = self.corrector.sp
        h = cand.h
        arc = HermiteArc(xa, ta, cand.x, cand.tangent, h)
        monitors = self.monitors
        near = [(info_a.Ju, info_a.Jlam)]  # the linearisation of the point solved last (a lazy Jacobian's chord)
        # a test that reads no linearisation, on a problem whose Jacobian costs many residuals: the points
        # on the arc are solved without one (their tangent from the chord's factorisation, Ju and Jlam the
        # nearby point's), and the located point gets its own below
        light = not ev.needs_linearisation and sp.lazy
        unlinearised = []  # the points solved without a linearisation

        ends = ((info_a.Ju, info_a.Jlam), (info_b.Ju, info_b.Jlam))
        solved = [(0.0, xa), (float(ta @ (cand.x - xa)), cand.x)]  # (sigma, scaled point) of the solved points

        def point_at(sigma: float):
            if light:  # the chord of the nearer end of the step (both linearised)
                near[0] = ends[int(sigma > 0.5 * h)]
            guess = _between(solved, sigma, h) if light else None
            res, why = self._solve_on_arc(arc, xa, ta, sigma, near[0], light=light, guess=guess)
            if res is None:
                return None, why
            solved.append((float(ta @ (res.x - xa)), res.x.copy()))
            t = unit_tangent(res.lu, self.corrector.e_last)
            if t is None:
                return None, "non-finite tangent"
            if res.jacobian is None:  # a light solve
                u, lam = res.x[:-1] * sp.su, float(res.x[-1] * sp.sl)
                Ju, Jlam = near[0]
            else:
                u, lam, R, Ju, Jlam = sp.last
            # the monitors run when an event's test first reads the point's data: a fold's test
            # (the tangent) needs none, a stability event's the multipliers
            data = LazyData(lambda u=u, lam=lam, Ju=Ju, Jlam=Jlam: evaluate_monitors(monitors, u, lam, Ju, Jlam))
            info = point_info(u, lam, t, res.lu, Ju, Jlam, info_a.s + sigma, data)
            if res.jacobian is None:
                unlinearised.append(info)
            else:
                near[0] = (info.Ju, info.Jlam)
            return info, ""

        locations = ev.locate(comp, point_at, h, info_a, info_b, float(ga[comp]), float(gb[comp]),
                              tol=self.opt.locate_tol, max_iter=self.opt.locate_max_iter)
        for loc in locations:
            if any(loc.point is q for q in unlinearised):
                loc.point = self._linearised(loc.point, ta)
            p = loc.point
            if isinstance(p.data, LazyData):
                try:
                    p.data = dict(p.data)
                except NUMERICAL_ERRORS as exc:
                    p.data = {}
                    loc.message += f"; a monitor failed there ({type(exc).__name__}: {exc})"
            point = location_point(ev, loc, ga[comp], gb[comp], comp, ga.size > 1, info_a.lam, info_b.lam, index)
            if ev.kind is SpecialKind.BP:
                reason, kernel = branch_point_artefact(p, info_a, info_b, sp.su, sp.sl,
                                                       bordered=isinstance(ev, BranchPointEvent))
                if reason is not None:  # kept out of the special points, said in the branch's data
                    self.builder.branch.info.setdefault("dropped_points", []).append(
                        {"kind": point.kind.value, "event": ev.name, "parameter": point.parameter,
                         "interval": [float(info_a.lam), float(info_b.lam)], "index": index, "reason": reason,
                         **kernel})
                    continue
                point.data.update(kernel)
            self.builder.add_special(point)
            if ev.barrier and loc.located:
                # the steps after it must show that the branch passes it (see Barriers.after_store)
                self.barriers.reached(ev, float(loc.point.lam), h, index + 1, ds_free)
