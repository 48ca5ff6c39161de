"""Branches traced side by side: the same files as one after the other, stops and errors as one after the other.

Truth from outside the threads: the same scene run with one thread (the calls one after the other on the
run's recorder) writes the reference files; with two, each direction of the start and its handover run in a
thread of their own and their records are written afterwards, renumbered where a direction's shooting branch
gets another id than the one it was traced under.
"""

import json
import signal
from types import SimpleNamespace

import numpy as np
import pytest

from contin.analyses.side_by_side import DeferredRecorder, side_by_side
from contin.engine.branch import BranchStatus
from contin.output.results import read_csv
from contin.util import workers
from tests.analyses.test_frequency_response_handover import GAP

#: the stop oscillator of the handover's tests, started at w = 0.7 and followed both ways, down first: the
#: first direction (branch 0) reaches w = 0.6; the second (branch 1) grazes the stop at w = 0.897 and is handed
#: over to shooting (branch 2, traced in its thread as the second direction's shooting branch, 3)
GAP_BOTH_WAYS = GAP.replace("range: [0.6, 1.1]\n", "range: [0.6, 1.1]\n  start: 0.7\n  both_ways: true\n"
                            "  continuation: {direction: -1}\n")

FILES = ("branches.csv", "special_points.csv", "coefficients.csv", "state.bin")


@pytest.fixture
def restore_threads():
    before = workers.threads()
    yield
    workers.set_threads(before)


def _run(tmp_path, name, n_threads, *extra):
    from contin.app.cli import main

    scene = tmp_path / "gap.yaml"
    scene.write_text(GAP_BOTH_WAYS)
    workers.set_threads(n_threads)
    return main(["run", str(scene), "-o", str(tmp_path / name), "-q", *extra])


def _records(path):
    """``state.jsonl`` without the names of the engine states' files (new names in every run)."""
    out = []
    for line in path.read_text().splitlines():
        rec = json.loads(line)
        if rec.get("type") == "engine":
            rec["state"] = {k: v for k, v in rec["state"].items() if k != "__last__"}
        out.append(rec)
    return out


@pytest.mark.slow  # the scene twice (~4 s)
def test_two_threads_write_the_files_of_one_thread(tmp_path, restore_threads):
    assert _run(tmp_path, "one", 1) == 0
    assert _run(tmp_path, "two", 2) == 0
    for name in FILES:
        assert (tmp_path / "one" / name).read_bytes() == (tmp_path / "two" / name).read_bytes(), name
    assert _records(tmp_path / "one" / "state.jsonl") == _records(tmp_path / "two" / "state.jsonl")
    one, two = (json.loads((tmp_path / d / "summary.json").read_text())["analysis"] for d in ("one", "two"))
    assert one == two
    b0, b1, b2 = two["branches"]
    assert (b0["status"], b1["status"], b1["handed_over_to"], b2["handed_over_from"]) == ("range_end", "boundary",
                                                                                          2, 1)


@pytest.mark.slow  # the scene three times, once stopped (~6 s)
def test_a_run_stopped_in_a_thread_resumes_to_the_rows_of_one_thread(tmp_path, monkeypatch, restore_threads):
    from contin.app.progress import Progress

    assert _run(tmp_path, "ref", 1) == 0
    update, seen = Progress.update, []

    def ctrl_c(self, text, **kwargs):
        if "branch 3 (nu=1)" in text:  # the shooting branch, traced under its id in the thread
            seen.append(text)
            if len(seen) == 6:
                signal.raise_signal(signal.SIGINT)
        update(self, text, **kwargs)

    monkeypatch.setattr(Progress, "update", ctrl_c)
    assert _run(tmp_path, "run", 2) == 130
    partial = json.loads((tmp_path / "run" / "summary.json").read_text())["analysis"]["branches"]
    # the stop keeps what one thread would have: both directions, then the shooting branch as far as it got
    assert [b["status"] for b in partial] == ["range_end", "boundary", "interrupted"]
    assert 0 < partial[2]["points"] < 28
    monkeypatch.setattr(Progress, "update", update)
    assert _run(tmp_path, "run", 2, "--resume") == 0
    a, b = read_csv(tmp_path / "ref" / "branches.csv"), read_csv(tmp_path / "run" / "branches.csv")
    assert len(a["w"]) == len(b["w"])
    for col in a:
        if a[col].dtype.kind == "f":
            np.testing.assert_allclose(b[col], a[col], rtol=1e-9, atol=1e-12, err_msg=col)


class _Recorder:
    """What a BranchRecorder is asked, in order."""

    def __init__(self):
        self.log, self.failed_switches = [], []

    def point_values(self, problem, u, lam, nu):
        return u, {}, {}

    def point(self, branch_id, nu, branch, i, H=None, problem=None, values=None):
        self.log.append(("point", branch_id, i, len(branch), len(branch.special_points)))

    def checkpoint(self, branch_id, branch, state):
        self.log.append(("checkpoint", branch_id, state["points"], len(branch)))

    def special_points(self, branch_id, branch, problem=None):
        self.log.append(("special", branch_id, len(branch.special_points)))


class _Branch:
    """A branch that grows: its length and special points as they are when a call is made."""

    def __init__(self):
        self.parameter, self.unknowns, self.special_points = [], [], []
        self.info, self.status, self.message = {}, BranchStatus.RUNNING, ""

    def __len__(self):
        return len(self.parameter)

    def grow(self, special=False):
        self.parameter.append(float(len(self.parameter)))
        self.unknowns.append(np.zeros(1))
        if special:
            self.special_points.append(SimpleNamespace(kind=SimpleNamespace(value="fold"), unknowns=np.zeros(1),
                                                       parameter=0.0))


def _trace(rec, branch_id, n, ctx):
    """A branch of ``n`` points traced on ``rec``: a point, a special point every third, a checkpoint."""
    br = _Branch()
    for i in range(n):
        br.grow(special=i % 3 == 2)
        rec.point(branch_id, 1, br, i, problem=None)
        rec.checkpoint(branch_id, br, {"points": len(br)})
    br.status = BranchStatus.INTERRUPTED if ctx.stop_requested else BranchStatus.RANGE_END
    rec.special_points(branch_id, br)
    return [(br, {})]


def _ctx():
    return SimpleNamespace(stop_requested=False, progress=SimpleNamespace(enabled=False, update=lambda *a, **k: None))


@pytest.mark.parametrize("n_threads", [1, 2])
def test_the_calls_reach_the_recorder_as_they_were_made(restore_threads, n_threads):
    workers.set_threads(n_threads)
    direct = _Recorder()
    for bid, n in ((0, 5), (1, 4)):
        _trace(direct, bid, n, _ctx())
    rec = _Recorder()
    out = side_by_side([lambda r, c: _trace(r, 0, 5, c), lambda r, c: _trace(r, 1, 4, c)], rec, _ctx(), "branches")
    assert rec.log == direct.log  # each call sees the branch as it was then: its length, its special points
    assert [len(r[0][0]) for r in out] == [5, 4]


def test_an_error_in_a_thread_is_raised_once_the_calls_before_it_are_written(restore_threads):
    workers.set_threads(2)

    def fails(r, c):
        _trace(r, 1, 2, c)
        raise RuntimeError("a bug in the second call")

    rec = _Recorder()
    with pytest.raises(RuntimeError, match="a bug in the second call"):
        side_by_side([lambda r, c: _trace(r, 0, 3, c), fails], rec, _ctx(), "branches")
    assert {entry[1] for entry in rec.log} == {0}  # the first call's records, none of the failed one's


def test_calls_after_an_interrupted_one_are_dropped(restore_threads):
    workers.set_threads(2)
    ctx = _ctx()

    def stopped(r, c):
        ctx.stop_requested = True  # as a signal would: on the run's context, which both threads read
        return _trace(r, 0, 2, c)

    rec = _Recorder()
    out = side_by_side([stopped, lambda r, c: _trace(r, 1, 3, c)], rec, ctx, "branches")
    assert out[0][0][0].status is BranchStatus.INTERRUPTED and out[1] is None
    assert {entry[1] for entry in rec.log} == {0}


def test_a_deferred_recorder_renumbers_one_branch(restore_threads):
    log = DeferredRecorder(_Recorder())
    _trace(log, 3, 2, _ctx())
    _trace(log, 1, 1, _ctx())
    rec = _Recorder()
    log.replay(rec, 3, 2)
    assert [entry[1] for entry in rec.log] == [2] * 5


def test_contin_kernels_leave_the_gil():
    from contin.hb.aft import synthesize
    from contin.stability.rk4 import variational_rk4
    from contin.util.jit import njit

    assert synthesize.targetoptions["nogil"] and variational_rk4.targetoptions["nogil"]
    assert njit(cache=True)(lambda x: x).targetoptions["nogil"]
    assert not njit(nogil=False)(lambda x: x).targetoptions.get("nogil", False)
