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
from contin.bifurcation.end_check import barrier_point
from contin.bifurcation.grazing_steps import through_grazing
from contin.engine.branch import BranchStatus
from contin.stability import orbit_state

__all__ = ["HANDOVER_AGREEMENT", "HANDOVER_BACK", "boundary_gap", "hand_over", "handover_start"]


def _direction(branch) -> int:
    """The branch's running direction in the parameter at its last point: from its last two points (the
    stored tangent of a point located at a barrier need not be oriented along the run), else its tangent."""
    lam = np.asarray(branch.parameter, dtype=float)
    if lam.size >= 2 and lam[-1] != lam[-2]:
        return 1 if lam[-1] > lam[-2] else -1
    t = np.asarray(branch.tangents[-1], dtype=float)
    return -1 if t.size and t[-1] < 0.0 else 1


def hand_over(results: list, first: int, setup, rec, ctx, previous: dict, lam_range) -> list:
    """Hand every ``boundary`` harmonic-balance branch from ``first`` on to shooting; the results with theirs.

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
    i = first
    while i < len(out):
        br, meta = out[i]
        prob = rec.problems.get(i)
        i += 1
        if (br.status is not BranchStatus.BOUNDARY or not len(br) or prob is None or is_shooting(prob)
                or meta.get("torus") is not None or ctx.stop_requested):
            continue
        hb = prob.full  # the periodic-problem protocol (contin.model.periodic)
        at = barrier_point(br)
        sp = shooting_problem(hb, setup.shooting, meta.get("nu", hb.nu))
        start = handover_start(sp, br, prob, at[0].index if at is not None else len(br) - 1,
                               at[1] if at is not None else _direction(br))
        if start is None:
            meta["handover_failed"] = ("no point of the harmonic-balance branch before its grazing point gave a "
                                       "shooting orbit within the truncation's reach")
            continue
        u0, lam, direction = start
        su = setup.options.unknown_scale
        opts = through_grazing(setup.options.replace(direction=direction,
                                                     unknown_scale=su if su is None or np.ndim(su) == 0 else None))
        j = len(out)
        new = setup.follow(sp, u0, lam, lam_range, opts, rec, ctx, previous, first_id=j, both_ways=False)
        if not new:
            continue
        meta.update(handed_over_to=j, end="handover")
        new[0][1]["handed_over_from"] = i - 1
        new[0][1]["origin"] = {"kind": "handover", "parameter": lam, "located": True,
                               "note": "harmonic balance could not pass the grazing point; continued by shooting"}
        out += new
        if ctx.stop_requested or any(b.status == BranchStatus.INTERRUPTED for b, _ in new):
            break
    return out


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
