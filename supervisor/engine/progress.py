"""A one-line progress report for long runs: simulated time and real-time factor, at most once a second; or, for the
Python API, a tqdm.auto bar (text; in a notebook a widget if ipywidgets, which is not a dependency, is installed)."""

from __future__ import annotations

import time
from typing import Any, TextIO

from supervisor.engine import interrupts


class Progress:
    def __init__(self, duration: float, stream: TextIO | None = None, enabled: bool = True, bar: bool = False) -> None:
        """stream: where the line goes, given by the command line (the only code that talks to the user); None: no
        line, only the timing. bar: a tqdm.auto bar on the stream instead of the line (cpf.run: it shows in a
        notebook as well as in a terminal)."""
        self.duration = duration
        self.stream = stream
        self.enabled = enabled and stream is not None
        self.started = time.perf_counter()
        self.stepping = self.started  # when the first sync step began (after any process start-up)
        self._last = self.started
        self._tty = stream is not None and stream.isatty()
        self._bar: Any = _bar(duration, stream) if bar and self.enabled else None

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
        if self._bar is not None:
            self._bar.update(t - self._bar.n)
            self._bar.set_postfix_str(f"{factor:.1f}x real time", refresh=False)
            return
        line = f"t = {t:7.1f} / {self.duration:.0f} s   {factor:6.1f}x real time"
        self.stream.write(("\r" + line) if self._tty else (line + "\n"))
        self.stream.flush()

    def stepping_time(self) -> float:
        """Wall time since stepping began."""
        return time.perf_counter() - self.stepping

    def done(self, t: float) -> float:
        """Final line; returns the whole wall time, start-up included."""
        self.update(t, force=True)
        if self._bar is not None:
            self.close()
        elif self.enabled and self._tty and self.stream is not None:
            self.stream.write("\n")
        return time.perf_counter() - self.started

    def close(self) -> None:
        """The bar closed, if there is one: done() closes it, and so must a run that ends otherwise (a Ctrl-C: an
        open bar stayed in a notebook). Closing it again does nothing."""
        if self._bar is not None:
            self._bar.close()


def _bar(duration: float, stream: TextIO | None) -> Any:
    from tqdm.auto import tqdm  # imported only when asked for: a run from the command line does without it

    return tqdm(total=duration, file=stream, unit="s", desc="simulated", bar_format=BAR)


BAR = "{desc}: {n:.1f}/{total:.0f} s |{bar}| {elapsed}<{remaining}{postfix}"
