"""What the command line shows the user beside the results: exit codes, progress lines and prompts.

Library code does not print: it takes callbacks (a progress, an on_ready) and the command line passes these.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, TextIO

if TYPE_CHECKING:
    from tqdm import tqdm

PROGRESS_INTERVAL = 1.0  # s of wall time between replay progress lines


def wait_to_start(delay: float | None, stream: TextIO | None = None) -> Callable[[str], None]:
    """An on_ready for `cpf replay`: print where the session is (stream, default: sys.stdout when called), then
    wait for Enter (delay None; end of input counts as Enter) or delay seconds, so subscribers can connect before the
    first message."""

    def ready(where: str) -> None:
        out = sys.stdout if stream is None else stream
        print(where, file=out, flush=True)
        if delay is None:
            print("press Enter to start the replay", file=out, flush=True)
            with contextlib.suppress(EOFError):
                input()
        elif delay > 0:
            from supervisor.tools.replay import wait_until  # here: every vehicle process imports this module

            wait_until(time.monotonic() + delay)

    return ready


class ProgressLine:
    """`cpf replay`'s progress: the log time being replayed, at most once a second of wall time (one line rewritten
    in place on a terminal; call close() before printing anything else)."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self._stream = sys.stderr if stream is None else stream  # looked up now: tests and callers swap sys.stderr
        self._tty = self._stream.isatty()
        self._last: float | None = None

    def __call__(self, t: float) -> None:
        now = time.monotonic()
        if self._last is not None and now - self._last < PROGRESS_INTERVAL:
            return
        self._last = now
        line = f"replaying t = {t:9.1f} s"
        self._stream.write(("\r" + line) if self._tty else (line + "\n"))
        self._stream.flush()

    def close(self) -> None:
        if self._tty and self._last is not None:
            self._stream.write("\n")
            self._stream.flush()


class SweepBar:
    """`cpf sweep`'s progress bar (tqdm, on stderr): a progress for supervisor.tools.sweep.sweep. notebook: tqdm.auto's
    bar (cpf.sweep: in a notebook a widget if ipywidgets, not a dependency, is installed)."""

    def __init__(self, notebook: bool = False) -> None:
        self._bar: tqdm[None] | None = None
        self._notebook = notebook

    def __call__(self, done: int, total: int) -> None:
        if self._bar is None:
            if self._notebook:
                from tqdm.auto import tqdm
            else:
                from tqdm import tqdm  # here: every vehicle process imports this module

            # Every run redrawn (runs are seconds apart): by default tqdm skips an update within 0.1 s of the
            # last, and a sweep interrupted then would not show the run it has kept.
            self._bar = tqdm(total=total, initial=done, desc="sweep", unit="run", mininterval=0, miniters=1)
        else:
            self._bar.update(done - self._bar.n)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
