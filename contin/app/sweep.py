"""Parameter sweeps: one scene run per point of a grid of scene values, on Dask.

``contin sweep SCENE.yaml --grid dotted.key=SPEC ... -o OUTDIR`` runs the
scene once per point of the outer product of the ``--grid`` axes. Each point
is an ordinary run (:func:`contin.app.runner.run_scene`) with the point's values
applied as ``--set`` overrides, written to its own directory
``OUTDIR/points/<name>``; ``OUTDIR/sweep.csv`` indexes the points (values,
status, message, timings, a summary of the special points and of the stable
intervals per subharmonic order) and ``OUTDIR/sweep_map.png`` maps that
summary over the grid.

Execution is delegated to ``dask.distributed``: by default an embedded
``LocalCluster`` of worker processes (one per core, one thread each) that the
sweep starts and stops; with ``scheduler`` an existing cluster. What the
engine provides and the sweep relies on:

- a task whose worker dies is rescheduled on another worker (the scheduler's
  ``allowed-failures``), and a task that raises an unexpected exception is
  run again (``retries``);
- progress is reported as tasks complete (``distributed.as_completed``).

What the sweep adds on top:

- a failed run (:class:`contin.app.runner.RunError`, a value the scene refuses,
  :class:`contin.scene.parse.SceneError`) is a result, not an error: it is recorded
  with its message and the other points go on;
- each point runs into a temporary directory that is renamed into place when
  the run has ended, so ``points/<name>`` is either absent or a finished
  result (complete or failed), never half-written;
- a point is *complete* when its ``summary.json`` says ``complete`` and holds
  the same scene (after defaults) as the point would run now; rerunning a
  sweep skips those points, so an interrupted sweep resumes where it stopped
  and nothing is computed twice;
- numba compiles each kernel once (``cache=True``; generated kernels under
  ``$CONTIN_CACHE_DIR``) and later processes load the machine code from the
  cache; each worker loads the kernels and the plotting stack once, when it
  starts (:class:`WarmUp`), not in every task.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import itertools
import json
import math
import os
import re
import shutil
import socket
import sys
import threading
import time
import uuid
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from contin.scene.schema import SceneError
from contin.analyses.intervals import SPECIAL_KINDS, stable_intervals

__all__ = ["GridAxis", "GridPoint", "PointTask", "SweepOptions", "SweepResult", "parse_grid", "grid_points",
           "run_point", "run_sweep", "summarize_point", "WarmUp", "warm_up",
           "INDEX_COLUMNS", "SUMMARY_COLUMNS"]

#: special-point kinds summarised in ``sweep.csv`` (count ``n_KIND`` and located values ``KIND_at``)
#: the fixed leading columns of ``sweep.csv`` after ``point`` and the grid keys
INDEX_COLUMNS = ("status", "message", "reused", "run_seconds", "task_seconds", "started_at", "finished_at",
                 "worker")
#: summary columns that follow (then ``n_KIND``, ``KIND_at`` and ``stable_nuN...``)
SUMMARY_COLUMNS = ("rows", "branches", "branch_status", "parameter")
#: significant digits of the values of a range ``start:stop:count`` (``0:0.6:13`` gives 0.05 exactly as typed)
RANGE_DIGITS = 12

_NAME_CHARS = re.compile(r"[^A-Za-z0-9._+=-]")


# ---------------------------------------------------------------- the grid
def _scalar(text: str, where: str):
    """A grid value from its text: an int, a float, true/false, or else the YAML scalar (a string)."""
    t = text.strip()
    if not t:
        raise SceneError(where, "a value between the commas", text)
    try:
        return int(t)
    except ValueError:
        pass
    try:
        v = float(t)
    except ValueError:
        pass
    else:
        if not math.isfinite(v):
            raise SceneError(where, "finite numbers", t)
        return v
    try:
        v = yaml.safe_load(t)
    except yaml.YAMLError:
        v = t
    if isinstance(v, (list, dict)) or v is None:
        raise SceneError(where, "scalar values (numbers, true/false or words) separated by commas", t)
    return v


def _yaml_text(value) -> str:
    """``value`` spelled so that ``yaml.safe_load`` gives it back exactly (for a ``--set`` override)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    text = yaml.safe_dump([value], default_flow_style=True).strip()
    text = text[1:-1].strip()  # drop the list brackets: the scalar in YAML flow style
    if yaml.safe_load(text) != value:  # pragma: no cover  (a guard: every scalar above round-trips)
        raise ValueError(f"cannot spell {value!r} in YAML")
    return text


def _plain(v):
    """numpy scalars as Python ones (so that they spell as YAML)."""
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.floating):
        return float(v)
    return v


@dataclass(frozen=True)
class GridAxis:
    """One ``--grid`` axis: a dotted scene key and the values it takes.

    Attributes
    ----------
    key : str
        Dotted scene key, as for ``--set`` (``model.parameters.F``).
    values : tuple
        Distinct scalar values (numbers, booleans or strings), in order.
    """

    key: str
    values: tuple

    def __post_init__(self):
        where = f"--grid {self.key}"
        if not isinstance(self.key, str) or not self.key or any(not p.strip() for p in self.key.split(".")) \
                or self.key != self.key.strip() or "=" in self.key:
            raise SceneError("--grid", "dotted.key=SPEC with a dotted scene key such as model.parameters.F", self.key)
        if not isinstance(self.values, tuple) or not self.values:
            raise SceneError(where, "at least one value", self.values)
        object.__setattr__(self, "values", tuple(_plain(v) for v in self.values))
        for v in self.values:
            if not isinstance(v, (int, float, str, bool)) or (isinstance(v, float) and not math.isfinite(v)):
                raise SceneError(where, "finite numbers, true/false or words", v)
        seen = set()
        for v in self.values:
            token = (type(v) is bool, v)
            if token in seen:
                raise SceneError(where, "distinct values (each point is run once)", v)
            seen.add(token)

    def override(self, value) -> str:
        """The ``--set`` assignment of ``value`` on this axis."""
        return f"{self.key}={_yaml_text(value)}"


def parse_grid(text: str) -> GridAxis:
    """Parse a ``--grid`` option ``dotted.key=SPEC``.

    SPEC is either a list ``v1,v2,...`` (numbers, ``true``/``false`` or words,
    each value at most once) or a range ``start:stop:count`` of ``count >= 2``
    equally spaced numbers from ``start`` to ``stop`` inclusive (rounded to
    12 significant digits, so ``0:0.6:13`` gives 0, 0.05, ..., 0.6 as typed).
    A single value is a list of one.

    Raises
    ------
    SceneError
        Naming ``--grid`` (and the key), what was expected and what was found.
    """
    if not isinstance(text, str) or "=" not in text:
        raise SceneError("--grid", "dotted.key=SPEC, for example model.parameters.F=0.1,0.2,0.5 "
                         "or model.parameters.F=0:0.6:13", text)
    key, _, spec = text.partition("=")
    key = key.strip()
    if not key or any(not p.strip() for p in key.split(".")):
        raise SceneError("--grid", "dotted.key=SPEC with a dotted scene key such as model.parameters.F", text)
    where = f"--grid {key}"
    spec = spec.strip()
    if not spec:
        raise SceneError(where, "a list v1,v2,... or a range start:stop:count after '='", spec)
    if ":" in spec:
        parts = spec.split(":")
        if len(parts) != 3 or "," in spec:
            raise SceneError(where, "a range start:stop:count (three numbers separated by colons)", spec)
        try:
            start, stop = float(parts[0]), float(parts[1])
        except ValueError:
            raise SceneError(where, "a range start:stop:count whose start and stop are numbers", spec) from None
        try:
            count = int(parts[2])
        except ValueError:
            raise SceneError(where, "a range start:stop:count whose count is an integer", spec) from None
        if not (math.isfinite(start) and math.isfinite(stop)):
            raise SceneError(where, "a range with finite start and stop", spec)
        if count < 2:
            raise SceneError(where, "a range start:stop:count with a count of at least 2", spec)
        if start == stop:
            raise SceneError(where, "a range start:stop:count with start different from stop", spec)
        values = tuple(float(f"{start + (stop - start) * i / (count - 1):.{RANGE_DIGITS}g}") for i in range(count))
        values = values[:-1] + (stop,)
        if len(set(values)) != len(values):
            raise SceneError(where, f"a range whose {count} values differ in {RANGE_DIGITS} significant digits", spec)
        return GridAxis(key, values)
    return GridAxis(key, tuple(_scalar(t, where) for t in spec.split(",")))


def _label(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.12g}"
    return str(value)


@dataclass(frozen=True)
class GridPoint:
    """A point of the grid: its position, values, directory name and ``--set`` overrides."""

    index: int
    values: tuple  # ((key, value), ...) in axis order
    name: str
    overrides: tuple

    @property
    def label(self) -> str:
        return " ".join(f"{k.rsplit('.', 1)[-1]}={_label(v)}" for k, v in self.values)


def grid_points(axes) -> list[GridPoint]:
    """The outer product of the axes, first axis slowest.

    Directory names spell the values (``F=0.3__c=0.1``, with the last part of
    each key, or the full key where two axes share it), so extending a grid
    keeps the names of the points already computed; if two points would share
    a name, or a name would be unreasonably long, the points are named
    ``p0000``, ``p0001``, ... instead.
    """
    axes = tuple(axes)
    short = [a.key.rsplit(".", 1)[-1] for a in axes]
    names = [s if short.count(s) == 1 else a.key for s, a in zip(short, axes)]
    points = []
    for i, combo in enumerate(itertools.product(*(a.values for a in axes))):
        name = "__".join(_NAME_CHARS.sub("~", f"{n}={_label(v)}") for n, v in zip(names, combo))
        points.append(GridPoint(i, tuple((a.key, v) for a, v in zip(axes, combo)), name,
                                tuple(a.override(v) for a, v in zip(axes, combo))))
    taken = [p.name for p in points]
    if len(set(taken)) != len(taken) or max(map(len, taken)) > 160 or any(n.startswith(".") for n in taken):
        width = max(4, len(str(len(points) - 1)))
        points = [GridPoint(p.index, p.values, f"p{p.index:0{width}d}", p.overrides) for p in points]
    return points


# ---------------------------------------------------------------- options
@dataclass(frozen=True)
class SweepOptions:
    """What to sweep and where to run it; the fields are the options of ``contin sweep``.

    Attributes
    ----------
    scene : str
        Scene file.
    grid : tuple of GridAxis
        The axes (``--grid``); the points are their outer product.
    outdir : str
        Sweep directory (``-o``): ``sweep.csv``, ``sweep.json``, ``sweep_map.png`` and ``points/``.
    overrides : tuple of str
        ``--set`` assignments applied to every point (before the grid values).
    scheduler : str or None
        Address of a running Dask scheduler (``--scheduler``); None starts an
        embedded local cluster.
    workers : int or None
        Worker processes of the embedded cluster (``--workers``); default one per core.
    serial : bool
        Run the points one after another in this process, without Dask (``--serial``).
    retries : int
        Times Dask runs a task again after an unexpected exception (``--retries``).
    map_plot : bool
        Draw ``sweep_map.png``.
    progress : bool
        Print a line per finished point on stderr.
    """

    scene: str
    grid: tuple
    outdir: str
    overrides: tuple = ()
    scheduler: str | None = None
    workers: int | None = None
    serial: bool = False
    retries: int = 2
    map_plot: bool = True
    progress: bool = True

    def __post_init__(self):
        if not isinstance(self.scene, (str, Path)) or not str(self.scene):
            raise SceneError("SCENE", "a scene file name", self.scene)
        if not isinstance(self.outdir, (str, Path)) or not str(self.outdir):
            raise SceneError("-o/--outdir", "a directory name", self.outdir)
        if not isinstance(self.grid, tuple) or not self.grid or not all(isinstance(a, GridAxis) for a in self.grid):
            raise SceneError("--grid", "at least one --grid dotted.key=SPEC", self.grid)
        keys = [a.key for a in self.grid]
        for k in keys:
            if keys.count(k) > 1:
                raise SceneError(f"--grid {k}", "each key in one --grid option only (give all its values there)", k)
            for other in keys:
                if other != k and other.startswith(k + "."):
                    raise SceneError(f"--grid {k}", f"keys that do not contain each other ({other} is inside {k})", k)
        if not isinstance(self.overrides, tuple) or not all(isinstance(o, str) for o in self.overrides):
            raise SceneError("--set", "dotted.key=value assignments", self.overrides)
        for o in self.overrides:
            k = o.partition("=")[0].strip()
            if any(k == g or k.startswith(g + ".") or g.startswith(k + ".") for g in keys):
                raise SceneError(f"--set {k}", "a key not swept by --grid (the grid sets it at every point)", o)
        if self.scheduler is not None and (not isinstance(self.scheduler, str) or not self.scheduler.strip()):
            raise SceneError("--scheduler", "the address of a Dask scheduler, such as tcp://10.0.0.5:8786",
                             self.scheduler)
        if self.workers is not None and (isinstance(self.workers, bool) or not isinstance(self.workers, int)
                                         or self.workers < 1):
            raise SceneError("--workers", "a positive number of worker processes", self.workers)
        if self.workers is not None and self.scheduler is not None:
            raise SceneError("--workers", "no --workers with --scheduler (the cluster has its own workers)",
                             self.workers)
        if not isinstance(self.serial, bool):
            raise SceneError("--serial", "true or false", self.serial)
        if self.serial and (self.scheduler is not None or self.workers is not None):
            raise SceneError("--serial", "no --scheduler or --workers with --serial (it runs in this process)", True)
        if isinstance(self.retries, bool) or not isinstance(self.retries, int) or not 0 <= self.retries <= 100:
            raise SceneError("--retries", "an integer from 0 to 100", self.retries)


# ---------------------------------------------------------------- one point (runs on a worker)
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


def _prepare_process() -> None:
    """Once per process: the Agg backend and one BLAS thread (as the command line runs)."""
    global _PREPARED
    if _PREPARED:
        return
    os.environ.setdefault("MPLBACKEND", "Agg")
    import matplotlib

    matplotlib.use("Agg")
    from contin.util.blas import limit_blas_threads

    limit_blas_threads()
    _PREPARED = True


def _now() -> str:
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
    _prepare_process()
    from contin.output.results import write_json_atomic
    from contin.app.runner import run_scene
    from contin.scene.registry import RunError
    from contin.scene.parse import parse_scene

    t0 = time.perf_counter()
    started = _now()
    final = Path(task.outdir) / task.name
    tmp = final.with_name(f".{task.name}.tmp-{uuid.uuid4().hex[:10]}")
    tmp.mkdir(parents=True)
    record: dict[str, Any] = {"name": task.name, "index": task.index, "values": [list(kv) for kv in task.values],
                              "overrides": list(task.overrides), "started_at": started, "worker": _where()}
    scene = None
    try:
        with _RUN_LOCK:  # one run at a time per process (pyplot is not thread-safe)
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
    record["finished_at"] = _now()
    record["task_seconds"] = time.perf_counter() - t0
    write_json_atomic(tmp / "point.json", record)
    _publish(tmp, final)
    return record


def _mark_failed(outdir: Path, scene, task: PointTask, message: str) -> None:
    """Make the point's ``summary.json`` say ``failed`` with the message (whatever stage failed)."""
    from contin.output.results import write_json_atomic

    path = outdir / "summary.json"
    try:
        summary = json.loads(path.read_text())
    except (OSError, ValueError):
        summary = {"scene": scene.data if scene is not None else None, "source": task.scene_source,
                   "overrides": list(task.overrides)}
    summary.update({"status": "failed", "message": message})
    write_json_atomic(path, summary)


# ---------------------------------------------------------------- summaries of a point
def _num(v: float) -> str:
    return repr(float(v))


def summarize_point(outdir: str | Path) -> dict:
    """The ``sweep.csv`` summary of a finished run directory.

    Returns
    -------
    dict
        ``rows`` and ``branches`` (counts), ``branch_status`` (the distinct
        branch end statuses), ``parameter`` (the continuation parameter), per
        kind in :data:`SPECIAL_KINDS` the count ``n_KIND`` and the located
        parameter values ``KIND_at`` (``;``-separated, in branch order), and
        per subharmonic order ``nu`` found: ``stable_nuN`` (the intervals of
        :func:`stable_intervals` as ``lo..hi;lo..hi``), ``stable_nuN_from``,
        ``stable_nuN_to`` (their hull) and ``stable_nuN_length`` (their total
        length). Analyses without branches give only what applies.
    """
    from contin.output.results import read_csv

    outdir = Path(outdir)
    out: dict[str, Any] = {}
    try:
        summary = json.loads((outdir / "summary.json").read_text())
    except (OSError, ValueError):
        return out
    analysis = summary.get("analysis") or {}
    branches = analysis.get("branches") if isinstance(analysis, dict) else None
    if isinstance(branches, list):
        out["branches"] = len(branches)
        out["branch_status"] = ";".join(dict.fromkeys(str(b.get("status")) for b in branches))
    if not (outdir / "branches.csv").exists():
        return out
    rows = read_csv(outdir / "branches.csv")
    special = read_csv(outdir / "special_points.csv") if (outdir / "special_points.csv").exists() else {}
    header = list(rows)
    parameter = analysis.get("parameter") if isinstance(analysis, dict) else None
    if parameter not in rows:
        parameter = header[2] if len(header) > 2 else None
    out["rows"] = len(rows.get("branch", []))
    out["parameter"] = parameter
    if parameter is None:
        return out
    kinds = list(special.get("kind", [])) if special else []
    for kind in SPECIAL_KINDS:
        vals = [float(v) for k, v in zip(kinds, special.get(parameter, [])) if k == kind] if kinds else []
        out[f"n_{kind}"] = len(vals)
        out[f"{kind}_at"] = ";".join(_num(v) for v in vals)
    for nu, iv in stable_intervals(rows, special, parameter).items():
        out[f"stable_nu{nu}"] = ";".join(f"{_num(a)}..{_num(b)}" for a, b in iv)
        out[f"stable_nu{nu}_from"] = iv[0][0] if iv else None
        out[f"stable_nu{nu}_to"] = iv[-1][1] if iv else None
        out[f"stable_nu{nu}_length"] = sum(b - a for a, b in iv) if iv else 0.0
    return out


# ---------------------------------------------------------------- worker warm-up
def warm_up(scene_text: str, scene_source: str, overrides=()) -> dict:
    """Load (or, on a cold cache, compile) what a run of this scene needs, once per process.

    Imports contin and the plotting stack, builds the scene's model (its
    generated kernels) and, for a ``frequency_response``, evaluates the
    harmonic-balance residual and Jacobian and Hill's stability once, so that
    numba loads its cached machine code here instead of inside the first task.
    On a cold cache (the first sweep after installing contin, or the first
    with a new custom model) each worker compiles here, all at once, which
    costs the wall time of one compilation when there are no more workers
    than cores; later sweeps load the cached code. Failures are ignored: the
    tasks report them.

    Returns
    -------
    dict
        ``seconds`` and ``status`` (``ok`` or the exception text).
    """
    t0 = time.perf_counter()
    _prepare_process()
    status = "ok"
    try:
        import io

        import matplotlib.pyplot as plt

        import contin.output.plotting  # noqa: F401
        from contin.scene.build import build_model
        from contin.scene.parse import parse_scene

        fig = plt.figure(figsize=(1, 1))
        fig.gca().plot([0, 1], [0, 1], "--")
        fig.savefig(io.BytesIO(), format="png")
        plt.close(fig)
        scene = parse_scene(scene_text, scene_source, overrides)
        model = build_model(scene)
        if scene.analysis["type"] == "frequency_response":
            from contin.analyses.frequency_response import build_problem

            hb = build_problem(scene, model)
            lam = float(scene.analysis["range"][0])
            u = hb.linear_solution(lam)
            hb.linearize(u, lam)
            if scene.analysis["stability"] != "none":
                from contin.analyses.stability_hooks import stability_options
                from contin.stability import StabilityMonitor

                StabilityMonitor(hb, stability_options(scene.analysis)).analyze(u, lam)
    except Exception as exc:  # noqa: BLE001  (a warm-up never fails a worker)
        status = f"{type(exc).__name__}: {exc}"
    return {"seconds": time.perf_counter() - t0, "status": status}


try:  # the plugin base class, when distributed is installed
    from distributed.diagnostics.plugin import WorkerPlugin as _WorkerPlugin
except ImportError:  # pragma: no cover
    _WorkerPlugin = object


class WarmUp(_WorkerPlugin):
    """Dask worker plugin: prepares each worker (Agg, one BLAS thread) and runs :func:`warm_up`.

    Registered by the sweep on every worker of the cluster, including workers
    that join later or are restarted after a crash. The warm-up runs in a
    thread, so the worker keeps answering the scheduler meanwhile.

    Parameters
    ----------
    scene_text, scene_source, overrides
        The scene of a grid point, for :func:`warm_up`.
    ignore_interrupt : bool
        Make the worker ignore SIGINT: for the embedded cluster, whose
        workers share the terminal of the command, so that Ctrl-C stops the
        command (which then closes the cluster) instead of killing every
        worker with a traceback.
    """

    name = "contin-sweep-warm-up"

    def __init__(self, scene_text: str, scene_source: str, overrides=(), ignore_interrupt: bool = False):
        self.scene_text, self.scene_source, self.overrides = scene_text, scene_source, tuple(overrides)
        self.ignore_interrupt = ignore_interrupt
        self.result = None

    async def setup(self, worker):
        import asyncio
        import signal

        if self.ignore_interrupt and threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        loop = asyncio.get_running_loop()
        self.result = await loop.run_in_executor(None, warm_up, self.scene_text, self.scene_source, self.overrides)


@contextlib.contextmanager
def _file_lock(path: Path, blocking: bool):
    """An exclusive ``flock`` on ``path`` (released when the process dies); a no-op where unsupported."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover  (not POSIX)
        yield True
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fh = open(path, "a+")
    except OSError:
        yield True
        return
    try:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | (0 if blocking else fcntl.LOCK_NB))
        except BlockingIOError:
            yield False
            return
        except OSError:
            yield True  # a file system without locks: go on unlocked
            return
        yield True
    finally:
        fh.close()


# ---------------------------------------------------------------- the sweep
@dataclass
class SweepResult:
    """What a sweep did.

    Attributes
    ----------
    records : list of dict
        One per grid point, in grid order (the rows of ``sweep.csv``).
    outdir : Path
    counts : dict
        Points per status, and ``reused`` (complete before this sweep started).
    seconds : float

    An interrupted sweep has no result: :func:`run_sweep` raises
    ``KeyboardInterrupt`` after writing ``sweep.csv``.
    """

    records: list
    outdir: Path
    counts: dict = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def failed(self) -> list:
        return [r for r in self.records if r.get("status") != "complete"]


def _normalized(data):
    return json.loads(json.dumps(data, default=str))


def _existing(point_dir: Path, scene) -> dict | None:
    """The record of a point already complete with this scene, else None."""
    try:
        summary = json.loads((point_dir / "summary.json").read_text())
    except (OSError, ValueError):
        return None
    if summary.get("status") != "complete" or scene is None or summary.get("scene") != _normalized(scene.data):
        return None
    try:
        record = json.loads((point_dir / "point.json").read_text())
    except (OSError, ValueError):
        finished = datetime.fromtimestamp((point_dir / "summary.json").stat().st_mtime, timezone.utc)
        record = {"status": "complete", "message": "", "run_seconds": summary.get("timings", {}).get("total"),
                  "finished_at": finished.isoformat(timespec="milliseconds")}
    if record.get("status") != "complete" or not record.get("summary"):
        record["summary"] = summarize_point(point_dir)
    return record


def _clean_leftovers(points_dir: Path) -> int:
    """Remove temporary directories of runs that never ended (killed workers or sweeps)."""
    n = 0
    if points_dir.is_dir():
        for p in points_dir.iterdir():
            if p.name.startswith(".") and (".tmp-" in p.name or ".old-" in p.name):
                shutil.rmtree(p, ignore_errors=True)
                n += 1
    return n


class _Index:
    """``sweep.csv``: written atomically whenever it changes (at most every ``interval`` s, and at the end)."""

    def __init__(self, path: Path, axes, points, interval: float = 1.0):
        self.path, self.axes, self.points = path, axes, points
        self.records: dict[int, dict] = {}
        self.interval, self._last = interval, 0.0

    def set(self, point: GridPoint, record: dict) -> None:
        self.records[point.index] = record
        now = time.monotonic()
        if now - self._last >= self.interval:
            self.write()

    def rows(self) -> list[dict]:
        out = []
        for p in self.points:
            r = self.records.get(p.index, {"status": "pending", "message": "not run yet"})
            row = {"point": p.name, **{k: v for k, v in p.values}}
            for c in INDEX_COLUMNS:
                row[c] = r.get(c)
            for k, v in (r.get("summary") or {}).items():
                row.setdefault(k, v)
            out.append(row)
        return out

    def columns(self, rows) -> list[str]:
        cols = ["point", *[a.key for a in self.axes], *INDEX_COLUMNS]
        extra: list[str] = []
        for kind in (*SUMMARY_COLUMNS, *(f"n_{k}" for k in SPECIAL_KINDS), *(f"{k}_at" for k in SPECIAL_KINDS)):
            if any(kind in r for r in rows):
                extra.append(kind)
        nus = sorted({int(m.group(1)) for r in rows for k in r for m in [re.fullmatch(r"stable_nu(\d+)", k)] if m})
        for nu in nus:
            extra += [f"stable_nu{nu}", f"stable_nu{nu}_from", f"stable_nu{nu}_to", f"stable_nu{nu}_length"]
        return cols + [c for c in extra if c not in cols]

    def write(self) -> Path:
        from contin.output.results import format_value

        rows = self.rows()
        cols = self.columns(rows)
        tmp = self.path.with_name(self.path.name + ".tmp")
        with open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(cols)
            for r in rows:
                w.writerow([_cell(r.get(c), format_value) for c in cols])
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, self.path)
        self._last = time.monotonic()
        return self.path


def _cell(v, format_value) -> str:
    if isinstance(v, float) and not math.isfinite(v):
        return ""
    return format_value(v)


def _progress_line(done: int, total: int, point: GridPoint, rec: dict) -> str:
    w = len(str(total))
    secs = rec.get("task_seconds") or rec.get("run_seconds")
    head = f"[{done:>{w}}/{total}] {point.label}: {rec.get('status')}"
    if secs is not None:
        head += f" ({secs:.1f} s)"
    if rec.get("status") != "complete":
        msg = " ".join(str(rec.get("message", "")).split())
        return head + (f": {msg[:160]}" if msg else "")
    s = rec.get("summary") or {}
    bits = [f"{s['n_' + k]} {k}" for k in SPECIAL_KINDS if s.get("n_" + k)]
    return head + (", " + ", ".join(bits) if bits else "")


def run_sweep(options: SweepOptions, echo=None) -> SweepResult:
    """Run a sweep (see the module documentation).

    Parameters
    ----------
    options : SweepOptions
    echo : callable, optional
        ``echo(line)`` for progress lines; default: stderr when ``options.progress``.

    Returns
    -------
    SweepResult

    Raises
    ------
    SceneError
        Bad input: the scene (with the ``--set`` options) is invalid, every
        grid point is refused by the scene's schema (a wrong ``--grid`` key),
        another sweep is writing ``outdir``, or the scheduler cannot be reached.
    KeyboardInterrupt
        After ``sweep.csv`` has been written with the points finished so far.
    """
    from contin.scene.parse import parse_scene

    t_start = time.perf_counter()
    if echo is None:
        echo = (lambda line: print(line, file=sys.stderr, flush=True)) if options.progress else (lambda line: None)
    scene_path = Path(options.scene)
    try:
        text = scene_path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SceneError(str(scene_path), "a readable scene file", None, hint=f" ({exc.strerror})") from None
    source = str(scene_path)
    base = parse_scene(text, source, options.overrides)  # the scene itself must be valid: bad input otherwise
    _check_grid_keys(base, options.grid)
    points = grid_points(options.grid)
    scenes, refusals = {}, {}
    for p in points:
        try:
            scenes[p.index] = parse_scene(text, source, options.overrides + p.overrides)
        except SceneError as exc:
            refusals[p.index] = str(exc)
    if len(refusals) == len(points):
        first = points[0]
        raise SceneError("--grid", "values the scene accepts at one grid point at least", None,
                         hint=f"; every point is refused, for example {first.label}: {refusals[first.index]}")
    outdir = Path(options.outdir)
    points_dir = outdir / "points"
    try:
        points_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SceneError("-o/--outdir", "a directory that can be created and written", str(outdir),
                         hint=f" ({exc.strerror or exc})") from None
    with _file_lock(outdir / ".sweep.lock", blocking=False) as locked:
        if not locked:
            raise SceneError("-o/--outdir", "a sweep directory no other sweep is writing", str(outdir),
                             hint="; wait for that sweep to end or choose another -o")
        _clean_leftovers(points_dir)
        index = _Index(outdir / "sweep.csv", options.grid, points)
        todo = []
        for p in points:
            rec = _existing(points_dir / p.name, scenes.get(p.index))
            if rec is not None:
                rec["reused"] = True
                index.set(p, rec)
            else:
                todo.append(p)
        reused = len(points) - len(todo)
        meta = {"scene": source, "scene_sha256": hashlib.sha256(text.encode()).hexdigest(),
                "grid": [{"key": a.key, "values": list(a.values)} for a in options.grid],
                "overrides": list(options.overrides), "points": len(points), "started_at": _now(),
                "executor": ("serial" if options.serial else options.scheduler or
                             f"local cluster of {options.workers or os.cpu_count() or 1} worker processes")}
        from contin.output.results import write_json_atomic

        write_json_atomic(outdir / "sweep.json", {**meta, "status": "running"})
        echo(f"sweep of {len(points)} points in {outdir}: {reused} already complete, {len(todo)} to run "
             f"({meta['executor']})")
        tasks = {p.index: PointTask(text, source, options.overrides + p.overrides, str(points_dir), p.name, p.index,
                                    p.values) for p in todo}
        interrupted = False
        timings: dict[str, float] = {}
        try:
            if todo:
                runner = _run_serial if options.serial else _run_dask
                first = next((p for p in todo if p.index in scenes), todo[0])
                runner(options, todo, tasks, index, echo, len(points), reused, timings,
                       warm=(text, source, tasks[first.index].overrides))
        except KeyboardInterrupt:
            interrupted = True
        except BaseException as exc:
            write_json_atomic(outdir / "sweep.json", {**meta, "status": "error", "message": str(exc),
                                                      "finished_at": _now()})
            raise
        finally:
            for p in points:  # runs that ended while the sweep was stopping
                if p.index not in index.records:
                    rec = _existing(points_dir / p.name, scenes.get(p.index))
                    if rec is not None:
                        rec["reused"] = False
                        index.records[p.index] = rec
            index.write()
        _clean_leftovers(points_dir)
        records = [dict(index.records.get(p.index, {"status": "pending", "message": "not run yet"}),
                       point=p.name, values=dict(p.values)) for p in points]
        for r in records:
            r.setdefault("reused", False)
        counts: dict[str, int] = {}
        for r in records:
            counts[r["status"]] = counts.get(r["status"], 0) + 1
        counts["reused"] = reused
        files = []
        if options.map_plot and not interrupted:
            from contin.output.sweep_plot import sweep_map

            t0 = time.perf_counter()
            files = sweep_map(index.rows(), options.grid, outdir / "sweep_map.png")
            timings["map"] = time.perf_counter() - t0
        seconds = time.perf_counter() - t_start
        write_json_atomic(outdir / "sweep.json", {**meta, "status": "interrupted" if interrupted else "finished",
                                                  "finished_at": _now(), "counts": counts, "plots": files,
                                                  "timings": {"total": seconds, **timings}})
        if interrupted:
            raise KeyboardInterrupt
    return SweepResult(records, outdir, counts, seconds)


def _check_grid_keys(scene, axes) -> None:
    """A grid over a parameter the built-in model does not have is bad input (before any run)."""
    from contin.model.catalog import get_spec
    from contin.util.naming import suggest

    name = scene.model.get("builtin")
    if name is None:
        return
    try:
        known = get_spec(name).parameters
    except ValueError:
        return  # the runs report the unknown model
    for a in axes:
        parts = a.key.split(".")
        if len(parts) == 3 and parts[:2] == ["model", "parameters"] and parts[2] not in known:
            raise SceneError(f"--grid {a.key}", f"a parameter of the built-in model '{name}' ({', '.join(known)})",
                             parts[2], hint=suggest(parts[2], known))


def _run_serial(options, todo, tasks, index, echo, total, done, timings, warm):
    """The points one after another in this process (no Dask): the baseline and a debugging aid."""
    for p in todo:
        rec = run_point(tasks[p.index])
        rec["reused"] = False
        index.set(p, rec)
        done += 1
        echo(_progress_line(done, total, p, rec))
        if rec["status"] == "interrupted":  # Ctrl-C inside the run: it stopped after its current point
            raise KeyboardInterrupt


def _worker_env() -> dict:
    return {"MPLBACKEND": "Agg", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


@contextlib.contextmanager
def _client(options, timings):
    """A ``distributed.Client`` on the given scheduler, or on an embedded ``LocalCluster`` it starts and stops."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise SceneError("contin sweep", "the dask.distributed package (pip install \"dask[distributed]\"); "
                         "--serial runs without it", None) from None

    t0 = time.perf_counter()
    if options.scheduler is not None:
        try:
            client = Client(options.scheduler, timeout="20s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise SceneError("--scheduler", "the address of a running Dask scheduler, such as tcp://10.0.0.5:8786",
                             options.scheduler, hint=f" ({type(exc).__name__}: {exc})") from None
        timings["connect"] = time.perf_counter() - t0
        try:
            yield client
        finally:
            client.close()
        return
    n = options.workers or os.cpu_count() or 1
    import logging

    # distributed's own warnings (a worker restarted, one slow to stop) are not shown: the sweep reports
    # every point's outcome itself
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                           env=_worker_env(), silence_logs=logging.ERROR)
    try:
        client = Client(cluster)
        timings["cluster_start"] = time.perf_counter() - t0
        try:
            yield client
        finally:
            client.close()
    finally:
        cluster.close()


def _run_dask(options, todo, tasks, index, echo, total, done, timings, warm):
    from distributed import as_completed

    t_end = None
    with _client(options, timings) as client:
        t0 = time.perf_counter()
        client.register_plugin(WarmUp(*warm, ignore_interrupt=options.scheduler is None), name=WarmUp.name)
        timings["warm_up"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        token = uuid.uuid4().hex[:8]
        point_of = {}
        futures = []
        for p in todo:
            fut = client.submit(run_point, tasks[p.index], key=f"contin-point-{p.name}-{token}", pure=False,
                                retries=options.retries)
            point_of[fut.key] = p
            futures.append(fut)
        for fut, result in as_completed(futures, with_results=True, raise_errors=False):
            p = point_of[fut.key]
            if isinstance(result, BaseException):
                rec = {"status": "failed", "error": type(result).__name__, "worker": "",
                       "message": f"the task failed (after up to {options.retries} retries): "
                                  f"{type(result).__name__}: {result}", "finished_at": _now()}
            else:
                rec = result
            rec["reused"] = False
            index.set(p, rec)
            done += 1
            echo(_progress_line(done, total, p, rec))
            fut.release()
        timings["tasks"] = time.perf_counter() - t0
        if options.scheduler is not None:  # leave an existing cluster as it was
            with contextlib.suppress(Exception):
                client.unregister_worker_plugin(WarmUp.name)
        t_end = time.perf_counter()
    timings["shutdown"] = time.perf_counter() - t_end
