"""Automatic bifurcation diagrams: a branch traced with stability, new branches switched onto at its bifurcations.

:func:`follow` traces a first branch with stability, switches automatically
at the requested special points (:func:`contin.bifurcation.switching.switch_at`),
traces the new branches the same way up to a depth, and returns every
branch with its parentage (:class:`BifurcationDiagram`); an interrupted
diagram is taken up from the engine states of its branches.
:func:`switch_branch` switches at one special point and traces the new
branches.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from typing import Any, Callable, Sequence

import numpy as np

from contin.bifurcation.grazing_steps import through_grazing
from contin.bifurcation.switching import BranchStart, continuation_scales, switch_at
from contin.bifurcation.torus_branch import TorusContinuation, TorusSettings, run_torus
from contin.bifurcation.torus_start import torus_start
from contin.engine.branch import Branch, BranchStatus, SpecialKind, SpecialPoint
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.grazing import grazing_events
from contin.model.periodic import is_circle, is_shooting
from contin.stability.events import stability_events
from contin.stability.monitor import StabilityMonitor
from contin.stability.options import StabilityMethod, StabilityOptions

__all__ = ["BifurcationDiagram", "follow", "switch_branch"]


def _run(start: BranchStart, lam_range, options: ContinuationOptions, stability: StabilityOptions,
         parameter_name: str, su: float, sl: float, callback=None, checkpoint=None, previous: Branch | None = None):
    """Trace the branch from ``start`` (or take up ``previous``, the same branch of an interrupted run)."""
    opts = options.replace(unknown_scale=su, parameter_scale=sl)
    monitor, events, monitors = _stability(start.problem, stability, opts)
    if previous is not None:
        return _resume(previous, start.problem, lam_range, opts, parameter_name, events, monitors, callback,
                       checkpoint), monitor
    tangent = np.concatenate([start.tangent[:-1] / su, [start.tangent[-1] / sl]])
    br = _continue(start.problem, start.u, start.lam, lam_range, opts, parameter_name=parameter_name,
                   events=events, monitors=monitors, tangent=tangent, solve_start=False, callback=callback,
                   checkpoint=checkpoint)
    return br, monitor


def _stability(problem, stability: StabilityOptions, options: ContinuationOptions):
    """The stability monitor, the events and the monitors of a branch of ``problem``.

    The events are the classified stability changes (with a monitor) and
    the grazing of contact laws (for a harmonic balance with switching force
    elements).
    """
    monitor, events, monitors = None, [], []
    shooting = is_shooting(problem)
    if shooting:
        from contin.bifurcation.shooting_branch import ShootingMonitor, return_events  # deferred: time domain
        from contin.timedomain.shooting_events import shooting_events  # deferred: as above
    if stability.method is not StabilityMethod.NONE:
        # a shooting branch's multipliers are the flow's (its monodromy), not Hill's
        monitor = ShootingMonitor(problem, stability) if shooting else StabilityMonitor(problem, stability)
        events = stability_events(monitor, folds=not options.detect_folds)
        monitors = [monitor]
    # a shooting branch locates its grazing points and passes them (and its return to the branch of half its
    # period); a harmonic balance ends at them
    if shooting:
        return monitor, events + shooting_events(problem) + return_events(problem), monitors
    return monitor, events + grazing_events(problem), monitors


def _continue(problem, u0, lam0, lam_range, options, *, events=(), monitors=(), callback=None, checkpoint=None,
              **kw) -> Branch:
    """:func:`continuation`, a branch of twice the period ending where it returns to the branch it was born on
    (:func:`contin.bifurcation.shooting_branch.watch_return`)."""
    if not is_shooting(problem):
        return continuation(problem, u0, lam0, lam_range, options, events=events, monitors=monitors,
                            callback=callback, checkpoint=checkpoint, **kw)
    from contin.bifurcation.shooting_branch import finish_return, watch_return  # deferred: the time domain

    br = continuation(problem, u0, lam0, lam_range, options, events=events, monitors=monitors,
                      callback=watch_return(callback, events), checkpoint=checkpoint, **kw)
    finish_return(br, events, monitors, checkpoint)
    return br


def _resume(prev: Branch, problem, lam_range, options: ContinuationOptions, name: str, events, monitors, callback,
            checkpoint=None):
    """Take up a branch of an interrupted run (:func:`contin.output.checkpoint.rebuild_branches`).

    An unfinished branch goes on from the engine state of its last point, as
    it would have without the interruption (same options, events and
    monitors as when it was started); a finished one is returned as it is,
    its monitors given back their final states.
    """
    if prev.status is not BranchStatus.INTERRUPTED:
        for mon, st in zip(monitors, prev.info.get("monitor_states") or ()):
            if st is not None and hasattr(mon, "restore"):
                mon.restore(st)
        return prev
    state = prev.info.pop("restart", None)
    if state is None or not len(prev):
        raise ValueError("resume: a branch without the engine state of its last point")
    return _continue(problem, prev.unknowns[0], float(prev.parameter[0]), lam_range, options, parameter_name=name,
                     events=events, monitors=monitors, callback=callback, checkpoint=checkpoint,
                     restart=(prev, state))


def switch_branch(problem, branch: Branch, point: SpecialPoint, lam_range=None, options=None, *,
                  stability: StabilityOptions | None = None, eps: float | None = None,
                  sides: Sequence[int] | None = None, problem_factory: Callable | None = None,
                  pd_direction: str = "svd") -> list[tuple[Branch, Any]]:
    """Switch at one special point and trace the new branch(es).

    Returns
    -------
    list of (Branch, problem)
        ``branch.info["origin"]`` describes the special point. Sides whose
        first point falls outside ``lam_range`` are left out.
    """
    options = ContinuationOptions() if options is None else options
    stability = StabilityOptions() if stability is None else stability
    lam_range = branch.info.get("lam_range", (-math.inf, math.inf)) if lam_range is None else lam_range
    out = []
    su, sl = continuation_scales(branch, options, np.asarray(point.unknowns))
    for st in switch_at(problem, branch, point, options=options, eps=eps, sides=sides,
                        problem_factory=problem_factory, pd_direction=pd_direction):
        if not lam_range[0] <= st.lam <= lam_range[1]:
            continue  # the new branch leaves the range at once
        br, mon = _run(st, lam_range, options, stability, branch.parameter_name, su, sl)
        br.info["origin"] = _origin(point, None, st)
        if mon is not None:
            _record_stability(br, mon)
        _annotate_problem(br, st.problem)
        out.append((br, st.problem))
    return out


def _record_stability(br: Branch, mon) -> None:
    """Store the monitor's statistics; say in the branch message where the monodromy replaced Hill."""
    st = mon.statistics()
    br.info["stability"] = st
    replaced = mon.report(br)  # counts the branch's points (not the evaluations) and names the ranges
    if replaced:
        br.message = f"{br.message}; {replaced}"
    if st.get("unevaluated"):
        lam, why = st["unevaluated"][0]
        br.message = (f"{br.message}; no stability verdict at {len(st['unevaluated'])} point(s) (first at "
                      f"{br.parameter_name}={lam:.10g}: {why})")


def _origin(point: SpecialPoint, parent: int | None, st: BranchStart) -> dict:
    return {
        "kind": SpecialKind(st.kind).value,
        "parameter": float(point.parameter),
        "parent": parent,
        "special_point_index": point.index,
        "event": point.event,
        "side": st.side,
        "eps": st.eps,
        "first_point_parameter": st.lam,
        "located": bool(point.located),
        **({"note": _from_bracket(point)} if not point.located else {}),
    }


def _annotate_problem(br: Branch, problem) -> None:
    if is_shooting(problem):
        br.info.update(subharmonic=int(problem.options.subharmonic), method="shooting")
    for attr, key in (("nu", "subharmonic"), ("H", "harmonics"), ("N", "samples")):
        if hasattr(problem, attr):
            br.info[key] = int(getattr(problem, attr))


@dataclasses.dataclass
class BifurcationDiagram:
    """Branches traced by :func:`follow`, with their parentage.

    Attributes
    ----------
    branches : list of Branch
        ``branches[0]`` is the first branch.
    problems : list
        The problem of each branch (its ``nu`` and ``H`` interpret the
        unknowns).
    parents : list of int or None
        Index of the parent branch (None for the first).
    origins : list of SpecialPoint or None
        The parent's special point each branch starts from.
    monitors : list of StabilityMonitor or None
    failed_switches : list of dict
        Sides of a switch whose first point could not be found: ``parent``,
        ``kind``, ``parameter``, ``side`` and ``message``.
    """

    branches: list = dataclasses.field(default_factory=list)
    problems: list = dataclasses.field(default_factory=list)
    parents: list = dataclasses.field(default_factory=list)
    origins: list = dataclasses.field(default_factory=list)
    monitors: list = dataclasses.field(default_factory=list)
    failed_switches: list = dataclasses.field(default_factory=list)

    def add(self, child: Branch, start: BranchStart, parent: int, point: SpecialPoint, monitor, depth: int) -> None:
        """Append a branch switched onto at ``point`` of branch ``parent`` from ``start``."""
        child.info.update(parent=parent, origin=_origin(point, parent, start), depth=depth)
        _annotate_problem(child, start.problem)
        self.branches.append(child)
        self.problems.append(start.problem)
        self.parents.append(parent)
        self.origins.append(point)
        self.monitors.append(monitor)

    def __len__(self) -> int:
        return len(self.branches)

    def __iter__(self):
        return iter(self.branches)

    def __getitem__(self, i) -> Branch:
        return self.branches[i]

    def children(self, i: int) -> list[int]:
        """Indices of the branches switched from branch ``i``."""
        return [j for j, p in enumerate(self.parents) if p == i]

    def summary(self) -> str:
        lines = []
        for i, br in enumerate(self.branches):
            org = br.info.get("origin")
            head = f"[{i}] nu={br.info.get('subharmonic', '?')} H={br.info.get('harmonics', '?')}"
            if org:
                head += f" from {org['kind']} of [{org['parent']}] at {br.parameter_name}={org['parameter']:.10g}"
            lines.append(head)
            lines.extend("    " + line for line in br.summary().splitlines())
        return "\n".join(lines)


def _switch_candidates(br: Branch, kinds: set, origin_lam: float | None, tol: float) -> list[SpecialPoint]:
    """Special points to switch at, one per bifurcation.

    The engine's determinant test and the ``+1`` multiplier event report the
    same branch point; they are merged by kind and bracketing interval,
    keeping the determinant one: it is located exactly, whereas the
    multiplier count is biased by ``tolerance / |d|mu|/dlam|``. A located
    report is preferred to an unlocated one; a bifurcation that no test
    located is still switched at, from the best point of its final bracket
    (a converged solution; :func:`_origin` records that it was not located).
    """
    chosen: dict[tuple, SpecialPoint] = {}
    # a shooting branch's return to its parent is no new branch (its module loaded: no such point otherwise)
    module = sys.modules.get("contin.bifurcation.shooting_branch")
    returned = module.ReturnEvent.name if module is not None else None
    for sp in br.special_points:
        kind = _kind(sp)
        if kind.value not in kinds or (returned is not None and sp.event == returned):
            continue
        scale = tol * max(1.0, abs(sp.parameter))
        if origin_lam is not None and abs(sp.parameter - origin_lam) <= 1e3 * scale and sp.index <= 1:
            continue  # the bifurcation the branch starts from
        key = (kind, sp.index)
        old = chosen.get(key)
        if old is None or (sp.located and not old.located) or (
                sp.located == old.located and kind is SpecialKind.BP and not sp.event.startswith("stability")):
            chosen[key] = sp
    return sorted(chosen.values(), key=lambda p: (p.s, p.index))


def _from_bracket(sp: SpecialPoint) -> str:
    """What a switch at an unlocated point says of where it started ("" at a located point)."""
    if sp.located:
        return ""
    lo, hi = sp.bracket
    return f"switched from the bracket [{lo:.10g}, {hi:.10g}], the point not located ({sp.message})"


def _kind(sp: SpecialPoint) -> SpecialKind:
    if sp.kind is SpecialKind.STABILITY:
        return SpecialKind(sp.data.get("classification", "stability"))
    return sp.kind


def _torus_child(prob, br: Branch, sp: SpecialPoint, torus: TorusSettings | None, options, diagram, parent: int):
    """The first point of the torus branch at ``sp``, or None (the failure recorded in the diagram)."""
    settings = torus or TorusSettings()
    try:
        st = torus_start(prob, br, sp, settings.torus_options(prob.H), tol=options.newton_tol)
        why = "Newton failed for the self-excited amplitude halved four times"
    except (ValueError, np.linalg.LinAlgError) as exc:
        st, why = None, str(exc)
    if st is None:
        diagram.failed_switches.append({"parent": parent, "kind": "ns", "parameter": float(sp.parameter), "side": 1,
                                        "message": f"no first point of the torus branch: {why}"
                                                   + (f" ({_from_bracket(sp)})" if not sp.located else "")})
    return st


def _circle_child(prob, sp: SpecialPoint, torus: TorusSettings | None, diagram, parent: int):
    """The first circle of the torus at a shooting branch's Neimark-Sacker point ``sp``, or None (the failure
    recorded in the diagram)."""
    from contin.bifurcation.circle_branch import circle_child_start  # deferred: the time domain

    try:
        return circle_child_start(prob, sp.parameter, sp.unknowns, (torus or TorusSettings()).points)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        where = _from_bracket(sp)
        diagram.failed_switches.append({"parent": parent, "kind": "ns", "parameter": float(sp.parameter), "side": 1,
                                        "message": f"no first circle of the torus: {exc}"
                                                   + (f" ({where})" if where else "")})
        return None


def _run_circle(st, lam_range, options, name: str, settings: TorusSettings, callback, checkpoint, previous):
    """The circle branch from ``st``, or the same branch of an interrupted run taken up (``previous``)."""
    from contin.bifurcation.circle_run import run_circle  # deferred: the time domain

    resume = None if previous is None else (
        lambda problem, opts, mons, watch: _resume(previous, problem, lam_range, opts, name, [], mons, watch,
                                                   checkpoint))
    return run_circle(st, lam_range, options, name, stability=settings.stability != "none", callback=callback,
                      checkpoint=checkpoint, resume=resume, natural=settings.continuation == TorusContinuation.NATURAL,
                      previous=previous)


def _locked_children(diagram, j: int, lam_range, options, stability, name: str, cb_for, ck_for, previous,
                     max_branches: int) -> bool:
    """At the locking end of circle branch ``j``: the branches of its periodic orbits of ``q`` forcing periods
    (:func:`contin.bifurcation.circle_branch.locked_starts`), or the failure recorded; False where
    ``max_branches`` is reached."""
    from contin.bifurcation.circle_branch import locked_starts  # deferred: the time domain

    br, circle = diagram.branches[j], diagram.problems[j]
    lock = next((sp for sp in br.special_points if sp.kind is SpecialKind.LOCKING), None)
    if lock is None:
        return True
    try:
        found = locked_starts(circle, br)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        found, why = [], str(exc)
    else:
        why = "no periodic orbit of the locking's period found from the circle's points"
    if not found:
        diagram.failed_switches.append({"parent": j, "kind": "locking", "parameter": float(lock.parameter), "side": 1,
                                        "message": why})
    for st in found:
        if len(diagram) >= max_branches:
            return False
        if not lam_range[0] <= st.lam <= lam_range[1]:
            continue
        br.info["end"] = "locking"  # the torus goes on as its locked orbits' branches: an end as asked
        k = len(diagram)
        su, sl = continuation_scales(None, options, st.u)
        child, mon = _run(st, lam_range, _orbit_options(options, st.problem), stability, name, su, sl,
                          cb_for(k, st.problem), ck_for(k, st.problem), previous.get(k))
        if mon is not None:
            _record_stability(child, mon)
        diagram.add(child, st, j, lock, mon, br.info.get("depth", 1) + 1)
    return True


def _orbit_options(options: ContinuationOptions, problem) -> ContinuationOptions:
    """The continuation options of a locked torus's orbit branch: the torus's, whose ``ds_min`` ends the steps of
    circles, with the engine's ``ds_min`` and, for a model with contacts, the step limits through grazing
    corners (:func:`~contin.bifurcation.grazing_steps.through_grazing`)."""
    opts = options.replace(ds_min=min(options.ds_min, ContinuationOptions().ds_min))
    return through_grazing(opts) if getattr(problem, "n_switch", 0) else opts


def _shooting_pd(prob, sp: SpecialPoint, failed: list) -> list:
    """The one first point of the doubled branch at a shooting branch's period doubling (its two sides are one
    orbit shifted by a forcing period), or none with the reason in ``failed``."""
    from contin.bifurcation.shooting_branch import shooting_pd_start  # deferred: the time domain

    try:
        return [shooting_pd_start(prob, sp)]
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        failed.append({"kind": "pd", "parameter": float(sp.parameter), "side": 1, "message": str(exc)})
        return []


def follow(problem, u0, lam0: float, lam_range, options: ContinuationOptions | dict | None = None, *,
           stability: StabilityOptions | dict | None = None, switch: Sequence[str] = ("pd", "bp"),
           max_depth: int = 1, parameter_name: str | None = None, problem_factory: Callable | None = None,
           eps: float | None = None, max_branches: int = 16, pd_direction: str = "svd",
           callback: Callable | None = None, callback_factory: Callable | None = None,
           checkpoint_factory: Callable | None = None, previous: dict | None = None,
           torus: TorusSettings | None = None) -> BifurcationDiagram:
    """Trace a branch with stability, then switch automatically at its bifurcations.

    Parameters
    ----------
    problem : HarmonicBalance
        Problem of the first branch (any engine problem if ``switch``
        contains only ``"bp"``).
    u0 : ndarray, shape (m,)
        Start guess.
    lam0 : float
    lam_range : (float, float)
        Range of every branch.
    options : ContinuationOptions or dict, optional
    stability : StabilityOptions or dict, optional
        Method ``none`` disables stability (then only the engine's ``bp``
        points can be switched at).
    switch : sequence of {'pd', 'bp', 'ns'}
        Kinds of special points to switch at (``ns``: a quasi-periodic
        branch, :mod:`contin.bifurcation.torus_branch`).
    max_depth : int
        Switching generations (1: the first branch's bifurcations only).
    parameter_name : str, optional
        Default: the problem's ``parameter`` attribute.
    problem_factory : callable, optional
        ``problem_factory(problem, factor)`` -> problem of order ``factor*nu``.
    eps : float, optional
        Offset of first points (see :func:`switch_at`).
    max_branches : int
        Stop after this many branches.
    pd_direction : {'svd', 'hill'}
    callback : callable, optional
        Passed to the engine for every branch.
    callback_factory : callable, optional
        ``callback_factory(index, problem) -> callback`` gives each branch its
        own engine callback (for example to record rows with the branch id
        and its order nu); it overrides ``callback``.
    checkpoint_factory : callable, optional
        ``checkpoint_factory(index, problem) -> checkpoint``: each branch's
        engine ``checkpoint`` (see :func:`contin.engine.continuation.continuation`),
        what ``previous`` is rebuilt from.
    previous : dict of int to Branch, optional
        Branches of an earlier, interrupted run of the same diagram, by index
        (see :mod:`contin.output.checkpoint`). A finished one is reused as it is; an
        unfinished one is continued from its last point with its own scales,
        and its callback is not called again for that point.
    torus : TorusSettings, optional
        Discretisation, stability check and ends of the torus branches.

    Returns
    -------
    BifurcationDiagram
        Each branch's ``info`` holds ``parent`` (index or None), ``origin``
        (dict: kind, parameter, parent, event, side, eps), ``depth``,
        ``subharmonic``, ``harmonics``, and ``stability`` (monitor
        statistics).
    """
    if options is None:
        options = ContinuationOptions()
    elif isinstance(options, dict):
        options = ContinuationOptions.from_dict(options)
    if stability is None:
        stability = StabilityOptions()
    elif isinstance(stability, dict):
        stability = StabilityOptions.from_dict(stability)
    kinds = set()
    for k in switch:
        k = SpecialKind(k).value
        if k not in ("pd", "bp", "ns"):
            raise ValueError(f"follow: can switch at 'pd', 'bp' and 'ns' points, not {k!r}")
        kinds.add(k)
    if isinstance(max_depth, bool) or not isinstance(max_depth, int) or max_depth < 0:
        raise ValueError(f"follow: max_depth must be an integer >= 0, got {max_depth!r}")
    name = parameter_name or getattr(problem, "parameter", "lambda")
    lam_range = tuple(float(v) for v in lam_range)
    diagram = BifurcationDiagram()

    # the first branch
    monitor, events, monitors = (None, [], []) if is_circle(problem) else _stability(problem, stability, options)

    def cb_for(index, prob):
        return callback_factory(index, prob) if callback_factory is not None else callback

    def ck_for(index, prob):
        return None if checkpoint_factory is None else checkpoint_factory(index, prob)

    previous = previous or {}
    if is_circle(problem):  # a torus from a start (an invariant circle): no switching from it but at its locking
        from contin.bifurcation.circle_branch import CircleStart  # deferred: the time domain

        st = CircleStart(problem, np.asarray(u0, dtype=float), float(lam0), None, kind="start", solve_start=True)
        root = _run_circle(st, lam_range, options, name, torus or TorusSettings(), cb_for(0, problem),
                           ck_for(0, problem), previous.get(0))
        root.info.update(parent=None, origin=None, depth=0)
        diagram.branches.append(root)
        diagram.problems.append(problem)
        diagram.parents.append(None)
        diagram.origins.append(None)
        diagram.monitors.append(None)
        _locked_children(diagram, 0, lam_range, options, stability, name, cb_for, ck_for, previous, max_branches)
        return diagram
    if 0 in previous:
        root = _resume(previous[0], problem, lam_range, options, name, events, monitors, cb_for(0, problem),
                       ck_for(0, problem))
    else:
        root = _continue(problem, u0, lam0, lam_range, options, parameter_name=name, events=events,
                         monitors=monitors, callback=cb_for(0, problem), checkpoint=ck_for(0, problem))
    root.info.update(parent=None, origin=None, depth=0)
    if monitor is not None:
        _record_stability(root, monitor)
    _annotate_problem(root, problem)
    diagram.branches.append(root)
    diagram.problems.append(problem)
    diagram.parents.append(None)
    diagram.origins.append(None)
    diagram.monitors.append(monitor)

    queue = [0]
    while queue:
        i = queue.pop(0)
        br, prob = diagram.branches[i], diagram.problems[i]
        if br.status is BranchStatus.INTERRUPTED:
            return diagram  # the user asked to stop: no new branches
        depth = br.info.get("depth", 0)
        if depth >= max_depth or not len(br):
            continue
        org = br.info.get("origin")
        origin_lam = org["first_point_parameter"] if org else None
        su, sl = continuation_scales(br, options, br.unknowns[0])
        if br.info.get("torus") is not None:
            continue  # no switching from a torus
        for sp in _switch_candidates(br, kinds, origin_lam, options.locate_tol):
            if _kind(sp) is SpecialKind.NS:
                if len(diagram) >= max_branches:
                    return diagram
                j = len(diagram)
                if is_shooting(prob):  # the torus as an invariant circle of the stroboscopic map
                    st = _circle_child(prob, sp, torus, diagram, i)
                    if st is None or not lam_range[0] <= st.lam <= lam_range[1]:
                        continue
                    child = _run_circle(st, lam_range, options, name, torus or TorusSettings(), cb_for(j, st.problem),
                                        ck_for(j, st.problem), previous.get(j))
                    diagram.add(child, st, i, sp, None, depth + 1)
                    if not _locked_children(diagram, j, lam_range, options, stability, name, cb_for, ck_for, previous,
                                            max_branches):
                        return diagram
                    continue
                st = _torus_child(prob, br, sp, torus, options, diagram, i)
                if st is None or not lam_range[0] <= st.lam <= lam_range[1]:
                    continue
                # the same torus branch of an interrupted run is taken up, not traced anew
                resume = None if j not in previous else (
                    lambda qp, opts, mons, prev=previous[j], j=j:
                    _resume(prev, qp, lam_range, opts, name, [], mons, cb_for(j, qp), ck_for(j, qp)))
                child = run_torus(st, lam_range, options, name, torus or TorusSettings(), cb_for(j, st.problem),
                                  ck_for(j, st.problem), resume)
                diagram.add(child, st, i, sp, None, depth + 1)
                continue
            failed: list = []
            if _kind(sp) is SpecialKind.PD and is_shooting(prob):
                found = _shooting_pd(prob, sp, failed)
            elif sp.kind is SpecialKind.PD and not hasattr(prob, "with_options") and problem_factory is None:
                continue
            else:
                found = switch_at(prob, br, sp, options=options, eps=eps, problem_factory=problem_factory,
                                  pd_direction=pd_direction, failures=failed)
            where = _from_bracket(sp)
            diagram.failed_switches.extend({"parent": i, **f, **({"message": f"{f['message']} ({where})"}
                                                                  if where else {})} for f in failed)
            for st in found:
                if len(diagram) >= max_branches:
                    return diagram
                if not lam_range[0] <= st.lam <= lam_range[1]:
                    continue  # the new branch leaves the range at once
                j = len(diagram)
                child, mon = _run(st, lam_range, options, stability, name, su, sl, cb_for(j, st.problem),
                                  ck_for(j, st.problem), previous.get(j))
                if mon is not None:
                    _record_stability(child, mon)
                diagram.add(child, st, i, sp, mon, depth + 1)
                queue.append(j)
    return diagram
