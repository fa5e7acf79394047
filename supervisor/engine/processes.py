"""Child processes of a run: each in its own session, stopped with a deadline, then killed.

Every child is started with start_new_session=True, so a Ctrl-C at the terminal reaches only the supervisor, which
then stops the children itself: politely (the stop message, sent by the caller), then SIGTERM to the child's process
group, then SIGKILL. Children's stderr goes to a temporary file whose last line explains an early exit.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import tempfile
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import IO


@dataclass
class Child:
    name: str
    process: subprocess.Popen[bytes]
    stderr: IO[bytes]

    def last_words(self) -> str:
        self.stderr.flush()
        lines = Path(self.stderr.name).read_text(errors="replace").strip().splitlines()
        return lines[-1] if lines else "no message"

    def kill(self) -> None:
        """SIGKILL to the child's process group: the fault, not a shutdown."""
        _signal_group(self.process.pid, signal.SIGKILL)
        self.process.wait()

    def how_it_ended(self) -> str | None:
        """None while running; otherwise a short description of its end."""
        code = self.process.poll()
        if code is None:
            return None
        if code < 0:
            return f"killed by {signal.Signals(-code).name}"
        return f"exit code {code}: {self.last_words()}"


class ProcessGroup:
    """The children of one run; a context manager that leaves none behind."""

    def __init__(self, env_of: Callable[[str], Mapping[str, str]] | None = None) -> None:
        """env_of: what a child, by name, gets in its environment besides ours (its credential: never on its
        command line, which every user of the machine can read)."""
        self._env_of = env_of
        self.children: list[Child] = []
        self._gone: list[Child] = []  # ended and accounted for
        self._logs = tempfile.TemporaryDirectory(prefix="cpf-children-")

    def spawn(self, name: str, argv: list[str]) -> Child:
        log_name = name.replace(" ", "-") + ".log"
        stderr = open(Path(self._logs.name) / log_name, "w+b")  # noqa: SIM115 - closed in stop()
        env = {**os.environ, **self._env_of(name)} if self._env_of is not None else None
        process = subprocess.Popen(
            argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=stderr, start_new_session=True, env=env
        )
        child = Child(name, process, stderr)
        self.children.append(child)
        return child

    def first_ended(self) -> Child | None:
        """A child that has exited (before being told to, if asked during a run)."""
        return next((c for c in self.children if c.process.poll() is not None), None)

    def forget(self, name: str) -> None:
        """A child whose end is accounted for: no longer reported by first_ended (it is still reaped in stop)."""
        child = self.named(name)
        if child is not None:
            self.children.remove(child)
            self._gone.append(child)

    def named(self, name: str) -> Child | None:
        return next((c for c in self.children if c.name == name), None)

    def pids(self) -> list[int]:
        return [c.process.pid for c in self.children]

    def stop(self, deadline: float = 3.0) -> None:
        """Wait up to deadline for children to exit, SIGTERM their groups, wait again, then SIGKILL."""
        self._wait_all(deadline)
        for sig in (signal.SIGTERM, signal.SIGKILL):
            alive = [c for c in self.children if c.process.poll() is None]
            if not alive:
                break
            for child in alive:
                _signal_group(child.process.pid, sig)
            self._wait_all(deadline)
        for child in self.children + self._gone:
            child.stderr.close()
        self._logs.cleanup()

    def _wait_all(self, deadline: float) -> None:
        end = time.monotonic() + deadline
        for child in self.children:
            with contextlib.suppress(subprocess.TimeoutExpired):
                child.process.wait(timeout=max(0.0, end - time.monotonic()))

    def __enter__(self) -> ProcessGroup:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.stop()


def _signal_group(pid: int, sig: signal.Signals) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.killpg(pid, sig)  # the child leads its own session, so its group id is its pid
