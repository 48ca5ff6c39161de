"""Kernel modules being compiled ahead in a second process: a module's first user waits for its compiled code.

numba compiles a kernel in the process that first calls it, and holds the
interpreter while it does: a run on an empty cache spends most of its time
compiling, one kernel after the other, on one core. A run whose late part
needs large kernels that are not yet cached (the main job's shooting flows,
half of its compilation: docs/benchmarks.md) has them compiled in a second process
(:mod:`contin.app.compile_ahead`) while its first part runs. Both write and
read the same private cache directory; numba writes its cache files
atomically.

This module is the registry of the main process: the generated modules being
compiled ahead and the child's reports. :func:`contin.model.codegen.load_module`
asks :func:`wait_for` before handing out a module: its first user waits until
the child reports the module compiled (or ends), then loads the compiled code
from the cache instead of compiling it a second time.

The child reports on its standard output, one module name a line, each once
its kernels are cached; a reader thread sets the module's event. End of
output (the child finished, failed or was stopped) releases every waiter: the
main process then compiles what is missing itself, as without the child.
"""

from __future__ import annotations

import threading

__all__ = ["WAIT_LIMIT", "Ahead", "active", "register", "stop", "wait_for"]

#: Longest wait (seconds) for one module; past it the main process compiles the module itself.
WAIT_LIMIT = 600.0


class Ahead:
    """A child process compiling modules ahead, and what it has reported.

    Parameters
    ----------
    process : subprocess.Popen
        The child, its standard output a text pipe of reported module names.
    names : iterable of str
        The modules it compiles.
    meanwhile : sequence of callable, optional
        Work for the main process while it would wait (compiling kernels the child does not), each called once,
        at the first wait that finds its module not yet reported; what it raises is ignored.
    """

    def __init__(self, process, names, meanwhile=()):
        self.process = process
        self.events = {name: threading.Event() for name in names}
        self.meanwhile = list(meanwhile)
        self.waited = 0.0
        self._reader = threading.Thread(target=self._read, name="contin-compile-ahead", daemon=True)
        self._reader.start()

    def _read(self) -> None:
        try:
            for line in self.process.stdout:
                ev = self.events.get((line.decode("utf-8", "replace") if isinstance(line, bytes) else line).strip())
                if ev is not None:
                    ev.set()
        except (OSError, ValueError):  # the pipe closed under the reader (stop)
            pass
        for ev in self.events.values():
            ev.set()

    def wait(self, name: str, limit: float = WAIT_LIMIT) -> bool:
        """Wait until ``name`` is reported (or the child ends); whether it was reported in time."""
        ev = self.events.get(name)
        if ev is None:
            return True
        import time  # deferred: only a waiting process needs it

        while self.meanwhile and not ev.is_set():
            try:
                self.meanwhile.pop(0)()
            except Exception:  # noqa: BLE001 - an optimisation only: what failed is compiled when first used
                pass
        t = time.perf_counter()
        done = ev.wait(limit)
        self.waited += time.perf_counter() - t
        return done

    def stop(self) -> None:
        """End the child if it still runs (what it has not cached is compiled by whoever needs it)."""
        p = self.process
        if p.poll() is None:
            p.terminate()
            try:
                p.wait(5.0)
            except Exception:  # noqa: BLE001 - a child that ignores SIGTERM: ended harder
                p.kill()
                p.wait()
        for stream in (p.stdout, p.stdin):
            if stream is not None:
                try:
                    stream.close()
                except OSError:
                    pass
        self._reader.join(1.0)


_CURRENT: Ahead | None = None


def register(process, names, meanwhile=()) -> Ahead:
    """Record ``process`` as compiling the modules ``names`` ahead (ending any earlier one first); ``meanwhile``:
    see :class:`Ahead`."""
    global _CURRENT
    stop()
    _CURRENT = Ahead(process, names, meanwhile)
    return _CURRENT


def active() -> Ahead | None:
    """The registered child, if any."""
    return _CURRENT


def wait_for(name: str) -> None:
    """Before module ``name`` is used: wait for the child compiling it ahead (nothing to do if none does)."""
    cur = _CURRENT
    if cur is not None and name in cur.events:
        cur.wait(name)


def stop() -> float:
    """End the registered child, if any; the seconds the main process waited for it."""
    global _CURRENT
    cur, _CURRENT = _CURRENT, None
    if cur is None:
        return 0.0
    cur.stop()
    return cur.waited
