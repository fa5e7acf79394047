"""A one-line progress report for long runs: simulated time and real-time factor, at most once a second."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class Progress:
    def __init__(self, duration: float, stream: TextIO = sys.stderr, enabled: bool = True) -> None:
        self.duration = duration
        self.stream = stream
        self.enabled = enabled
        self.started = time.perf_counter()
        self._last = self.started
        self._tty = stream.isatty()

    def update(self, t: float, force: bool = False) -> None:
        now = time.perf_counter()
        if not self.enabled or (now - self._last < 1.0 and not force):
            return
        self._last = now
        factor = t / max(now - self.started, 1e-9)
        line = f"t = {t:7.1f} / {self.duration:.0f} s   {factor:6.1f}x real time"
        self.stream.write(("\r" + line) if self._tty else (line + "\n"))
        self.stream.flush()

    def done(self, t: float) -> float:
        """Final line; returns the wall time."""
        self.update(t, force=True)
        if self.enabled and self._tty:
            self.stream.write("\n")
        return time.perf_counter() - self.started
