"""Threads for independent compiled integrations (segments of a period, points of a circle).

The flow kernels are compiled with ``nogil=True``: while one thread
integrates a segment, another integrates the next, so ``K`` independent
integrations take about ``K / threads`` of their serial time on a machine
with free cores. Each call writes only its own arrays and the results are
gathered in order, so a run's numbers do not depend on the number of
threads.

The number of threads is ``$CONTIN_THREADS`` or the cores this process may
run on, at most :data:`MAX_THREADS`; :func:`set_threads` changes it (a sweep
running one process per core sets 1, so that they do not compete). A call
made from inside one of the threads runs its work in that thread.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor, wait
from typing import Callable, TypeVar

__all__ = ["MAX_THREADS", "map_ordered", "set_threads", "threads"]

T = TypeVar("T")

#: threads at most, whatever the cores
MAX_THREADS = 8
#: seconds between the caller's checks that its workers have ended (and for signals)
SIGNAL_POLL = 0.05

_lock = threading.Lock()
_pool: ThreadPoolExecutor | None = None
_threads: int | None = None
_inside = threading.local()


def _available() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not every platform has affinity
        return os.cpu_count() or 1


def threads() -> int:
    """The number of threads :func:`map_ordered` uses (``$CONTIN_THREADS``, else the cores available)."""
    global _threads
    if _threads is None:
        from contin.util.options import environment_count  # deferred: numpy (its names), not for --help

        _threads = min(environment_count("CONTIN_THREADS", _available()), MAX_THREADS)
    return _threads


def set_threads(n: int) -> None:
    """Use ``n`` threads from now on (1: every call in the caller's thread)."""
    global _threads, _pool
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"set_threads: n must be a positive integer, got {n!r}")
    with _lock:
        _threads = min(n, MAX_THREADS)
        if _pool is not None:
            _pool.shutdown(wait=True)
            _pool = None


def _executor() -> ThreadPoolExecutor:
    global _pool
    with _lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(max_workers=threads() - 1, thread_name_prefix="contin-flow",
                                       initializer=_mark)
        return _pool


def _mark() -> None:
    _inside.flag = True


def map_ordered(fn: Callable[[int], T], n: int) -> list[T]:
    """``[fn(0), ..., fn(n - 1)]``, spread over the threads (the caller's among them), in order.

    The first exception raised by a call is raised here once all calls have ended. ``fn`` must
    leave the GIL for its work to overlap (a ``nogil`` kernel) and must not write state that
    another call reads.
    """
    if n <= 1 or threads() <= 1 or getattr(_inside, "flag", False):
        return [fn(k) for k in range(n)]
    k_threads = threads()
    # contiguous shares: the caller takes the first, each worker one of the rest
    bounds = [round(n * i / k_threads) for i in range(k_threads + 1)]

    def share(i):
        return [fn(k) for k in range(bounds[i], bounds[i + 1])]

    futures = [_executor().submit(share, i) for i in range(1, k_threads)]
    _inside.flag = True  # a call inside the caller's share runs there too, as in the workers
    try:
        out = share(0)
    finally:
        _inside.flag = False
        # waits for all of them, in short waits: a signal's handler runs only in the main thread, between
        # its bytecodes (a Ctrl-C that a worker received would otherwise wait for the workers to end)
        while wait(futures, timeout=SIGNAL_POLL).not_done:
            pass
        rest = [f.exception() for f in futures]
    for f, exc in zip(futures, rest):
        if exc is not None:
            raise exc
        out += f.result()
    return out
