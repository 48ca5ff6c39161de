"""Parameter sweeps: one scene run per point of a grid of scene values, on Dask.

``contin sweep SCENE.yaml --grid dotted.key=SPEC ... -o OUTDIR`` runs the
scene once per point of the outer product of the ``--grid`` axes. Each point
is an ordinary run (:func:`contin.app.runner.run_scene`) with the point's values
applied as ``--set`` overrides, written to its own directory
``OUTDIR/points/<name>``; ``OUTDIR/sweep.csv`` indexes the points (values,
status, message, timings, a summary of the special points and of the stable
intervals per subharmonic order) and ``OUTDIR/sweep_map.png`` maps that
summary over the grid.

Execution is delegated to ``dask.distributed``, an optional dependency
(``pip install "contin[sweep]"``; ``serial`` runs without it): by default an
embedded ``LocalCluster`` of worker processes (one per core, one thread
each) that the sweep starts and stops; with ``scheduler`` an existing
cluster. What the engine provides and the sweep relies on:

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
  starts (:class:`~contin.app.sweep_workers.WarmUp`), not in every task.

The grid is :mod:`contin.app.sweep_grid`, one point's run
:mod:`contin.app.sweep_point`, the summaries and ``sweep.csv``
:mod:`contin.app.sweep_index`, and the execution (serial or on Dask, with
the workers' warm-up) :mod:`contin.app.sweep_workers`.
"""


from __future__ import annotations

import hashlib
import json
import os
import shlex
import shutil
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from contin.app.outdir import OutdirLock, check_outdir, clean_temporary_files
from contin.app.progress import Progress
from contin.app.sweep_grid import GridAxis, grid_points
from contin.app.sweep_index import SweepIndex, progress_line, summarize_point
from contin.app.sweep_point import PointTask, utc_now
from contin.app.sweep_workers import require_distributed, run_dask, run_serial
from contin.model.catalog import get_spec
from contin.output.results import write_json_atomic
from contin.output.sweep_plot import sweep_map
from contin.scene.parse import parse_scene, read_scene_text
from contin.scene.schema import SceneError
from contin.util.naming import suggest

__all__ = ["SweepOptions", "SweepResult", "run_sweep", "sweep_command"]


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
        Show the progress on stderr (points done of the total, with the
        remaining time) and a line for each point that failed or fell short.
    force : bool
        Write into a directory that holds files and is not contin's (``--force``).
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
    force: bool = False

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
        if not isinstance(self.force, bool):
            raise SceneError("--force", "true or false", self.force)



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


def sweep_command(options: SweepOptions) -> str:
    """The ``contin sweep`` command line of ``options``: run again, it resumes the sweep.

    The scene, the ``--grid`` axes (as typed, when parsed from text), the
    ``--set`` options, ``-o`` and the way of running (``--serial``,
    ``--workers``, ``--scheduler``); shell-quoted.
    """
    args = ["contin", "sweep", str(options.scene)]
    for a in options.grid:
        args += ["--grid", a.option()]
    for o in options.overrides:
        args += ["--set", o]
    args += ["-o", str(options.outdir)]
    if options.serial:
        args.append("--serial")
    if options.workers is not None:
        args += ["--workers", str(options.workers)]
    if options.scheduler is not None:
        args += ["--scheduler", options.scheduler]
    return shlex.join(args)


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



def run_sweep(options: SweepOptions, echo=None) -> SweepResult:
    """Run a sweep (see the module documentation).

    Parameters
    ----------
    options : SweepOptions
    echo : callable, optional
        ``echo(line)`` for the opening line and a line per finished point;
        default: a :class:`~contin.app.progress.Progress` display on stderr
        when ``options.progress`` (the opening line, points done of the total
        with the remaining time, a line per point that failed or fell short).

    Returns
    -------
    SweepResult

    Raises
    ------
    SceneError
        Bad input: the scene (with the ``--set`` options) is invalid, every
        grid point is refused by the scene's schema (a wrong ``--grid`` key),
        another process is writing ``outdir`` (its lock, :class:`~contin.app.outdir.OutdirLock`, names it),
        ``outdir`` holds files and is not contin's (without ``force``), the scheduler cannot be reached,
        or Dask is not installed and ``serial`` is false
        (:class:`~contin.app.sweep_workers.MissingDependencyError`); nothing
        is written then.
    KeyboardInterrupt
        After ``sweep.csv`` has been written with the points finished so far,
        and ``sweep.json`` with status ``interrupted`` and a ``message`` that
        gives the command that resumes the sweep (:func:`sweep_command`).
    """
    t_start = time.perf_counter()
    display = None
    if echo is None:
        display = Progress(options.progress)
        echo = display.write

    def report(done: int, total: int, point, rec: dict) -> None:
        line = progress_line(done, total, point, rec)
        if display is None:
            echo(line)
            return
        # a point that failed or fell short gets a line of its own; an interrupted one ends the sweep, and its
        # line comes as the display's last
        if rec.get("status") not in ("complete", "interrupted"):
            display.write(line)
        display.update(line, done=done, total=total, task="sweep")
    scene_path = Path(options.scene)
    text, _ = read_scene_text(scene_path)  # a regular file under its cap: never a FIFO or a device
    source = str(scene_path)
    base = parse_scene(text, source, options.overrides)  # the scene itself must be valid: bad input otherwise
    _check_grid_keys(base, options.grid)
    if not options.serial:
        require_distributed()  # before anything is written
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
    check_outdir(outdir, force=options.force, flag="-o/--outdir")  # before anything is written
    try:
        points_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SceneError("-o/--outdir", "a directory that can be created and written", str(outdir),
                         hint=f" ({exc.strerror or exc})") from None
    # one writer at a time, a sweep or a run alike: the lock of contin.app.outdir (each point's run locks its own)
    with OutdirLock(outdir, flag="-o/--outdir"):
        clean_temporary_files(outdir)
        _clean_leftovers(points_dir)
        index = SweepIndex(outdir / "sweep.csv", options.grid, points)
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
                "overrides": list(options.overrides), "points": len(points), "started_at": utc_now(),
                "executor": ("serial" if options.serial else options.scheduler or
                             f"local cluster of {options.workers or os.cpu_count() or 1} worker processes")}
        write_json_atomic(outdir / "sweep.json", {**meta, "status": "running"})
        echo(f"sweep of {len(points)} points in {outdir}: {reused} already complete, {len(todo)} to run "
             f"({meta['executor']})")
        tasks = {p.index: PointTask(text, source, options.overrides + p.overrides, str(points_dir), p.name, p.index,
                                    p.values) for p in todo}
        interrupted = False
        timings: dict[str, float] = {}
        try:
            if todo:
                if display is not None:  # the remaining time counts from here, on the points to run
                    display.update(f"[{reused}/{len(points)}] running", done=reused, total=len(points), task="sweep")
                runner = run_serial if options.serial else run_dask
                first = next((p for p in todo if p.index in scenes), todo[0])
                runner(options, todo, tasks, index, report, len(points), reused, timings,
                       warm=(text, source, tasks[first.index].overrides))
        except KeyboardInterrupt:
            interrupted = True
        except BaseException as exc:
            write_json_atomic(outdir / "sweep.json", {**meta, "status": "error", "message": str(exc),
                                                      "finished_at": utc_now()})
            raise
        finally:
            if display is not None:
                display.close()
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
            t0 = time.perf_counter()
            files = sweep_map(index.rows(), options.grid, outdir / "sweep_map", formats=base.output["formats"],
                              dpi=base.output["dpi"], style=base.output["style"])
            timings["map"] = time.perf_counter() - t0
        seconds = time.perf_counter() - t_start
        end = {"status": "interrupted" if interrupted else "finished"}
        if interrupted:
            end["message"] = (f"interrupted with {counts.get('complete', 0)} of {len(points)} points complete; "
                              f"to resume, run the same command again: {sweep_command(options)} "
                              "(the complete points are not run again)")
        write_json_atomic(outdir / "sweep.json", {**meta, **end, "finished_at": utc_now(), "counts": counts,
                                                  "plots": files, "timings": {"total": seconds, **timings}})
        if interrupted:
            raise KeyboardInterrupt
    return SweepResult(records, outdir, counts, seconds)


def _check_grid_keys(scene, axes) -> None:
    """A grid over a parameter the built-in model does not have is bad input (before any run)."""
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
