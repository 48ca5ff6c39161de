"""Running the points of a parameter sweep: in this process, or on the workers of a Dask cluster, warmed up once.

:func:`run_dask` submits every point (:func:`~contin.app.sweep_point.run_point`)
to a ``distributed`` cluster, an embedded ``LocalCluster`` or an existing
scheduler (:func:`_client`), and records the results as they complete;
:func:`run_serial` runs them one after another in this process. Each worker
loads the kernels and the plotting stack once, when it starts
(:class:`WarmUp`, :func:`warm_up`), not in every task.

Dask is an optional dependency (``pip install "contin[sweep]"``): this module
imports ``distributed`` only when the points run on a cluster, so a serial
sweep and ``contin run`` never load it; :func:`require_distributed` turns its
absence into a message before the sweep writes anything.
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
import uuid

from contin.app.sweep_point import prepare_process, run_point, utc_now
from contin.scene.schema import SceneError

__all__ = ["WarmUp", "warm_up", "require_distributed", "MissingDependencyError",  # noqa: F822 (WarmUp: __getattr__)
           "run_serial", "run_dask"]

#: what ``contin sweep`` says when Dask is needed and not installed
DASK_MISSING = ("contin sweep runs its points on Dask (the dask.distributed package), which is not installed. "
                "Install it with: pip install \"contin[sweep]\" (or: pip install \"dask[distributed]\"); or run "
                "the points one after another in this process, without Dask, with --serial.")


class MissingDependencyError(SceneError):
    """An optional package that the requested way of running needs is not installed (bad input: exit status 2)."""

    def __init__(self, message: str):
        ValueError.__init__(self, message)
        self.key, self.expected, self.found, self.line = "contin sweep", message, None, None


def require_distributed() -> None:
    """Raise :class:`MissingDependencyError` if ``distributed`` cannot be imported."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise MissingDependencyError(DASK_MISSING) from None


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
    prepare_process()
    status = "ok"
    try:
        import io

        # deferred: a worker unpickles this module on its event loop; the warm-up loads all this in its thread
        from contin.output.figures import new_figure  # deferred: matplotlib, in the warm-up's thread (above)
        from contin.scene.build import build_model  # deferred: numba kernels, in the warm-up's thread
        from contin.scene.parse import parse_scene  # deferred: in the warm-up's thread

        fig = new_figure((1, 1))  # loads matplotlib's fonts and PNG writer once, outside the tasks
        fig.add_subplot().plot([0, 1], [0, 1], "--")
        fig.savefig(io.BytesIO(), format="png")
        scene = parse_scene(scene_text, scene_source, overrides)
        model = build_model(scene)
        if scene.analysis["type"] == "frequency_response":
            from contin.analyses.frequency_response import build_problem  # deferred: in the warm-up's thread

            hb = build_problem(scene, model)
            lam = float(scene.analysis["range"][0])
            u = hb.linear_solution(lam)
            hb.linearize(u, lam)
            if scene.analysis["stability"] != "none":
                from contin.analyses.stability_hooks import stability_options  # deferred: in the warm-up's thread
                from contin.stability import StabilityMonitor  # deferred: in the warm-up's thread

                StabilityMonitor(hb, stability_options(scene.analysis)).analyze(u, lam)
    except Exception as exc:  # noqa: BLE001  (a warm-up never fails a worker)
        status = f"{type(exc).__name__}: {exc}"
    return {"seconds": time.perf_counter() - t0, "status": status}


def _warm_up_class():
    """The :class:`WarmUp` plugin class, made on first use: it derives from distributed's ``WorkerPlugin``."""
    cls = globals().get("WarmUp")
    if cls is None:
        from distributed.diagnostics.plugin import WorkerPlugin

        cls = globals()["WarmUp"] = type("WarmUp", (_WarmUpMixin, WorkerPlugin), {"__module__": __name__})
        cls.__doc__ = _WarmUpMixin.__doc__
    return cls


def __getattr__(name):
    # ``WarmUp`` (imported, or looked up by pickle on a worker) is made when first asked for, so that
    # importing this module does not import distributed
    if name == "WarmUp":
        return _warm_up_class()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class _WarmUpMixin:
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



def run_serial(options, todo, tasks, index, report, total, done, timings, warm):
    """The points one after another in this process (no Dask): the baseline and a debugging aid.

    ``report(done, total, point, record)`` is called as each point finishes.
    """
    for p in todo:
        rec = run_point(tasks[p.index])
        rec["reused"] = False
        index.set(p, rec)
        done += 1
        report(done, total, p, rec)
        if rec["status"] == "interrupted":  # Ctrl-C inside the run: it stopped after its current point
            raise KeyboardInterrupt


def _worker_env() -> dict:
    # the workers fill the cores: no second process compiling a run's kernels ahead (contin.app.compile_ahead),
    # and one thread for the flows (contin.util.workers)
    return {"MPLBACKEND": "Agg", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
            "CONTIN_COMPILE_AHEAD": "0", "CONTIN_THREADS": "1"}


@contextlib.contextmanager
def _client(options, timings):
    """A ``distributed.Client`` on the given scheduler, or on an embedded ``LocalCluster`` it starts and stops."""
    require_distributed()
    from distributed import Client, LocalCluster

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


def run_dask(options, todo, tasks, index, report, total, done, timings, warm):
    """The points on a Dask cluster; ``report(done, total, point, record)`` as each finishes."""
    require_distributed()
    from distributed import as_completed

    WarmUp = _warm_up_class()
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
                                  f"{type(result).__name__}: {result}", "finished_at": utc_now()}
            else:
                rec = result
            rec["reused"] = False
            index.set(p, rec)
            done += 1
            report(done, total, p, rec)
            fut.release()
        timings["tasks"] = time.perf_counter() - t0
        if options.scheduler is not None:  # leave an existing cluster as it was
            with contextlib.suppress(Exception):
                client.unregister_worker_plugin(WarmUp.name)
        t_end = time.perf_counter()
    timings["shutdown"] = time.perf_counter() - t_end
