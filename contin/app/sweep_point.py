"""One point of a parameter sweep, run on a worker: its scene run into a directory that appears only when finished.

:class:`PointTask` is what a worker needs (small and picklable);
:func:`run_point` runs it (the task function of the sweep) into a temporary
directory and renames it into place when the run has ended, so a point's
directory is either absent or a finished result, and records a failed run as
a result rather than an error.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import threading
import time
import uuid
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from contin.analyses.base import RunError
from contin.app.sweep_index import summarize_point
from contin.output.results import write_json_atomic
from contin.scene.schema import SceneError
from contin.util.blas import limit_blas_threads

__all__ = ["PointTask", "run_point", "prepare_process", "utc_now"]


@dataclass(frozen=True)
class PointTask:
    """Everything a worker needs to run one grid point (small and picklable).

    The scene travels as its text, so workers need not see the scene file,
    only ``outdir`` (a directory the workers and the sweep both reach).
    """

    scene_text: str
    scene_source: str
    overrides: tuple
    outdir: str  # the sweep's points/ directory
    name: str
    index: int
    values: tuple


_PREPARED = False
_RUN_LOCK = threading.Lock()


def prepare_process() -> None:
    """Once per process: one BLAS thread (as the command line runs).

    The figures of a run are drawn on their own canvas (:mod:`contin.output.figures`),
    so no matplotlib backend is chosen here: a worker thread in the user's own
    process leaves the user's backend as it was.
    """
    global _PREPARED
    if _PREPARED:
        return
    limit_blas_threads()
    _PREPARED = True


def utc_now() -> str:
    """The time now in UTC, ISO 8601 to the millisecond (the times of ``point.json`` and ``sweep.json``)."""
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


def _where() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def _publish(tmp: Path, final: Path) -> None:
    """Move a finished point directory into place (replacing an earlier, unfinished or failed one)."""
    for _ in range(5):
        try:
            os.rename(tmp, final)
            return
        except OSError:
            if not final.exists():
                raise
        old = final.with_name(f".{final.name}.old-{uuid.uuid4().hex[:10]}")
        try:
            os.rename(final, old)
        except FileNotFoundError:
            continue
        try:
            os.rename(tmp, final)
        finally:
            shutil.rmtree(old, ignore_errors=True)
        return
    raise OSError(f"could not move {tmp} to {final}")


def run_point(task: PointTask) -> dict:
    """Run one grid point; the task function of the sweep (importable, so workers can unpickle it).

    The run goes into ``.<name>.tmp-<random>`` beside its final directory and
    is renamed to ``<name>`` when it has ended, with ``point.json`` (this
    function's return value) inside. A run that fails for a reason of its own
    (:class:`~contin.app.runner.RunError`, :class:`~contin.scene.parse.SceneError`) is
    returned as ``status: failed`` with its message; any other exception
    propagates, so that Dask retries the task.

    Returns
    -------
    dict
        ``name``, ``index``, ``values``, ``status`` (``complete``, ``failed`` or
        ``interrupted``), ``message``, ``error`` (exception type or empty),
        ``run_seconds``, ``task_seconds``, ``started_at``, ``finished_at``,
        ``worker`` and ``summary`` (see :func:`summarize_point`).
    """
    prepare_process()
    # a worker imports this module on its event loop when it unpickles a task or the warm-up plug-in; the
    # machinery of a run (numba, matplotlib: 1.5 s) loads here instead, in the task's thread
    from contin.app.runner import run_scene  # deferred: 1.5 s, in the task's thread (above)
    from contin.scene.parse import parse_scene  # deferred: in the task's thread (above)

    t0 = time.perf_counter()
    started = utc_now()
    final = Path(task.outdir) / task.name
    tmp = final.with_name(f".{task.name}.tmp-{uuid.uuid4().hex[:10]}")
    tmp.mkdir(parents=True)
    record: dict[str, Any] = {"name": task.name, "index": task.index, "values": [list(kv) for kv in task.values],
                              "overrides": list(task.overrides), "started_at": started, "worker": _where()}
    scene = None
    try:
        # one run at a time per process: a run's figures set matplotlib's rcParams (global) for their style
        with _RUN_LOCK:
            scene = parse_scene(task.scene_text, task.scene_source, task.overrides)
            summary = run_scene(scene, tmp, progress=False)
        status, message, error = summary["status"], "", ""
        if status != "complete":
            message = summary.get("message") or f"the run ended with status {status}"
        run_seconds = summary.get("timings", {}).get("total")
    except (RunError, SceneError) as exc:
        status, message, error = "failed", str(exc), type(exc).__name__
        run_seconds = time.perf_counter() - t0
        _mark_failed(tmp, scene, task, message)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    record.update({"status": status, "message": message, "error": error, "run_seconds": run_seconds,
                   "summary": summarize_point(tmp) if status in ("complete", "incomplete") else {}})
    record["finished_at"] = utc_now()
    record["task_seconds"] = time.perf_counter() - t0
    write_json_atomic(tmp / "point.json", record)
    _publish(tmp, final)
    return record


def _mark_failed(outdir: Path, scene, task: PointTask, message: str) -> None:
    """Make the point's ``summary.json`` say ``failed`` with the message (whatever stage failed)."""
    path = outdir / "summary.json"
    try:
        summary = json.loads(path.read_text())
    except (OSError, ValueError):
        summary = {"scene": scene.data if scene is not None else None, "source": task.scene_source,
                   "overrides": list(task.overrides)}
    summary.update({"status": "failed", "message": message})
    write_json_atomic(path, summary)
