"""Progress display on stderr: a bar with percentage and ETA on a terminal, plain throttled lines otherwise.

The analyses call :meth:`Progress.update` at every computed point (branch
point, setting, value) with a status text and, where the total is known, how
far the task has got; the run closes the display with :meth:`Progress.close`.

- On a terminal: one ``tqdm`` bar per task (a branch, a curve, the settings
  of a convergence study), redrawn in place at most every ``interval``
  seconds, with percentage, elapsed time and remaining time; a finished
  task's bar stays as a line.
- Elsewhere (a log file, a pipe, CI): no carriage returns; a plain line at
  most every ``log_interval`` seconds and one when a task ends, which says
  what the task did (a branch: the interval of the parameter it covered),
  not a percentage and a remaining time that went stale when it stopped.
- Nothing during the first ``delay`` seconds (short runs and tests print
  nothing), and nothing at all when disabled (``--quiet``).

``tqdm`` computes the terminal width, the smoothed rate and the remaining
time; the plain lines use its formatter too.
"""

from __future__ import annotations

import math
import os
import sys
import time
from dataclasses import dataclass
from enum import Enum

import numpy as np
from tqdm import tqdm

__all__ = ["Progress", "covered_fraction"]

#: units of a task whose progress is a fraction (the bar counts thousandths)
_UNITS = 1000


def covered_fraction(parameter, bounds) -> float | None:
    """How much of its parameter range a branch has covered, from its start towards the end it heads for.

    The fraction towards the upper bound is ``(max(p) - p[0]) / (hi - p[0])``,
    towards the lower bound ``(p[0] - min(p)) / (p[0] - lo)``; the larger of
    the two is returned, so a branch that turns back at a fold keeps the
    maximum it reached, and one that runs from an interior start to either end
    ends at 1.

    Parameters
    ----------
    parameter : array_like, shape (P,)
        The branch's parameter values so far, its start first.
    bounds : tuple of float
        ``(lo, hi)``, the range the continuation stops at.

    Returns
    -------
    float or None
        In [0, 1]; None when there is no point yet or neither side of the start
        has a positive finite length (no meaningful fraction).
    """
    p = np.asarray(parameter, dtype=float)
    if p.size == 0:
        return None
    lo, hi = float(min(bounds)), float(max(bounds))
    start = float(p[0])
    fractions = []
    if math.isfinite(hi - start) and hi - start > 0:
        fractions.append((float(np.max(p)) - start) / (hi - start))
    if math.isfinite(start - lo) and start - lo > 0:
        fractions.append((start - float(np.min(p))) / (start - lo))
    fractions = [f for f in fractions if math.isfinite(f)]
    if not fractions:
        return None
    return min(1.0, max(0.0, max(fractions)))


class _Mode(Enum):
    FRACTION = "fraction"  # total known as a fraction (thousandths)
    COUNT = "count"  # done of total
    TEXT = "text"  # no total: the text alone (it carries the point count)


@dataclass
class _Task:
    """The state of the task being displayed."""

    key: object
    mode: _Mode
    total: int | None
    n: int
    n0: int  # n when the task started (the rate counts what was done since)
    t0: float
    text: str = ""
    bar: tqdm | None = None
    printed: str | None = None  # the last plain line written for it
    parameter: object = None  # a branch's parameter values so far, as last reported (for its final line)
    bounds: tuple | None = None


def _terminal_columns(stream) -> int:
    """Columns of the terminal behind ``stream``; 0 when unknown (a pseudo-terminal of size 0, no file number)."""
    try:
        return os.get_terminal_size(stream.fileno()).columns
    except (AttributeError, ValueError, OSError):
        return 0


class _Bar(tqdm):
    """A tqdm bar without tqdm's monitor thread (the display is redrawn on every throttled update)."""

    monitor_interval = 0


class Progress:
    """Progress of a run on a stream (stderr by default), throttled, silent during the first ``delay`` seconds.

    Parameters
    ----------
    enabled : bool
        False (``--quiet``, ``progress=False``) prints nothing.
    stream : file-like, optional
        Default ``sys.stderr``.
    delay : float
        Seconds after creation during which nothing is printed.
    interval : float
        Least seconds between two redraws of a terminal bar.
    log_interval : float
        Least seconds between two plain lines (stream not a terminal); a task's
        end is always written.
    clock : callable, optional
        Seconds, monotonic (``time.monotonic``); tests pass a fake one.
    terminal : bool, optional
        Whether ``stream`` is a terminal (default: ``stream.isatty()``).
    """

    def __init__(self, enabled: bool = True, stream=None, delay: float = 1.0, interval: float = 0.2,
                 log_interval: float = 10.0, clock=None, terminal: bool | None = None):
        self.enabled = bool(enabled)
        self.stream = stream or sys.stderr
        self.clock = clock or time.monotonic
        self.delay, self.interval, self.log_interval = float(delay), float(interval), float(log_interval)
        if terminal is None:
            isatty = getattr(self.stream, "isatty", None)
            try:
                terminal = bool(isatty()) if isatty is not None else False
            except (ValueError, OSError):  # a closed stream
                terminal = False
        self.terminal = terminal
        self.t0 = self.clock()
        self._task: _Task | None = None
        self._last_draw = -math.inf
        self._last_line = -math.inf

    # ------------------------------------------------------------------ API
    def update(self, text: str, fraction: float | None = None, done: int | None = None, total: int | None = None,
               parameter=None, bounds=None, task=None) -> None:
        """Report the state of the current task.

        Parameters
        ----------
        text : str
            What is being computed (branch, parameter value, point count).
        fraction : float, optional
            Part of the task done, in [0, 1].
        done, total : int, optional
            Items done of ``total`` (points of a sweep, settings, values).
        parameter : array_like, shape (P,), optional
            With ``bounds``: the branch's parameter values so far; the fraction
            is :func:`covered_fraction` (computed only when displayed).
        bounds : tuple of float, optional
            ``(lo, hi)``, the branch's parameter range.
        task : hashable, optional
            Names the task (``"branch 2"``); a new value ends the current task
            (its bar stays, or a plain line is written) and starts a new one.
            A changed ``total`` also starts a new task.
        """
        if not self.enabled:
            return
        now = self.clock()
        if fraction is None and parameter is not None and bounds is not None:
            fraction = covered_fraction(parameter, bounds)
        if fraction is not None and math.isfinite(fraction):
            mode, units, n = _Mode.FRACTION, _UNITS, round(min(1.0, max(0.0, float(fraction))) * _UNITS)
        elif done is not None and total is not None and total > 0:
            mode, units, n = _Mode.COUNT, int(total), int(min(max(done, 0), total))
        else:
            mode, units, n = _Mode.TEXT, None, 0
        t = self._task
        if t is None or task != t.key or mode is not t.mode or units != t.total or n < t.n:
            self._end_task()
            t = self._task = _Task(task, mode, units, n, n, now)
        t.text, t.n = str(text), n
        if parameter is not None and bounds is not None:
            t.parameter, t.bounds = parameter, bounds  # kept, not reduced: min/max only for the final line
        if now - self.t0 < self.delay:
            return
        if self.terminal:
            if now - self._last_draw >= self.interval:
                self._last_draw = now
                self._draw(t)
        elif now - self._last_line >= self.log_interval:
            self._line(t, now)

    def write(self, line: str) -> None:
        """Write a line at once (not throttled, not delayed), above the bar on a terminal."""
        if not self.enabled:
            return
        if self.terminal and self._task is not None and self._task.bar is not None:
            tqdm.write(line, file=self.stream)
        else:
            self.stream.write(line + "\n")
            self.stream.flush()

    def close(self) -> None:
        """End the display: the last task's final state (if anything was shown), then nothing more."""
        if self.enabled:
            self._end_task()

    # ------------------------------------------------------------ internals
    def _shown(self) -> bool:
        return self.clock() - self.t0 >= self.delay

    def _end_task(self) -> None:
        t, self._task = self._task, None
        if t is None:
            return
        if t.bar is not None:
            t.bar.set_description_str(t.text, refresh=False)
            t.bar.n = t.n
            t.bar.close()  # leave=True: the final state is drawn and stays as a line
        elif not self.terminal and self._shown():
            self._final_line(t, self.clock())

    def _draw(self, t: _Task) -> None:
        if t.bar is None:
            if t.mode is _Mode.TEXT:
                fmt = "{desc} [{elapsed}]"
            else:
                fmt = "{desc} {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}]"
            # initial=n: the rate and the remaining time count what is done from here on
            # tqdm follows the size of a resized terminal; one that reports no size (a pseudo-terminal of
            # size 0) gets 100 columns, and enough rows for tqdm to draw at all
            size = {} if _terminal_columns(self.stream) > 0 else {"ncols": 100, "nrows": 24}
            t.bar = _Bar(total=t.total, initial=t.n, file=self.stream, leave=True, dynamic_ncols=not size,
                         mininterval=0, miniters=0, smoothing=0.3, bar_format=fmt, desc=t.text, **size)
            return
        t.bar.set_description_str(t.text, refresh=False)
        t.bar.update(t.n - t.bar.n)

    def _final_line(self, t: _Task, now: float) -> None:
        """The line that ends a task in a log: what it covered or did, and its time; no remaining time."""
        elapsed = tqdm.format_interval(max(now - t.t0, 0.0))
        p = np.asarray(t.parameter, dtype=float) if t.parameter is not None else np.empty(0)
        if p.size and t.bounds is not None:
            lo, hi = sorted(float(b) for b in t.bounds)
            line = (f"{t.text}  ended: covered [{np.min(p):.6g}, {np.max(p):.6g}] of [{lo:.6g}, {hi:.6g}], "
                    f"{elapsed} elapsed")
        elif t.mode is _Mode.COUNT:
            line = f"{t.text}  ended: {t.n} of {t.total} done, {elapsed} elapsed"
        elif t.mode is _Mode.FRACTION:
            line = f"{t.text}  ended at {100 * t.n / _UNITS:.0f}%, {elapsed} elapsed"
        else:
            line = f"{t.text}  ({elapsed} elapsed)"
        if line != t.printed:
            self.stream.write(line + "\n")
            self.stream.flush()

    def _line(self, t: _Task, now: float) -> None:
        elapsed = max(now - t.t0, 0.0)
        if t.mode is _Mode.TEXT:
            line = f"{t.text}  ({tqdm.format_interval(elapsed)} elapsed)"
        else:
            rate = (t.n - t.n0) / elapsed if elapsed > 0 and t.n > t.n0 else None
            line = tqdm.format_meter(t.n, t.total, elapsed, prefix=t.text, rate=rate,
                                     bar_format="{desc}  {percentage:.0f}%, {elapsed} elapsed, {remaining} left")
        if line == t.printed:
            return
        t.printed = line
        self._last_line = now
        self.stream.write(line + "\n")
        self.stream.flush()
