"""The progress display: bars with percentage and ETA on a terminal, few plain lines in a log, silence when short."""

import io
import re

import numpy as np
import pytest

from contin.app.progress import Progress, covered_fraction


class Clock:
    """A fake monotonic clock: tests step it instead of sleeping."""

    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


class Terminal(io.StringIO):
    def isatty(self):
        return True


def run_branch(progress, clock, seconds, rate=10.0, t0=0.0, task="branch 0", bounds=(1.0, 3.0)):
    """A branch from bounds[0] to bounds[1], one point every 1/rate s."""
    n = int(seconds * rate)
    lam = np.linspace(bounds[0], bounds[1], n + 1)
    for i in range(n + 1):
        clock.t = t0 + i / rate
        progress.update(f"{task}  w={lam[i]:.4g}  point {i}", parameter=lam[:i + 1], bounds=bounds, task=task)
    return n + 1


def test_covered_fraction_of_a_branch():
    assert covered_fraction([1.0, 1.5, 2.0], (1.0, 3.0)) == pytest.approx(0.5)
    # a branch that turns back at a fold keeps the furthest point it reached
    assert covered_fraction([1.0, 2.0, 2.5, 2.2, 1.8], (1.0, 3.0)) == pytest.approx(0.75)
    # from an interior start towards the lower end (a switched branch, the second run of both_ways)
    assert covered_fraction([2.0, 1.75, 1.5], (1.0, 3.0)) == pytest.approx(0.5)
    assert covered_fraction([2.0, 1.0], (1.0, 3.0)) == 1.0
    # bounds in either order; no meaningful fraction: no point, or a range of zero length
    assert covered_fraction([3.0, 2.0], (3.0, 1.0)) == pytest.approx(0.5)
    assert covered_fraction([], (1.0, 3.0)) is None
    assert covered_fraction([2.0, 2.0], (2.0, 2.0)) is None


def test_a_log_gets_few_plain_lines_without_carriage_returns():
    clock, log = Clock(), io.StringIO()
    p = Progress(stream=log, clock=clock)
    assert not p.terminal
    calls = run_branch(p, clock, 18.0)  # an 18 s branch reported at every one of its points
    calls += run_branch(p, clock, 2.0, t0=18.5, task="branch 1", bounds=(3.0, 1.0))
    p.close()
    text = log.getvalue()
    lines = text.splitlines()
    assert calls > 200 and "\r" not in text
    # silent for the first second, then at most one line per 10 s, and one at the end of each branch
    assert len(lines) == 4, text
    assert lines[0].startswith("branch 0  w=1.111  point 10") and " 6%, 00:01 elapsed, 00:16 left" in lines[0]
    assert lines[1].startswith("branch 0  w=2.222  point 110") and " 61%" in lines[1]
    assert lines[2] == "branch 0  w=3  point 180  ended: covered [1, 3] of [1, 3], 00:18 elapsed"
    assert lines[3] == "branch 1  w=1  point 20  ended: covered [1, 3] of [1, 3], 00:02 elapsed"


def test_a_branch_that_stops_early_ends_its_log_with_the_interval_covered():
    # before: "branch 0  w=1.16  point 8  8%, 00:03 elapsed, 00:34 left", a percentage and a time left
    # that went stale when the branch stopped
    clock, log = Clock(), io.StringIO()
    p = Progress(stream=log, clock=clock, delay=0.0, log_interval=100.0)
    lam = [1.0, 1.05, 1.1, 1.2, 1.16]  # turned back at a fold, then stopped
    for i in range(len(lam)):
        clock.t = 0.75 * i
        p.update(f"branch 0  w={lam[i]:.4g}  point {i}", parameter=np.array(lam[:i + 1]), bounds=(3.0, 1.0),
                 task="branch 0")
    p.close()
    lines = log.getvalue().splitlines()
    assert lines[-1] == "branch 0  w=1.16  point 4  ended: covered [1, 1.2] of [1, 3], 00:03 elapsed"
    assert not any(re.search(r"left|\d+%", line) for line in lines[1:]), lines


def test_short_runs_print_nothing():
    clock, log = Clock(), io.StringIO()
    p = Progress(stream=log, clock=clock)
    run_branch(p, clock, 0.9)
    clock.t = 0.95
    p.close()
    assert log.getvalue() == ""


def test_counts_and_text_only_tasks():
    clock, log = Clock(), io.StringIO()
    p = Progress(stream=log, clock=clock, delay=0.0)
    for i in range(4):  # settings of a convergence study: done of total
        clock.t = 3.0 * i
        p.update(f"setting {i + 1}/4", done=i, total=4, task="settings")
    clock.t = 12.0
    p.update("shooting at F=0.5", task="shooting")  # no total: the text and the elapsed time
    clock.t = 14.0
    p.close()
    lines = log.getvalue().splitlines()
    assert lines[0].startswith("setting 1/4  0%")
    assert lines[1] == "setting 4/4  ended: 3 of 4 done, 00:12 elapsed"  # at the end of the task, when the next starts
    assert lines[-1] == "shooting at F=0.5  (00:02 elapsed)"


def test_a_terminal_gets_a_bar_with_percentage_and_remaining_time():
    clock, tty = Clock(), Terminal()
    p = Progress(stream=tty, clock=clock, interval=0.0)
    assert p.terminal
    run_branch(p, clock, 3.0)
    p.close()
    text = tty.getvalue()
    assert "\r" in text and text.endswith("\n")
    last = text.rstrip("\n").split("\r")[-1]
    assert last.startswith("branch 0  w=3  point 30") and re.search(r" 100%\|#+\| \[\d\d:\d\d<\d\d:\d\d\]", last)
    assert re.search(r"point 15 +50%\|#+ +\| \[\d\d:\d\d<(\d\d:\d\d|\?)\]", text)


def test_disabled_prints_nothing():
    for stream in (io.StringIO(), Terminal()):
        clock = Clock()
        p = Progress(enabled=False, stream=stream, clock=clock, delay=0.0)
        run_branch(p, clock, 15.0)
        p.write("a failed point")
        p.close()
        assert stream.getvalue() == ""


def test_lines_written_between_updates_come_at_once():
    clock, log = Clock(), io.StringIO()
    p = Progress(stream=log, clock=clock)
    p.write("[1/3] F=0.3: failed (0.2 s): no starting solution")  # not delayed, not throttled
    assert log.getvalue() == "[1/3] F=0.3: failed (0.2 s): no starting solution\n"
