"""A one-line progress display on stderr for runs longer than a second."""

from __future__ import annotations

import sys
import time

__all__ = ["Progress"]


class Progress:
    """Throttled status line: branch, parameter value, point count, step size.

    Silent during the first second and when disabled, so short runs and
    tests print nothing.
    """

    def __init__(self, enabled: bool = True, stream=None, delay: float = 1.0, interval: float = 0.2):
        self.enabled = enabled
        self.stream = stream or sys.stderr
        self.t0 = time.perf_counter()
        self.delay, self.interval = delay, interval
        self._last = 0.0
        self._shown = False

    def update(self, text: str) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if now - self.t0 < self.delay or now - self._last < self.interval:
            return
        self._last = now
        self._shown = True
        self.stream.write("\r" + text[:110].ljust(110))
        self.stream.flush()

    def close(self) -> None:
        if self._shown:
            self.stream.write("\n")
            self.stream.flush()
            self._shown = False
