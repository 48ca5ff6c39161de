"""The main process's side of kernels compiled ahead (contin.util.compile_ahead): waits end on the child's
report, on its end, or at the limit; the child is ended with the run; a generated module's first user waits."""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import pytest

from contin.model import codegen
from contin.util import compile_ahead


def _child(script: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", script], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL)


#: a child that reports 'a' at once, then 'b' once the test writes a line to it, then ends
TWO_REPORTS = "import sys; print('a', flush=True); sys.stdin.readline(); print('b', flush=True)"


def _release(proc) -> None:
    proc.stdin.write(b"go\n")
    proc.stdin.flush()


@pytest.fixture(autouse=True)
def _no_child_left():
    yield
    compile_ahead.stop()
    assert compile_ahead.active() is None


def test_a_wait_ends_with_the_report_of_its_module_and_every_wait_with_the_childs_end():
    proc = _child(TWO_REPORTS)
    ahead = compile_ahead.register(proc, ["a", "b", "never"])
    assert ahead.wait("a", limit=30)
    assert not ahead.wait("b", limit=0.2)  # not reported while the child holds it back
    _release(proc)
    assert ahead.wait("b", limit=30)
    assert ahead.wait("never", limit=30)  # released at the end of the child's output
    assert proc.wait(30) == 0
    assert ahead.wait("not registered")
    assert compile_ahead.stop() >= 0.0


def test_stop_ends_a_child_still_running():
    proc = _child("import time; time.sleep(60)")
    compile_ahead.register(proc, ["m"])
    compile_ahead.stop()
    assert proc.poll() is not None


def test_registering_a_second_child_ends_the_first():
    first = _child("import time; time.sleep(60)")
    compile_ahead.register(first, ["m"])
    compile_ahead.register(_child("pass"), ["n"])
    assert first.poll() is not None
    assert set(compile_ahead.active().events) == {"n"}


def test_the_first_user_of_a_generated_module_waits_for_its_report():
    source = f"# contin generated test module {time.time_ns()}\nVALUE = 7\n"
    name = codegen.module_name(source)
    proc = _child(f"import sys; sys.stdin.readline(); print({name!r}, flush=True); sys.stdin.readline()")
    compile_ahead.register(proc, [name])
    loaded = []
    user = threading.Thread(target=lambda: loaded.append(codegen.load_module(source)))
    user.start()
    user.join(0.5)
    assert user.is_alive() and not loaded  # held until the child reports the module
    _release(proc)
    user.join(30)
    assert loaded and loaded[0].VALUE == 7


def test_the_work_meanwhile_runs_once_at_the_first_wait_that_would_block():
    done = []
    proc = _child(TWO_REPORTS)
    ahead = compile_ahead.register(proc, ["a", "b"], meanwhile=[lambda: done.append(1), lambda: 1 / 0])
    assert ahead.events["a"].wait(30)
    assert ahead.wait("a") and done == []  # reported already: nothing to do meanwhile
    assert not ahead.wait("b", limit=0.2)  # held back by the child: the work meanwhile runs first
    assert done == [1] and ahead.meanwhile == []  # the failing one is dropped too
    _release(proc)
    assert ahead.wait("b", limit=30)
    assert ahead.wait("b") and done == [1]
