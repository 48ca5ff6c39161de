"""The engine's resumable state: where the branch is, and what the next step starts from.

:class:`Position` holds the branch's last stored point (scaled point,
tangent, arclength, the events' tests) and the references the next steps
compare against (the previous point, the start). :func:`save` gathers,
after each stored point, everything the main loop carries to the next step
(the position, the step control and its rule's own state, the scales, the corner and barrier
bookkeeping, the counters and the monitors' states); with the branch's
points it is all :func:`restore` needs to go on exactly as the interrupted
run would have: the continuation's ``checkpoint`` and ``restart``
(:func:`contin.engine.continuation.continuation`).

A state is JSON-able except for numpy arrays
(:func:`contin.output.checkpoint.encode`); its keys are
:data:`RESTART_KEYS`.
"""

from __future__ import annotations

import collections
import dataclasses
from typing import Any, Mapping

import numpy as np

from contin.engine.barriers import Barrier
from contin.engine.branch import Branch, BranchStatus
from contin.engine.events import PointInfo
from contin.engine.newton import factorize
from contin.engine.problem import ScaledProblem, bordered_matrix, point_info

__all__ = ["RESTART_KEYS", "STATE_ARRAYS", "STATE_SCALARS", "Position", "restore", "save"]

#: the engine's values a state holds as they are: arrays, and plain values (see :func:`save`)
STATE_ARRAYS = ("x", "t", "t_prev", "prev_x", "x_start", "t_start", "groups")
STATE_SCALARS = ("s", "jac_norm_start", "max_dist", "n_rejected", "n_newton", "n_backtracked", "adaptive_scale",
                 "min_rcond", "min_rcond_index", "last_rcond", "last_failure", "event_cap", "ds_free", "barrier_tried")
#: every key of an engine state (what a ``restart`` reads)
RESTART_KEYS = ("points", "ds", "recent", "turns", "su", "sl", "calls", "rescalings", "tests", "monitors",
                "barrier", "step_control") + STATE_ARRAYS + STATE_SCALARS

#: the part of the engine holding each value of STATE_ARRAYS and STATE_SCALARS (None: the engine itself)
HOLDER = {
    "x": "pos", "t": "pos", "t_prev": "pos", "prev_x": "pos", "x_start": "pos", "t_start": "pos", "s": "pos",
    "max_dist": "pos",
    "groups": "scales", "adaptive_scale": "scales",
    "jac_norm_start": "step", "n_rejected": "step", "last_failure": "step", "event_cap": "step", "ds_free": "step",
    "n_newton": "corrector", "n_backtracked": "corrector",
    "min_rcond": None, "min_rcond_index": None, "last_rcond": None,
    "barrier_tried": "barriers",
}


@dataclasses.dataclass(eq=False)
class Position:
    """Where the branch is: its last stored point and the references of the next steps.

    Points ``x`` and tangents ``t`` are in scaled coordinates, shape (m+1,).

    Attributes
    ----------
    x, t : ndarray
        The last stored point and its unit tangent.
    u : ndarray, shape (m,)
    lam, s : float
        Its parameter and arclength.
    info : PointInfo
        Everything the events know of it.
    g : list of ndarray
        The events' test values there.
    prev_x, t_prev : ndarray
        The point before and its tangent (the bordering row of the last
        point's matrix).
    prev_info : PointInfo or None
    x_start, t_start : ndarray
        The start point and its tangent (closed loops, the direction set out in).
    max_dist : float
        Largest distance from the start so far.
    """

    x: np.ndarray | None = None
    u: np.ndarray | None = None
    lam: float = float("nan")
    t: np.ndarray | None = None
    s: float = 0.0
    info: PointInfo | None = None
    g: list | None = None
    prev_x: np.ndarray | None = None
    t_prev: np.ndarray | None = None
    prev_info: PointInfo | None = None
    x_start: np.ndarray | None = None
    t_start: np.ndarray | None = None
    max_dist: float = 0.0


def _holder(engine, name: str):
    """The part of ``engine`` holding the state value ``name``."""
    part = HOLDER[name]
    return engine if part is None else getattr(engine, part)


def save(engine) -> dict:
    """What the main loop carries from the last stored point to the next step (see :func:`restore`).

    ``points`` is the number of stored points it belongs to; ``step_control`` the step rule's ``state()``
    (None for a rule without one, such as the default: the wanted step ``ds`` is the engine's).
    """
    pos, sp, step = engine.pos, engine.sp, engine.step
    bar = engine.barriers.at_barrier
    out = {"points": len(engine.branch), "ds": float(step.ds), "recent": [float(v) for v in step.recent],
           "turns": [[a, d] for a, d in engine.corners.turns], "su": sp.su.copy(), "sl": float(sp.sl),
           "calls": int(sp.calls), "rescalings": [list(r) for r in engine.scales.rescalings],
           "tests": [np.asarray(g, dtype=float).copy() for g in pos.g],
           "monitors": [mon.state() if hasattr(mon, "state") else None for mon in engine.monitors],
           "barrier": None if bar is None else {**{f.name: getattr(bar, f.name) for f in dataclasses.fields(bar)},
                                                "event": engine.events.index(bar.event)},
           "step_control": step.rule.state() if callable(getattr(step.rule, "state", None)) else None}
    for name in STATE_ARRAYS:
        out[name] = np.array(getattr(_holder(engine, name), name))
    for name in STATE_SCALARS:
        v = getattr(_holder(engine, name), name)
        out[name] = v if isinstance(v, (str, bool, int)) else float(v)
    return out


def restore(engine, branch: Branch, state: Mapping[str, Any]) -> None:
    """Take up ``branch`` (the points stored so far) where :func:`save` left it.

    The last two points are linearized again (their test values come from
    ``state``), so the next step is the one the interrupted run would have
    taken.

    Raises
    ------
    ValueError
        The state belongs to another number of points, or holds a step rule's
        state that the given rule cannot restore.
    """
    if len(branch) != state["points"] or len(branch) < 1:
        raise ValueError(f"restart: the state belongs to {state['points']} points, the branch has {len(branch)}")
    rule, saved = engine.step.rule, state["step_control"]
    if saved is not None and not callable(getattr(rule, "restore", None)):
        raise ValueError(f"restart: the state holds the step control's state, but {type(rule).__name__} "
                         "has no restore(state): give the step control the interrupted run had")
    branch.status, branch.message = BranchStatus.RUNNING, ""
    engine.builder.branch = engine.branch = branch
    m = engine.m
    engine.sp = sp = ScaledProblem(engine.problem, m, np.array(state["su"], dtype=float), float(state["sl"]))
    for name in STATE_ARRAYS:
        setattr(_holder(engine, name), name, np.array(state[name], dtype=np.intp if name == "groups" else float))
    for name in STATE_SCALARS:
        setattr(_holder(engine, name), name, state[name])
    engine.corners.turns = [(a, d) for a, d in state["turns"]]
    engine.scales.rescalings = [tuple(r) for r in state["rescalings"]]
    pos = engine.pos
    pos.g = [np.asarray(g, dtype=float) for g in state["tests"]]
    for mon, st in zip(engine.monitors, state["monitors"]):
        if st is not None and hasattr(mon, "restore"):
            mon.restore(st)
    k = len(branch) - 1
    pos.u, pos.lam = branch.unknowns[k].copy(), float(branch.parameter[k])

    def info_at(i, tangent, row, s):
        u, lam = branch.unknowns[i], float(branch.parameter[i])
        R, Ju, Jlam = sp.evaluate(u, lam)
        data = {name: values[i] for name, values in branch.point_data.items()}
        return point_info(u, lam, tangent, factorize(bordered_matrix(Ju, Jlam, sp.su, sp.sl, row)), Ju, Jlam, s, data)

    pos.info = info_at(k, pos.t, pos.t_prev, pos.s)
    pos.prev_info = info_at(k - 1, pos.t_prev, pos.t_prev, float(branch.arclength[k - 1])) if k else None
    bar = state["barrier"]
    engine.barriers.at_barrier = None if bar is None else Barrier(**{**bar, "event": engine.events[bar["event"]]})
    sp.calls = int(state["calls"])
    engine.step.ds = float(state["ds"])
    engine.step.recent = collections.deque(list(state["recent"]), maxlen=engine.opt.stall_points)
    if saved is not None:
        rule.restore(saved)
