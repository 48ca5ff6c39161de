"""Run a scene: build its model, run its analysis, write the result files and plots.

A run owns its output directory while it runs (:class:`contin.app.outdir.OutdirLock`):
a directory that holds files and is not contin's is refused unless ``force``, a
second writer is refused while the lock is held, and SIGINT, SIGTERM and SIGHUP
stop the run at its next point with its files saying ``interrupted``. A file
that cannot be written during the run ends it as ``failed`` with
:class:`WriteFailed`, which names the file.
"""

from __future__ import annotations

import platform
import signal
import time
from pathlib import Path

import numpy as np

from contin.util.version import __version__
from contin.output.checkpoint import CheckpointError, read_records, rebuild_branches, resumable_prefix
from contin.app.outdir import OutdirLock, check_outdir, clean_temporary_files
from contin.app.progress import Progress
from contin.app.run_inputs import check_same_inputs, model_fingerprint, scene_inputs
from contin.output.exports import write_exports
from contin.output.outcome import Outcome, Sink
from contin.output.labels import model_symbols
from contin.output.results import write_json_atomic
from contin.scene.parse import Scene, SceneError, model_frequency
from contin.scene.build import build_model
from contin.app import compile_ahead
from contin.scene.registry import analysis, check_scene
from contin.util.safe_files import open_regular
from contin.analyses.base import RunContext, RunError

__all__ = ["execute", "run_scene", "versions", "WriteFailed", "STOP_SIGNALS"]

#: the signals that stop a run at its next point, as Ctrl-C does (what schedulers, ``timeout`` and a closed
#: terminal send)
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))


class WriteFailed(RunError):
    """A result file could not be written during a run (a full disk, no permission, a read-only file system).

    Attributes
    ----------
    filename : str or None
        The file.
    strerror : str
        Why (the system's words).
    """

    def __init__(self, exc: OSError):
        import errno

        self.filename, self.strerror = exc.filename, exc.strerror or str(exc)
        where = f"{exc.filename}: " if exc.filename else ""
        # a full disk or a read-only file system fails writes; a permission, either (a resume reads its files)
        verb = "write" if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS) else "write or read"
        super().__init__(f"could not {verb} {where}{self.strerror}")


def versions() -> dict:
    import numba
    import scipy

    return {"contin": __version__, "python": platform.python_version(), "numpy": np.__version__,
            "scipy": scipy.__version__, "numba": numba.__version__}


def run_scene(scene: Scene, outdir: str | Path, progress: bool = True, resume: bool = False, force: bool = False,
              resume_command: str | None = None) -> dict:
    """Run a validated scene into ``outdir``; returns ``summary.json``'s content (:func:`execute`'s summary)."""
    return execute(scene, outdir, progress, resume, force, resume_command).summary


def execute(scene: Scene, outdir: str | Path | None = None, progress: bool = True, resume: bool = False,
            force: bool = False, resume_command: str | None = None) -> Outcome:
    """Run a validated scene: in memory, and into ``outdir`` when given.

    Every check of the scene (:func:`contin.scene.registry.check_scene`) and of
    ``outdir`` (:func:`contin.app.outdir.check_outdir`) is made before anything
    is written. ``outdir`` is locked for the whole run. Without ``outdir``
    nothing is written: the tables, the summary and the solutions are held in
    the returned outcome only (the Python API).

    Parameters
    ----------
    outdir : path or None
    resume : bool
        Continue an interrupted run in ``outdir`` (same scene, same files read,
        same model) from its checkpoint instead of starting anew.
    force : bool
        Write into a directory that holds files and is not contin's.
    resume_command : str, optional
        The command that resumes this run, for the ``message`` of an
        interrupted run's ``summary.json``.

    Returns
    -------
    Outcome
        Its ``summary`` is the content of ``summary.json``, whose ``status`` is
        ``complete`` when the analysis did everything the scene asked,
        ``incomplete`` when it fell short (``shortfalls`` says where and why),
        ``interrupted``, or ``failed`` (a run that could not proceed;
        :class:`RunError` is raised, :class:`WriteFailed` when a result file
        could not be written).

    Raises
    ------
    SceneError
        Bad input, before anything is written: the scene, ``outdir`` (not
        contin's, a link where a result file goes, locked by another process),
        or a ``resume`` that cannot go on (another scene, changed files).
    """
    t0 = time.perf_counter()
    if outdir is not None and str(outdir) == "":
        raise SceneError("-o", "a directory name for the results", "")
    if outdir is None and (resume or force):
        raise SceneError("resume" if resume else "force", "a result directory (outdir) to resume or write into",
                         None)
    model = build_model(scene)
    plan = check_scene(scene, model)
    inputs, fingerprint = scene_inputs(scene), model_fingerprint(model)
    summary = {"status": "running", "scene": scene.data, "source": scene.source, "versions": versions(),
               "inputs": inputs, "fingerprint": fingerprint,
               "model": {"name": model.name, "dofs": list(model.dof_names), "effects": list(model.effects),
                         "terms": model.describe().splitlines()[1:],
                         "frequency": model_frequency(scene.model, scene.analysis) or model.frequency,
                         "parameters": dict(zip(model.param_names, map(float, model.parameter_vector()))),
                         "symbols": model_symbols(model)}}
    if outdir is None:
        ctx = RunContext(scene, model, Sink(None), Progress(progress), run_scene=execute)
        ctx.timings["model"] = time.perf_counter() - t0
        summary.update(timings=ctx.timings, resumed=None)
        return _run(ctx, plan, summary, t0, resume_command)
    outdir = Path(outdir)
    check_outdir(outdir, force=force)
    outdir.mkdir(parents=True, exist_ok=True)
    with OutdirLock(outdir):
        resumed_from = None
        if resume:
            resumed_from = _check_resumable(scene, outdir, inputs, fingerprint)
        clean_temporary_files(outdir)
        ctx = RunContext(scene, model, Sink(outdir), Progress(progress), resume=resumed_from is not None,
                         run_scene=execute)
        ctx.timings["model"] = time.perf_counter() - t0
        summary.update(timings=ctx.timings, resumed=resumed_from)
        return _run(ctx, plan, summary, t0, resume_command)


def _run(ctx: RunContext, plan, summary: dict, t0: float, resume_command: str | None) -> Outcome:
    """Run the analysis of ``ctx`` (its directory locked) and write its files; returns the outcome."""
    scene, outdir = ctx.scene, ctx.outdir
    ctx.summary = summary
    signals = []

    def on_signal(signum, frame):
        ctx.stop_requested = True
        signals.append(signal.Signals(signum).name)
        if signum == getattr(signal, "SIGHUP", None):
            ctx.progress.enabled = False  # the terminal is gone: writing to it would fail

    # SIGTERM and SIGHUP as Ctrl-C: the run stops at its next point, its files say `interrupted`; a signal the
    # run was started to ignore (nohup) stays ignored
    previous = {}
    if _main_thread():
        for s in STOP_SIGNALS:
            if s == signal.SIGINT or signal.getsignal(s) is not signal.SIG_IGN:
                previous[s] = signal.signal(s, on_signal)
    ahead = []
    try:
        try:
            if outdir is not None:
                write_json_atomic(outdir / "summary.json", summary)
            made = analysis(scene.analysis["type"])
            ahead += compile_ahead.start(scene, made, plan)  # the run's late kernels, compiled meanwhile
            outcome = made.run(plan, ctx)
            files = []
            if scene.output["plots"] and outcome.draw is not None and ctx.sink.writes:
                tp = time.perf_counter()
                files += outcome.draw()
                ctx.timings["plots"] = time.perf_counter() - tp
        finally:
            if ahead:
                ctx.timings["compile_ahead_wait"] = compile_ahead.stop()
            for s, handler in previous.items():
                signal.signal(s, handler)
            ctx.progress.close()
            ctx.sink.close()
    except BaseException as exc:
        # never leave the files saying `running`
        message = str(exc) if isinstance(exc, (RunError, SceneError)) else f"{type(exc).__name__}: {exc}"
        if isinstance(exc, OSError) and outdir is not None:
            _failed_write(summary, outdir, WriteFailed(exc), resume_command, ctx.timings)
        interrupted = isinstance(exc, KeyboardInterrupt)
        if interrupted and resume_command:
            message = f"interrupted; to resume from the last stored point: {resume_command}"
        summary.update({"status": "interrupted" if interrupted else "failed", "message": message,
                        "timings": ctx.timings})
        if outdir is not None:
            write_json_atomic(outdir / "summary.json", summary)
        raise
    ctx.timings["total"] = time.perf_counter() - t0
    shortfalls = list(outcome.shortfalls)
    if ctx.interrupted or ctx.stop_requested:
        status = "interrupted"
    else:
        status = "incomplete" if shortfalls else "complete"
    summary.update({"status": status, "shortfalls": shortfalls, "analysis": outcome.analysis, "plots": files,
                    "timings": ctx.timings})
    if status == "incomplete":
        summary["message"] = "; ".join(shortfalls)
    elif status == "interrupted":
        by = f" by {signals[0]}" if signals and signals[0] != "SIGINT" else ""
        summary["message"] = f"interrupted{by}" + (f"; to resume from the last stored point: {resume_command}"
                                                   if resume_command else "")
    outcome.summary, outcome.files = summary, files
    if outcome.data is not None:
        outcome.data["summary"] = summary
    if outdir is None:
        return outcome
    try:
        expand = getattr(ctx.recorder, "expansion", None)  # condensed branches' full coefficients
        summary["exports"] = write_exports(outdir, scene.output["exports"], summary, expand, data=outcome.data)
        write_json_atomic(outdir / "summary.json", summary)
    except OSError as exc:
        _failed_write(summary, outdir, WriteFailed(exc), resume_command, ctx.timings)
    return outcome


def _failed_write(summary: dict, outdir: Path, failed: WriteFailed, resume_command: str | None, timings) -> None:
    """Record a run ended by a file it could not write (``failed``, the file named), and raise ``failed``."""
    message = str(failed) + (f"; once it can be written, resume the run: {resume_command}" if resume_command else "")
    summary.update({"status": "failed", "message": message, "timings": timings})
    try:
        write_json_atomic(outdir / "summary.json", summary)
    except OSError:
        pass  # the disk that failed the run may fail this too: the error that ended it is what counts
    raise failed from None


def _check_resumable(scene: Scene, outdir: Path, inputs: dict, fingerprint: str):
    """The earlier run's summary if ``outdir`` holds an unfinished run of the same scene, else None."""
    import json

    path = outdir / "summary.json"
    if not path.exists() or not (outdir / "state.jsonl").exists():
        return None  # nothing to resume: a fresh run
    try:
        with open_regular(path) as fh:
            old = json.loads(fh.read(), parse_constant=_refuse_constant)
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise SceneError("--resume", f"a summary.json written by contin in {outdir}", "a file that does not parse",
                         hint=f" ({exc}); run again without --resume, or use another -o") from None
    if not isinstance(old, dict):
        raise SceneError("--resume", f"a summary.json written by contin in {outdir}", type(old).__name__)
    for name in ("branches.csv", "special_points.csv"):
        if not (outdir / name).is_file():
            continue
        try:
            (outdir / name).read_bytes().decode("utf-8")
        except UnicodeDecodeError as exc:
            raise SceneError("--resume", f"a {name} written by contin", "a file that is not UTF-8",
                             hint=f" ({exc}); run again without --resume, or use another -o") from None
    try:
        records, _, _ = resumable_prefix(read_records(outdir / "state.jsonl"), 1 << 62)
        rebuild_branches(records, "lambda")
    except (CheckpointError, ValueError, KeyError, TypeError, IndexError) as exc:  # what contin never writes
        raise SceneError("--resume", "a state.jsonl written by contin", str(exc),
                         hint="; run again without --resume, or use another -o") from None
    if old.get("scene") != json.loads(json.dumps(scene.data)):
        raise SceneError("--resume", f"the same scene as the run in {outdir}", "a different scene",
                         hint="; resume with the scene and --set options of that run, or use another -o")
    if old.get("status") == "complete":
        raise SceneError("--resume", f"an unfinished run in {outdir}", "a complete run")
    check_same_inputs(old, inputs, fingerprint, outdir)
    return {"status": old.get("status"), "timings": old.get("timings")}


def _refuse_constant(token: str):
    raise ValueError(f"{token} is not JSON (contin writes a value that is not finite as null)")


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()
