"""The ``auto`` method of ``frequency_response``: a harmonic-balance branch handed to shooting at a grazing point.

Harmonic balance truncates a contact force whose derivative jumps, and its
branch stops (status ``boundary``) at the point where a contact arc appears or
vanishes. The equations of motion integrated with located switches have no
such wall: the branch is handed over to shooting
(:class:`contin.timedomain.shooting.ShootingProblem`) from a stored point a
few steps before the grazing point it could not pass, where the harmonic-balance
orbit and the flow's agree (:func:`handover_start`), and continued in the
direction the branch ran there, through the grazing point. In the outputs the
shooting part is the next branch, with
``handed_over_from`` in ``summary.json``; the harmonic-balance branch says
``handed_over_to`` and ``end: handover`` (its end is then no shortfall: the
shooting branch's end decides).
"""

from __future__ import annotations

import numpy as np

from contin.analyses.shooting_rows import is_shooting, shooting_problem, unknowns_from_state
from contin.analyses.side_by_side import interrupted, run_threads, side_by_side
from contin.bifurcation.end_check import barrier_point
from contin.bifurcation.grazing_steps import through_grazing
from contin.engine.branch import BranchStatus
from contin.scene.sweep_plan import runs_from_start
from contin.stability import orbit_state
from contin.util.workers import threads

__all__ = ["HANDOVER_AGREEMENT", "HANDOVER_BACK", "boundary_gap", "follow_and_hand_over", "follow_jobs", "hand_over",
           "handover_start", "shooting_options"]


def _direction(branch) -> int:
    """The branch's running direction in the parameter at its last point: from its last two points (the
    stored tangent of a point located at a barrier need not be oriented along the run), else its tangent."""
    lam = np.asarray(branch.parameter, dtype=float)
    if lam.size >= 2 and lam[-1] != lam[-2]:
        return 1 if lam[-1] > lam[-2] else -1
    t = np.asarray(branch.tangents[-1], dtype=float)
    return -1 if t.size and t[-1] < 0.0 else 1


def _job(i: int, br, meta: dict, prob, setup, ctx):
    """What hands branch ``i`` over: ``(i, meta, shooting problem, u0, lam, options)``; None for a branch that
    is not a harmonic-balance branch ended at a point it cannot pass, or that no start was found for (said in
    ``meta``)."""
    if (br.status is not BranchStatus.BOUNDARY or not len(br) or prob is None or is_shooting(prob)
            or meta.get("torus") is not None or ctx.stop_requested):
        return None
    hb = prob.full  # the periodic-problem protocol (contin.model.periodic)
    at = barrier_point(br)
    sp = shooting_problem(hb, setup.shooting, meta.get("nu", hb.nu))
    start = handover_start(sp, br, prob, at[0].index if at is not None else len(br) - 1,
                           at[1] if at is not None else _direction(br))
    if start is None:
        meta["handover_failed"] = ("no point of the harmonic-balance branch before its grazing point gave a "
                                   "shooting orbit within the truncation's reach (the flow integrated at "
                                   f"{sp.options.steps_per_period} steps a period: a stiff contact may need "
                                   "more, analysis.shooting.steps_per_period)")
        return None
    u0, lam, direction = start
    return i, meta, sp, u0, lam, shooting_options(setup, direction)


def shooting_options(setup, direction: int):
    """The start's continuation options for a shooting branch that goes on from another branch the way
    ``direction``: through grazing corners (:func:`~contin.bifurcation.grazing_steps.through_grazing`), a
    scale per unknown dropped (the unknowns are states now)."""
    su = setup.options.unknown_scale
    return through_grazing(setup.options.replace(direction=direction,
                                                 unknown_scale=su if su is None or np.ndim(su) == 0 else None))


def _follow_job(job, setup, lam_range, previous: dict, first_id: int):
    """``call(recorder, ctx)``: the shooting branch of ``job`` (:func:`_job`), as branch ``first_id``."""
    _, _, sp, u0, lam, opts = job
    return lambda recorder, context: setup.follow(sp, u0, lam, lam_range, opts, recorder, context, previous,
                                                  first_id=first_id, both_ways=False)


def _attach(out: list, job, new) -> None:
    """Append the shooting branches ``new`` of ``job`` to ``out``, each side saying where it was handed over."""
    if not new:
        return
    i, meta, _, _, lam, _ = job
    meta.update(handed_over_to=len(out), end="handover")
    new[0][1]["handed_over_from"] = i
    new[0][1]["origin"] = {"kind": "handover", "parameter": lam, "located": True,
                           "note": "harmonic balance could not pass the grazing point; continued by shooting"}
    out += new


def hand_over(results: list, first: int, setup, rec, ctx, previous: dict, lam_range) -> list:
    """Hand every ``boundary`` harmonic-balance branch from ``first`` on to shooting; the results with theirs.

    The shooting branches run side by side (:mod:`contin.analyses.side_by_side`) unless the start switches
    (then how many branches each gives is known only at its end, and so are the ids of the next).

    Parameters
    ----------
    results : list of (Branch, dict)
        The run's branches by id (those of the start being run from ``first``).
    setup : StartSetup
        The start (its shooting settings, options and branch-following function).
    rec : BranchRecorder
    ctx : run context
    previous : dict
        Branches of an interrupted run by id (a handed-over branch is taken up as any other).
    lam_range : (float, float)
    """
    out = list(results)
    jobs = [job for i in range(first, len(results))
            if (job := _job(i, *results[i], rec.problems.get(i), setup, ctx)) is not None]
    if not jobs or ctx.stop_requested:
        return out
    for job, new in zip(jobs, follow_jobs(jobs, len(out), setup, rec, ctx, previous, lam_range)):
        _attach(out, job, new)
    return out


def follow_jobs(jobs: list, first_id: int, setup, rec, ctx, previous: dict, lam_range) -> list:
    """The shooting branches of ``jobs`` (``(i, meta, problem, u0, lam, options)`` each), numbered from
    ``first_id``: side by side (:mod:`contin.analyses.side_by_side`) unless the start switches (then how many
    branches each gives is known only at its end, and so are the ids of the next). A list of their results."""
    if setup.scene.analysis["switch"]:
        news = []
        for job in jobs:
            news.append(_follow_job(job, setup, lam_range, previous, first_id + sum(len(n) for n in news))(rec, ctx))
            if ctx.stop_requested or interrupted(news[-1]):
                break
        return news
    ids = [first_id + k for k in range(len(jobs))]  # one branch each: their ids are known before they run
    return side_by_side([_follow_job(job, setup, lam_range, previous, j) for job, j in zip(jobs, ids)], rec, ctx,
                        "branches " + ", ".join(str(j) for j in ids))


def follow_and_hand_over(setup, problem, u0, lam0: float, lam_range, rec, ctx, first: int) -> list | None:
    """Both directions of an ``auto`` start side by side, each handed over to shooting as soon as it ends at a
    point harmonic balance cannot pass: the branches :func:`hand_over` would add to those of the start's
    ``follow``, with the same ids and in the same order (its harmonic-balance branches, then the shooting
    branches in their order). None where they would not run side by side: one thread, a start followed one
    way, a start that switches, or one taken up from a checkpoint (all run one after the other then).

    In a thread a shooting branch's id is not known until the other direction's harmonic-balance branch has
    ended (it may not hand over), so each direction records its shooting branch under the id it gets when
    both hand over; the records are renumbered as they are written. An exception raised in a thread is
    raised once both have ended, before anything of theirs is written.
    """
    runs = runs_from_start(setup.options, setup.scene.analysis["both_ways"], lam0, lam_range)
    if len(runs) < 2 or threads() < 2 or setup.scene.analysis["switch"]:
        return None
    n = len(runs)
    # a problem keeps work arrays: each thread its own (the same numbers)
    problems = [problem] + [problem.with_options() for _ in range(n - 1)]

    def chain(d):
        def call(recorder, context):
            part = setup.follow(problems[d], u0, lam0, lam_range, runs[d], recorder, context, {},
                                first_id=first + d, both_ways=False)
            # without switching, one branch (:func:`contin.analyses.stability_hooks.stability_setup`)
            if not part or context.stop_requested or interrupted(part):
                return part, None, None
            job = _job(first + d, *part[0], recorder.problems.get(first + d), setup, context)
            if job is None:
                return part, None, None
            return part, job, _follow_job(job, setup, lam_range, {}, first + n + d)(recorder, context)

        return call

    chains = run_threads([chain(d) for d in range(n)], rec, ctx,
                         f"branches {first}-{first + 2 * n - 1}")
    for _, _, exc in chains:
        if exc is not None:
            raise exc
    out: list = []
    # written in the order one after the other would have: the harmonic-balance branches, then the shooting ones
    for d, (log, (part, _, _), _) in enumerate(chains):
        log.replay(rec, first + d)
        out += part
        if interrupted(part):
            return out
    results = [None] * first + out  # ids as in the run
    for d, (log, (_, job, new), _) in enumerate(chains):
        if job is None or new is None:
            continue
        log.replay(rec, first + n + d, len(results))
        _attach(results, job, new)
        if interrupted(new):
            break
    return results[first:]


#: how many stored points before the grazing point a handover tries, nearest first
HANDOVER_BACK = (2, 4, 8, 16, 32)
#: the shooting orbit corrected at a harmonic-balance point must lie this close to it (relative to the orbit)
HANDOVER_AGREEMENT = 5e-2


def _corrected(sp, u, lam: float, tol: float = 1e-10, max_iter: int = 12):
    """Newton at fixed ``lam`` on the shooting residual from ``u``; the solution, or None."""
    for _ in range(max_iter + 1):
        try:
            r, Ju, _ = sp.linearize(u, lam)
        except ArithmeticError:
            return None
        if not np.all(np.isfinite(r)):
            return None
        if float(np.max(np.abs(r))) <= tol * max(1.0, float(np.max(np.abs(u)))):
            return u
        try:
            u = u - np.linalg.solve(Ju, r)
        except np.linalg.LinAlgError:
            return None
    return None


def handover_start(sp, br, prob, index: int, direction: int):
    """Where shooting takes a harmonic-balance branch over: ``(u0, lam, direction)``, or None.

    At the grazing point itself the truncated series is at its worst, and the shooting orbit corrected from it
    can be another orbit of the flow at the same ``lam`` (beside a fold, another sheet of the response): a
    silent jump. The handover therefore starts a few stored points before it, where the harmonic-balance orbit
    and the orbit of the integrated flow agree to :data:`HANDOVER_AGREEMENT` (relative to the orbit's largest
    state), nearest first, and runs in the direction the branch ran there; the shooting branch then passes the
    grazing point itself (located as a ``grazing`` special point of its own).
    """
    hb = prob.full
    for back in HANDOVER_BACK:
        j = index - back
        if j < 0:
            break
        lam = float(br.parameter[j])
        c = prob.expand(br.unknowns[j], lam) if prob.condensed else np.asarray(br.unknowns[j])
        z = np.asarray(orbit_state(hb, c, lam, 0.0), dtype=float)
        try:
            u0 = unknowns_from_state(sp, z, lam)
        except ArithmeticError:
            continue
        u = _corrected(sp, u0, lam)
        if u is None:
            continue
        if float(np.max(np.abs(u[:z.size] - z))) > HANDOVER_AGREEMENT * max(1e-12, float(np.max(np.abs(z)))):
            continue
        nxt = float(br.parameter[j + 1])
        run = direction if nxt == lam else (1 if nxt > lam else -1)
        return u, lam, run
    return None


def boundary_gap(branch, lam_range) -> list | None:
    """The interval a ``boundary`` branch left uncovered: from its last point to the end of ``lam_range`` it was
    running towards (None for any other end, or nothing left). A branch that turned at a fold covered that
    interval on another of its parts, not on the part that stopped."""
    if branch.status is not BranchStatus.BOUNDARY or not len(branch):
        return None
    lo, hi = (float(v) for v in lam_range)
    last = float(branch.parameter[-1])
    gap = [last, hi] if _direction(branch) > 0 else [lo, last]
    return gap if gap[1] > gap[0] else None
