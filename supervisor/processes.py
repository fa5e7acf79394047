"""Child processes of a run: each in its own session, stopped with a deadline, then killed.

Every child is started with start_new_session=True, so a Ctrl-C at the terminal reaches only the supervisor, which
then stops the children itself: politely (the stop message, sent by the caller), then SIGTERM to the child's process
group, then SIGKILL. Children's stderr goes to a temporary file whose last line explains an early exit; the file
has no name (unlinked at once), so a supervisor that is killed leaves none behind.

No child outlives the supervisor by more than about a second, whenever and however it ends: every child is started
through comms.bus.lifeline's launcher, with the read end of a pipe as its stdin (the write end stays here, and the
kernel closes it when this process ends) and, on Linux, a parent-death signal that covers the child's start-up.
A group that forks (the Zenoh engine's, on Linux) starts its `cpf` children from a fork server instead
(supervisor.forked, supervisor.cli.fork_server): the same session, stdin, stderr and descriptors, the fork server
itself a child started as above, each forked child's parent-death signal the fork server's until it watches its
lifeline.
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import os
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import TracebackType
from typing import IO

from comms.bus import lifeline
from supervisor import forked
from supervisor.errors import TooManyDescriptors

FORK_SERVER_TIMEOUT = 30.0  # s for the fork server to import what a child needs (~0.4 s of CPU)
log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)
Process = subprocess.Popen[bytes] | forked.ForkedProcess

STEM_MAX = 64  # characters of a process name in a file name


@dataclass
class Child:
    name: str
    process: Process
    stderr: IO[bytes]
    control: int = -1  # the write end of its control pipe (a vehicle host's), -1 if none

    def tell(self, order: str) -> None:
        """A line on its control pipe (vehicles.host reads it); none if it has ended (its vehicles' tokens say so) or
        its pipe is closed."""
        if self.control < 0:
            return
        with contextlib.suppress(BrokenPipeError):
            os.write(self.control, f"{order}\n".encode())

    def close_control(self) -> None:
        if self.control >= 0:
            os.close(self.control)
            self.control = -1

    def last_words(self) -> str:
        fd = self.stderr.fileno()
        size = os.fstat(fd).st_size
        tail = os.pread(fd, min(size, 65536), max(0, size - 65536))  # pread: the child's file offset stays put
        lines = tail.decode(errors="replace").strip().splitlines()
        return lines[-1] if lines else "no message"

    def kill(self) -> None:
        """SIGKILL to the child's process group: the fault, not a shutdown."""
        _signal_group(self.process.pid, signal.SIGKILL)
        self.process.wait()

    def how_it_ended(self, grace: float = 0.0) -> str | None:
        """None while running (after up to grace s of waiting for it to end); otherwise a short description of its
        end."""
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.process.wait(timeout=grace)
        code = self.process.poll()
        if code is None:
            return None
        if code < 0:
            return f"killed by {signal.Signals(-code).name}"
        return f"exit code {code}: {self.last_words()}"


class ProcessGroup:
    """The children of one run; a context manager that leaves none behind."""

    def __init__(
        self,
        env_of: Callable[[str], Mapping[str, str]] | None = None,
        fds_of: Callable[[str], tuple[int, ...]] | None = None,
        fork: str | None = None,
    ) -> None:
        """env_of: what a child, by name, gets in its environment besides ours; fds_of: the file descriptors it
        inherits (its credential: never on its command line, which every user of the machine can read). fork: the
        `cpf` children are forked from a fork server (supervisor.cli.fork_server), started with the first of them,
        where the platform allows, with this text (the run's scenario file) on its command line; any other child,
        or every child if the server cannot start, is spawned."""
        self._env_of = env_of
        self._fds_of = fds_of
        self.children: list[Child] = []
        self._gone: list[Child] = []  # ended and accounted for
        self._fork = fork is not None and forked.available()
        self._label = fork or ""
        self._server: forked.ForkServer | None = None
        self._server_child: Child | None = None  # the fork server's own process, not a child the run needs
        # The lifeline: children get the read end as stdin; the write end is only ever here (os.pipe's fds are not
        # inherited, and Popen closes every other fd in the child), so its closing tells them this process is gone.
        self._lifeline_read, self._lifeline_write = os.pipe()

    def spawn(self, name: str, argv: list[str], control_env: str | None = None) -> Child:
        """Start argv as a child in its own session. The parent-death signal names the forking thread as the
        parent, so it is asked for only from the main thread (the lifeline alone covers a child spawned elsewhere
        once it runs comms.bus.bus.serve). control_env: give it a control pipe (Child.tell), its read end's descriptor
        in that environment variable."""
        stderr = _stderr_file(name)
        env = {**os.environ, **self._env_of(name)} if self._env_of is not None else dict(os.environ)
        fds = self._fds_of(name) if self._fds_of is not None else ()
        read, write = os.pipe() if control_env is not None else (-1, -1)
        if control_env is not None:
            env[control_env] = str(read)
            fds = (*fds, read)
        try:
            process = self._start(argv, env, fds, stderr)
        except BaseException:
            if write >= 0:
                os.close(write)
            raise
        finally:
            if read >= 0:
                os.close(read)  # the child's now; here only the write end stays
        child = Child(name, process, stderr, write)
        self.children.append(child)
        return child

    def _start(self, argv: list[str], env: dict[str, str], fds: tuple[int, ...], stderr: IO[bytes]) -> Process:
        """Forked, if this group forks and argv is a `cpf` command line, else spawned."""
        args = forked.cli_args(argv) if self._fork else None
        server = self._fork_server() if args is not None else None
        if server is not None and args is not None:
            try:
                return server.fork(args, env, (self._lifeline_read, stderr.fileno()), fds)
            except TooManyDescriptors as exc:  # this child alone is spawned
                log.debug("spawning %s: %s", " ".join(args[:1]), exc)
            except OSError as exc:  # killed, say: this child and the next are spawned
                log.warning("cannot fork %s (%s): spawning it", " ".join(args[:1]), exc)
                self._fork = False
        return self._popen(argv, env, fds, stderr)

    def _popen(self, argv: list[str], env: Mapping[str, str], fds: tuple[int, ...], stderr: IO[bytes]) -> Process:
        from_main = threading.current_thread() is threading.main_thread()
        return subprocess.Popen(
            lifeline.launcher(argv, parent_death_signal=from_main),
            stdin=self._lifeline_read,
            stdout=subprocess.DEVNULL,
            stderr=stderr,
            start_new_session=True,
            env=env,
            pass_fds=fds,
        )

    def _fork_server(self) -> forked.ForkServer | None:
        """The fork server, started on first use; None (and spawning from then on) if it cannot start."""
        if self._server is None and self._fork:
            stderr = _stderr_file("fork-server")
            spawn = lambda argv, env, fds: self._popen(argv, env, fds, stderr)  # noqa: E731
            try:
                self._server = forked.ForkServer(spawn, self._label, FORK_SERVER_TIMEOUT)
            except OSError as exc:
                log.warning("no fork server (%s): spawning every process", exc)
                self._fork = False
            finally:
                self._server_child = Child("fork server", self._server.process, stderr) if self._server else None
                if self._server is None:
                    stderr.close()
        return self._server

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
        """Every process of the group, the fork server's included."""
        return [c.process.pid for c in self._all()]

    @property
    def fork_server(self) -> int | None:
        """The fork server's pid, once one runs."""
        return self._server_child.process.pid if self._server_child is not None else None

    def _all(self) -> list[Child]:
        return self.children + ([self._server_child] if self._server_child is not None else [])

    def stop(self, deadline: float = 3.0) -> None:
        """Cut the lifeline (children still serving stop by themselves), wait up to deadline for children to exit,
        SIGTERM their groups, wait again, then SIGKILL."""
        self._cut_lifeline()
        self._wait_all(deadline)
        for sig in (signal.SIGTERM, signal.SIGKILL):
            alive = [c for c in self._all() if c.process.poll() is None]
            if not alive:
                break
            for child in alive:
                _signal_group(child.process.pid, sig)
            self._wait_all(deadline)
        if self._server is not None:
            self._server.close()
        for child in self._all() + self._gone:
            child.stderr.close()
            child.close_control()

    def _cut_lifeline(self) -> None:
        for fd in (self._lifeline_write, self._lifeline_read):
            if fd >= 0:
                os.close(fd)
        self._lifeline_read = self._lifeline_write = -1  # a second stop must not close fds that reuse the numbers

    def _wait_all(self, deadline: float) -> None:
        end = time.monotonic() + deadline
        for child in self._all():
            with contextlib.suppress(subprocess.TimeoutExpired):
                child.process.wait(timeout=max(0.0, end - time.monotonic()))

    def __enter__(self) -> ProcessGroup:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.stop()


def _stderr_file(name: str) -> IO[bytes]:
    return tempfile.TemporaryFile(prefix=f"cpf-{file_stem(name)}-")


def file_stem(name: str) -> str:
    """A process's name as part of a file name: a host's names its vehicles ('vehicles 1,2,...,150': 540 characters
    past the 255 a file name may have), so a long one keeps its start and a digest of the whole."""
    text = name.replace(",", "-").replace(" ", "-")
    if len(text) <= STEM_MAX:
        return text
    return f"{text[: STEM_MAX - 13]}-{hashlib.sha256(text.encode()).hexdigest()[:12]}"


def _signal_group(pid: int, sig: signal.Signals) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.killpg(pid, sig)  # the child leads its own session, so its group id is its pid
