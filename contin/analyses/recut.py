"""A shooting branch that crawls, continued with its orbits cut at another section.

A shooting branch is a curve of its orbits' states at the section ``t0``
(``ShootingOptions.start_step``; docs/theory/events.md, where a shooting
branch is cut). Where ``t0`` falls in a bounce of a stiff contact, a small
change of the orbit slides the bounce across ``t0`` and the steps crawl,
while the same orbits cut elsewhere pass; no section suits every branch, and
which one suits a branch is known only along it. So a shooting branch that
ends ``step_too_small`` is continued from its last point, its orbit cut at
its quiet section (:func:`contin.timedomain.shooting_section.quiet_step`:
farthest in time from every switch), the way it ran there. In the outputs
the continuation is the next branch, with ``recut_from`` in ``summary.json``;
the branch that crawled says ``recut_to`` and ``end: recut`` (no shortfall:
the continuation's end decides). At most :data:`RECUTS` in a row.
"""

from __future__ import annotations

import numpy as np

from contin.analyses.handover import follow_jobs, shooting_options
from contin.analyses.side_by_side import interrupted
from contin.engine.branch import BranchStatus
from contin.model.periodic import is_shooting

__all__ = ["RECUTS", "recut"]

#: continuations of one chain of crawling branches at most (each at the quiet section of its last orbit)
RECUTS = 2


def _job(i: int, br, meta: dict, prob, setup, ctx):
    """What continues branch ``i`` at another section: ``(i, meta, problem, u0, lam, options)``; None for a
    branch that did not crawl, is no shooting branch, or whose orbit's quiet section is the one it has."""
    if (br.status is not BranchStatus.STEP_TOO_SMALL or not len(br) or prob is None or not is_shooting(prob)
            or meta.get("torus") is not None or ctx.stop_requested or meta.get("recuts", 0) >= RECUTS):
        return None
    from contin.timedomain.shooting_section import at_quiet_section  # deferred: the time domain, shooting only

    lam = float(br.parameter[-1])
    try:
        cut, u0 = at_quiet_section(prob, np.asarray(br.unknowns[-1], dtype=float), lam)
    except ArithmeticError:
        return None
    if cut is prob:
        return None
    # the way the branch ran at its last point (its tangent's parameter component; a crawl's points zigzag)
    t = float(np.asarray(br.tangents[-1], dtype=float)[-1])
    lam_prev = float(br.parameter[-2]) if len(br) > 1 else lam
    direction = (1 if t > 0 else -1) if t != 0.0 else (1 if lam >= lam_prev else -1)
    return i, meta, cut, u0, lam, shooting_options(setup, direction)


def recut(results: list, first: int, setup, rec, ctx, previous: dict, lam_range) -> list:
    """Continue every shooting branch from ``first`` on that crawled at another section (module docstring); the
    results with the continuations appended, each after the branches before it.

    Parameters
    ----------
    results : list of (Branch, dict)
        The run's branches by id.
    first : int
        The first branch of the start being run.
    setup : StartSetup
    rec : BranchRecorder
    ctx : run context
    previous : dict
        Branches of an interrupted run by id (a continuation is taken up as any other).
    lam_range : (float, float)
    """
    out = list(results)
    todo = range(first, len(out))
    while not ctx.stop_requested:
        jobs = [job for i in todo if (job := _job(i, *out[i], rec.problems.get(i), setup, ctx)) is not None]
        if not jobs:
            break
        news = follow_jobs(jobs, len(out), setup, rec, ctx, previous, lam_range)
        start = len(out)
        for (i, meta, cut, _, lam, _), new in zip(jobs, news):
            if not new:
                continue
            meta.update(recut_to=len(out), end="recut")
            new[0][1].update(recut_from=i, recuts=meta.get("recuts", 0) + 1)
            new[0][1]["origin"] = {"kind": "recut", "parameter": lam, "located": True,
                                   "note": f"the branch crawled; continued with its orbits cut at step "
                                           f"{cut.options.start_step} of {cut.options.steps_per_period} a period"}
            out += new
            if interrupted(new):
                return out
        todo = range(start, len(out))
    return out
