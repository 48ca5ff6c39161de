"""The main process's side of kernels compiled ahead (contin.util.compile_ahead): waits end on the child's
report, on its end, or at the limit; the child is ended with the run; a generated module's first user waits."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from contin.model import codegen
from contin.util import compile_ahead


def _child(script: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)


@pytest.fixture(autouse=True)
def _no_child_left():
    yield
    compile_ahead.stop()
    assert compile_ahead.active() is None


def test_a_wait_ends_with_the_report_of_its_module_and_every_wait_with_the_childs_end():
    proc = _child("import time; print('a', flush=True); time.sleep(0.6); print('b', flush=True)")
    ahead = compile_ahead.register(proc, ["a", "b", "never"])
    t = time.perf_counter()
    assert ahead.wait("a")
    assert time.perf_counter() - t < 0.5
    compile_ahead.wait_for("b")
    assert time.perf_counter() - t >= 0.5
    assert ahead.wait("never")  # released at the end of the child's output
    assert proc.wait(5) == 0
    assert ahead.wait("not registered")
    assert compile_ahead.stop() >= 0.5


def test_a_wait_gives_up_at_its_limit_and_stop_ends_the_child():
    proc = _child("import time; time.sleep(60)")
    ahead = compile_ahead.register(proc, ["m"])
    t = time.perf_counter()
    assert not ahead.wait("m", limit=0.2)
    assert 0.2 <= time.perf_counter() - t < 5.0
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
    compile_ahead.register(_child(f"import time; time.sleep(0.5); print({name!r}, flush=True); time.sleep(60)"),
                           [name])
    t = time.perf_counter()
    module = codegen.load_module(source)
    assert time.perf_counter() - t >= 0.5
    assert module.VALUE == 7


def test_the_work_meanwhile_runs_once_at_the_first_wait_that_would_block():
    done = []
    proc = _child("import time; print('ready', flush=True); time.sleep(0.5); print('late', flush=True)")
    ahead = compile_ahead.register(proc, ["ready", "late"], meanwhile=[lambda: done.append(1), lambda: 1 / 0])
    assert ahead.events["ready"].wait(10)
    assert ahead.wait("ready") and done == []  # reported already: nothing to do meanwhile
    assert ahead.wait("late")
    assert done == [1] and ahead.meanwhile == []  # the failing one is dropped too
    assert ahead.wait("late") and done == [1]
