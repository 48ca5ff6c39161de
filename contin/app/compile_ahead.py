"""Kernels compiled ahead: a run's late kernels compiled in a second process while its first part runs.

On an empty cache a run spends most of its time letting numba compile, one
kernel after the other in the one process (docs/benchmarks.md, Compilation).
numba holds the interpreter while it compiles, so a thread does not help; a
second process does, on a machine with a second core. Before the analysis
runs, :func:`start` asks it which time-domain problems it may integrate
after its first part (:meth:`contin.analyses.base.Analysis.compile_ahead`:
``frequency_response``'s shooting and ``auto`` starts, whose harmonic-balance
part comes first) and which of their generated kernels are not in the cache
yet. If any, it starts ``python -m contin.app.compile_ahead``, hands it the
scene on its standard input, and registers the modules with
:mod:`contin.util.compile_ahead`: the run's first use of such a module waits
for the child's report, then loads the compiled code from the cache; while it
would wait, it compiles what the child does not (:func:`compile_multipliers`).

The child (:func:`main`) builds the model and the plan again from the scene,
calls each problem's residual and linearisation once (at the zero state: what
is compiled does not depend on where the flow goes), and reports each module
once its kernels are cached. It writes nothing but numba's cache, in the
same private directory (:mod:`contin.util.jit`), and is started with
``-P`` (``-I`` before Python 3.11) so that it imports contin from where the
run did, never from the current directory. Whatever fails in it, the run
compiles what it needs itself, as without it; :func:`stop` ends it with the
run. ``CONTIN_COMPILE_AHEAD=0`` turns it off.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import threading

from contin.util import compile_ahead as registry
from contin.util.jit import disk_cached

__all__ = ["ENV", "compile_multipliers", "main", "pending", "start", "stop"]

#: Set to ``0`` to compile every kernel in the run's own process.
ENV = "CONTIN_COMPILE_AHEAD"


def pending(problems) -> list[str]:
    """Names of the generated modules of ``problems`` (``(problem, value)`` pairs) whose kernels are not cached.

    Loading a module compiles nothing; numba looks for compiled code when a kernel is first called.
    """
    names = []
    for prob, _ in problems:
        for module, function in prob.kernels():
            if not disk_cached(getattr(module, function)) and module.__name__ not in names:
                names.append(module.__name__)
    return names


def start(scene, made, plan) -> list[str]:
    """Start the child if the run of ``plan`` (analysis ``made``) needs kernels not yet cached; their modules."""
    if os.environ.get(ENV, "1").strip() == "0":
        return []
    try:
        names = pending(made.compile_ahead(plan))
    except Exception:  # noqa: BLE001 - an optimisation only: whatever fails here, the run itself will meet and tell
        return []
    if not names:
        return []
    cmd = [sys.executable, "-P" if sys.version_info >= (3, 11) else "-I", "-m", "contin.app.compile_ahead"]
    try:
        proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    except OSError:
        return []  # no second process: the run compiles its kernels itself
    data = pickle.dumps(scene)

    def feed():  # a scene larger than the pipe's buffer must not hold the run up until the child reads it
        try:
            proc.stdin.write(data)
            proc.stdin.close()
        except OSError:
            pass

    threading.Thread(target=feed, name="contin-compile-ahead-feed", daemon=True).start()
    registry.register(proc, names, meanwhile=[compile_multipliers])
    return names


def compile_multipliers() -> None:
    """Compile the periodic Schur decomposition the shooting branches' multipliers need: the run's work while it
    would wait for the child's variational flow."""
    import numpy as np  # deferred: as the stability module, only where a run waits

    from contin.stability.periodic_schur import periodic_eigenvalues  # deferred: only where a run waits

    periodic_eigenvalues(np.stack([np.eye(3), 2.0 * np.eye(3)]))


def stop() -> float:
    """End the child of this run, if any; the seconds the run waited for it."""
    return registry.stop()


def _report(problems, reported: set) -> None:
    for prob, _ in problems:
        for module, function in prob.kernels():
            if module.__name__ not in reported and disk_cached(getattr(module, function)):
                reported.add(module.__name__)
                print(module.__name__, flush=True)


def main() -> int:
    """The child: compile the kernels of the scene read (pickled) from standard input; 0 when all went well."""
    import numpy as np  # deferred: the child's own work

    from contin.scene.build import build_model  # deferred: the child's work; the run has them loaded
    from contin.scene.registry import analysis  # deferred: as above

    scene = pickle.loads(sys.stdin.buffer.read())  # the run's own scene, through a pipe only it holds
    made = analysis(scene.analysis["type"])
    problems = made.compile_ahead(made.plan(scene, build_model(scene)))
    reported: set = set()
    for prob, lam in problems:
        for call in (prob.residual, prob.linearize):
            try:
                call(np.zeros(prob.size), lam)
            except (ArithmeticError, ValueError, np.linalg.LinAlgError):
                pass  # compiled before it ran: where the flow went does not matter
            _report(problems, reported)
    return 0


if __name__ == "__main__":
    sys.exit(main())
