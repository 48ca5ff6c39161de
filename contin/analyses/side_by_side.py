"""Branches traced side by side: independent branch-following calls in threads, written in order.

A shooting branch spends its time in the integrator's kernels, which leave
the GIL (:mod:`contin.util.workers`), so two branches that share nothing
(the two halves of a subharmonic branch handed over to shooting at their
grazing points) can run at once, one per core. The run's files, however,
are written one branch after the other (the rows of a branch are
contiguous, the checkpoint is resumed from its last engine record). So each
call records into a :class:`DeferredRecorder` of its own, which keeps what
the call asked of the run's recorder, with the branch as it was at that
moment; once all calls have ended these are made on the run's recorder in
the calls' order. The files are then those of the calls made one after the
other, byte for byte.

What is written while the calls run is nothing: a run killed then (not
stopped: a signal stops each branch at its next point) resumes from before
them. A stop keeps the calls up to the first interrupted one, that one
included, as calls made one after the other would have; the work of the
calls after it is dropped, and a resumed run takes them up from their
start. An exception raised by a call is raised (by :func:`side_by_side`)
once the calls before it are written.
"""

from __future__ import annotations

import copy
import threading
from typing import Callable

from contin.engine.branch import BranchStatus
from contin.util.workers import map_ordered, threads

__all__ = ["DeferredRecorder", "interrupted", "run_threads", "side_by_side"]


class _Snapshot:
    """A branch as the recorder saw it at one call: its length, special points, status, message and info then
    (the branch's arrays only grow, so its earlier entries are read from the branch itself)."""

    def __init__(self, branch):
        self._branch = branch
        self._n = len(branch)
        self._n_special = len(branch.special_points)
        self.info = dict(branch.info)
        self.status = branch.status
        self.message = branch.message

    def __len__(self) -> int:
        return self._n

    @property
    def special_points(self) -> list:
        return self._branch.special_points[:self._n_special]

    def __getattr__(self, name):
        return getattr(self._branch, name)


class DeferredRecorder:
    """Stands in for a :class:`contin.analyses.branch_recorder.BranchRecorder` in a call run in a thread: keeps
    the calls of the branch-following function (:func:`contin.analyses.stability_hooks.stability_setup`) and
    makes them on the real recorder in :meth:`replay`; ``problems`` as the recorder's (branch id -> problem)."""

    def __init__(self, rec):
        self.calls: list[tuple[str, tuple, dict]] = []
        self.failed_switches: list = []
        self.problems: dict = {}
        self._rec = rec

    def point(self, branch_id: int, nu: int, branch, i: int, H=None, problem=None) -> None:
        if problem is not None:
            self.problems[branch_id] = problem
        # the row's values here, in the thread (a shooting row integrates its orbit)
        values = self._rec.point_values(self.problems.get(branch_id), branch.unknowns[i], float(branch.parameter[i]),
                                        nu)
        self.calls.append(("point", (branch_id, nu, _Snapshot(branch), i, H), {"problem": problem, "values": values}))

    def checkpoint(self, branch_id: int, branch, state: dict) -> None:
        # the engine's state is a fresh dict, but a monitor's state may share lists with the monitor
        self.calls.append(("checkpoint", (branch_id, _Snapshot(branch), copy.deepcopy(state)), {}))

    def special_points(self, branch_id: int, branch, problem=None) -> None:
        if problem is not None:
            self.problems[branch_id] = problem
        self.calls.append(("special_points", (branch_id, _Snapshot(branch)), {"problem": problem}))

    def replay(self, rec, branch_id: int | None = None, as_id: int | None = None) -> None:
        """Make the kept calls on ``rec``, in the order they were made: all of them, or those of branch
        ``branch_id`` alone, written as branch ``as_id`` (default: its own id)."""
        for name, args, kwargs in self.calls:
            if branch_id is not None and args[0] != branch_id:
                continue
            if as_id is not None:
                args = (as_id,) + args[1:]
            getattr(rec, name)(*args, **kwargs)
        if branch_id is None:
            rec.failed_switches.extend(self.failed_switches)


class _SharedProgress:
    """One progress line for calls running at once: each thread's latest text (the branch it traces now),
    side by side (no bar: the branches' fractions of the range are not one fraction)."""

    def __init__(self, progress, task: str):
        self._progress = progress
        self._task = task
        self._lock = threading.Lock()
        self._texts: dict = {}

    @property
    def enabled(self) -> bool:
        return self._progress.enabled

    def update(self, text: str, **where) -> None:
        with self._lock:
            self._texts[threading.get_ident()] = text
            self._progress.update("  |  ".join(self._texts.values()), task=self._task)

    def close(self) -> None:
        pass  # the run's display is closed by the run


class _ThreadContext:
    """The run context as a call run in a thread sees it: the shared progress line, the rest the run's own
    (``stop_requested`` read live)."""

    def __init__(self, ctx, progress):
        self._ctx = ctx
        self.progress = progress

    def __getattr__(self, name):
        return getattr(self._ctx, name)


def interrupted(result) -> bool:
    """Whether a branch of ``result`` (``[(Branch, meta)]``) was interrupted."""
    return any(b.status == BranchStatus.INTERRUPTED for b, _ in result)


def run_threads(calls: list[Callable], rec, ctx, task: str) -> list[tuple]:
    """Run ``calls`` (each ``call(recorder, ctx)``) in threads, each with a :class:`DeferredRecorder` of its own
    (for the run's recorder ``rec``) and the shared progress line ``task``; per call ``(recorder, result,
    exception or None)``, in order."""
    logs = [DeferredRecorder(rec) for _ in calls]
    shared = _ThreadContext(ctx, _SharedProgress(ctx.progress, task))

    def run(k):
        try:
            return logs[k], calls[k](logs[k], shared), None
        except BaseException as exc:  # raised by the caller, once what comes before it is written
            return logs[k], None, exc

    return map_ordered(run, len(calls))


def side_by_side(calls: list[Callable], rec, ctx, task: str) -> list:
    """Run ``calls`` (each ``call(recorder, ctx) -> [(Branch, meta)]``) side by side; their results in order.

    With one thread (``CONTIN_THREADS=1``) or one call they run one after the other on ``rec`` and ``ctx``
    themselves. Either way the results end at the first call whose branches were interrupted or whose stop
    was requested (the calls after it: None).

    Parameters
    ----------
    calls : list of callable
    rec : BranchRecorder
    ctx : run context
    task : str
        Names the shared progress line (``"branches 3, 4"``).

    Returns
    -------
    list
        Per call, its result, or None for a call dropped after an interrupted one.
    """
    out: list = [None] * len(calls)
    if len(calls) < 2 or threads() < 2:
        for k, call in enumerate(calls):
            out[k] = call(rec, ctx)
            if ctx.stop_requested or interrupted(out[k]):
                break
        return out
    for k, (log, result, exc) in enumerate(run_threads(calls, rec, ctx, task)):
        if exc is not None:
            raise exc
        log.replay(rec)
        out[k] = result
        if interrupted(result):
            break
    return out
