"""Run a scene: build its model, run its analysis, write the result files and plots."""

from __future__ import annotations

import platform
import signal
import time
from pathlib import Path

import numpy as np

from contin.util.version import __version__
from contin.output.checkpoint import CheckpointError, read_records, rebuild_branches, resumable_prefix
from contin.app.progress import Progress
from contin.output.exports import write_exports
from contin.output.labels import model_symbols
from contin.output.results import write_json_atomic
from contin.scene.parse import Scene, SceneError, model_frequency
from contin.scene.build import build_model
from contin.scene.registry import RunContext, RunError

__all__ = ["run_scene", "versions"]


def versions() -> dict:
    import numba
    import scipy

    return {"contin": __version__, "python": platform.python_version(), "numpy": np.__version__,
            "scipy": scipy.__version__, "numba": numba.__version__}


def run_scene(scene: Scene, outdir: str | Path, progress: bool = True, resume: bool = False) -> dict:
    """Run a validated scene and write its results into ``outdir``.

    Every check of the scene (:func:`contin.scene.registry.check_scene`) is made
    before anything is written.

    Parameters
    ----------
    resume : bool
        Continue an interrupted run in ``outdir`` (same scene) from its
        checkpoint instead of starting anew.

    Returns
    -------
    dict
        The content of ``summary.json``. Its ``status`` is ``complete`` when
        the analysis did everything the scene asked, ``incomplete`` when it
        fell short (``shortfalls`` says where and why), ``interrupted``, or
        ``failed`` (a run that could not proceed; :class:`RunError` is raised).
    """
    from contin.scene.registry import check_scene, get_runner

    t0 = time.perf_counter()
    outdir = Path(outdir)
    model = build_model(scene)
    plan = check_scene(scene, model)
    resumed_from = None
    if resume:
        resumed_from = _check_resumable(scene, outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    ctx = RunContext(scene, model, outdir, Progress(progress), resume=resumed_from is not None, plan=plan,
                     run_scene=run_scene)
    ctx.timings["model"] = time.perf_counter() - t0
    summary = {"status": "running", "scene": scene.data, "source": scene.source, "versions": versions(),
               "model": {"name": model.name, "dofs": list(model.dof_names), "effects": list(model.effects),
                         "terms": model.describe().splitlines()[1:],
                         "frequency": model_frequency(scene.model, scene.analysis) or model.frequency,
                         "parameters": dict(zip(model.param_names, map(float, model.parameter_vector()))),
                         "symbols": model_symbols(model)},
               "timings": ctx.timings, "resumed": resumed_from}
    write_json_atomic(outdir / "summary.json", summary)

    def on_sigint(signum, frame):
        ctx.stop_requested = True

    previous = signal.signal(signal.SIGINT, on_sigint) if _main_thread() else None
    try:
        try:
            result = get_runner(scene.analysis["type"])(ctx)
            files = []
            if scene.output["plots"] and ctx.plot is not None:
                tp = time.perf_counter()
                files += ctx.plot()
                ctx.timings["plots"] = time.perf_counter() - tp
        finally:
            if previous is not None:
                signal.signal(signal.SIGINT, previous)
            ctx.progress.close()
    except BaseException as exc:
        # never leave the files saying `running`
        message = str(exc) if isinstance(exc, (RunError, SceneError)) else f"{type(exc).__name__}: {exc}"
        summary.update({"status": "interrupted" if isinstance(exc, KeyboardInterrupt) else "failed",
                        "message": message, "timings": ctx.timings})
        write_json_atomic(outdir / "summary.json", summary)
        raise
    ctx.timings["total"] = time.perf_counter() - t0
    shortfalls = list(result.get("shortfalls") or []) if isinstance(result, dict) else []
    if ctx.interrupted or ctx.stop_requested:
        status = "interrupted"
    else:
        status = "incomplete" if shortfalls else "complete"
    summary.update({"status": status, "shortfalls": shortfalls, "analysis": result, "plots": files,
                    "timings": ctx.timings})
    if status == "incomplete":
        summary["message"] = "; ".join(shortfalls)
    summary["exports"] = write_exports(outdir, scene.output["exports"], summary)
    write_json_atomic(outdir / "summary.json", summary)
    return summary


def _check_resumable(scene: Scene, outdir: Path):
    """The earlier run's summary if ``outdir`` holds an unfinished run of the same scene, else None."""
    import json

    path = outdir / "summary.json"
    if not path.exists() or not (outdir / "state.jsonl").exists():
        return None  # nothing to resume: a fresh run
    try:
        old = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
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
    return {"status": old.get("status"), "timings": old.get("timings")}


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()
