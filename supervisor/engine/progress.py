"""A one-line progress report for long runs: simulated time and real-time factor, at most once a second."""

from __future__ import annotations

import time
from typing import TextIO

from supervisor.engine import interrupts


class Progress:
    def __init__(self, duration: float, stream: TextIO | None = None, enabled: bool = True) -> None:
        """stream: where the line goes, given by the command line (the only code that talks to the user); None: no
        line, only the timing."""
        self.duration = duration
        self.stream = stream
        self.enabled = enabled and stream is not None
        self.started = time.perf_counter()
        self.stepping = self.started  # when the first sync step began (after any process start-up)
        self._last = self.started
        self._tty = stream is not None and stream.isatty()

    def begin(self) -> None:
        """Stepping starts now: the real-time factor counts from here, start-up excluded."""
        self.stepping = time.perf_counter()

    def update(self, t: float, force: bool = False) -> None:
        interrupts.check()  # once a step: where a run stops on Ctrl-C
        now = time.perf_counter()
        if not self.enabled or (now - self._last < 1.0 and not force):
            return
        self._last = now
        assert self.stream is not None  # enabled
        factor = t / max(now - self.stepping, 1e-9)
        line = f"t = {t:7.1f} / {self.duration:.0f} s   {factor:6.1f}x real time"
        self.stream.write(("\r" + line) if self._tty else (line + "\n"))
        self.stream.flush()

    def stepping_time(self) -> float:
        """Wall time since stepping began."""
        return time.perf_counter() - self.stepping

    def done(self, t: float) -> float:
        """Final line; returns the whole wall time, start-up included."""
        self.update(t, force=True)
        if self.enabled and self._tty and self.stream is not None:
            self.stream.write("\n")
        return time.perf_counter() - self.started
