"""Threads for independent integrations: order, errors, nesting and the thread count's settings."""

import threading

import pytest

from contin.util import workers


@pytest.fixture
def restore():
    before = workers.threads()
    yield
    workers.set_threads(before)


@pytest.mark.parametrize("n_threads", [1, 2, 3])
@pytest.mark.parametrize("n", [0, 1, 2, 5, 31])
def test_results_in_order(restore, n_threads, n):
    workers.set_threads(n_threads)
    assert workers.map_ordered(lambda k: k * k, n) == [k * k for k in range(n)]


def test_work_shared_with_a_worker(restore):
    workers.set_threads(2)
    seen = workers.map_ordered(lambda k: threading.get_ident(), 4)
    assert seen[0] == seen[1] == threading.get_ident()  # the caller's share: the first half
    assert seen[2] == seen[3] != threading.get_ident()


def test_one_thread_stays_in_the_caller(restore):
    workers.set_threads(1)
    assert set(workers.map_ordered(lambda k: threading.get_ident(), 6)) == {threading.get_ident()}


def test_a_call_from_a_worker_runs_there(restore):
    workers.set_threads(2)

    def inner(k):
        here = threading.get_ident()
        return {here} == set(workers.map_ordered(lambda j: threading.get_ident(), 4))

    assert workers.map_ordered(inner, 2) == [True, True]  # no nested pool: no deadlock either


def test_an_error_is_raised_after_all_calls_ended(restore):
    workers.set_threads(2)
    done = []

    def fn(k):
        if k == 3:
            raise ArithmeticError("segment 3 blew up")
        done.append(k)
        return k

    with pytest.raises(ArithmeticError, match="segment 3 blew up"):
        workers.map_ordered(fn, 4)
    assert sorted(done) == [0, 1, 2]


@pytest.mark.parametrize("bad", [0, -1, 2.0, True, "2"])
def test_set_threads_rejects(bad):
    with pytest.raises(ValueError, match="positive integer"):
        workers.set_threads(bad)


@pytest.mark.parametrize("text", ["0", "two", "-3"])
def test_environment_rejects(restore, monkeypatch, text):
    monkeypatch.setenv("CONTIN_THREADS", text)
    monkeypatch.setattr(workers, "_threads", None)
    with pytest.raises(ValueError, match="CONTIN_THREADS must be a positive integer"):
        workers.threads()


def test_environment_sets_the_count(restore, monkeypatch):
    monkeypatch.setenv("CONTIN_THREADS", "64")
    monkeypatch.setattr(workers, "_threads", None)
    assert workers.threads() == workers.MAX_THREADS
    monkeypatch.setenv("CONTIN_THREADS", "1")
    monkeypatch.setattr(workers, "_threads", None)
    assert workers.threads() == 1
