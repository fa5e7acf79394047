"""The supervisor's side of the fork server (supervisor.cli.fork_server): start it, ask it for children, know how they
end.

A forked child is the fork server's child, not ours, so `ForkedProcess` stands in for its subprocess.Popen: its pid,
its pidfd (sent by the server, which opened it before it could reap the child: no pid reuse can fool it), and its
exit status from the server's messages. Should the server be gone (killed), a child's end is still seen on its
pidfd, its status then unknown (LOST).
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any

from supervisor.errors import TooManyDescriptors

CLI = ("-m", "supervisor.cli")  # the command lines the server can fork: `python [-P] -m supervisor.cli ...`
LOST = 255  # the exit code of a child whose status went with a killed fork server
STATUS_WAIT = 1.0  # s for the server's word on a child its pidfd says has ended
SOCKET_ENV = "CPF_FORK_SERVER_SOCKET"  # the descriptor of the fork server's end of the socket
MAX_MESSAGE = 1 << 20  # bytes: a request carries the child's whole environment
MAX_FDS = 253  # Linux's SCM_MAX_FD, the most one message passes: a host of 150 vehicles passes 151 (64 made it spawn)


def available() -> bool:
    """Forking needs Linux's pidfds (5.3) and descriptor passing."""
    return sys.platform.startswith("linux") and hasattr(os, "pidfd_open") and hasattr(socket, "send_fds")


def cli_args(argv: list[str]) -> list[str] | None:
    """What follows `-m supervisor.cli` in a child's command line run by this interpreter; None for another."""
    if not argv or argv[0] != sys.executable:
        return None
    for at in range(1, len(argv) - 1):
        if tuple(argv[at : at + 2]) == CLI:
            return argv[at + 2 :] if all(a == "-P" for a in argv[1:at]) else None
    return None


class ForkServer:
    """The client: Popen-like handles for children forked by the server, which `spawn` (a ProcessGroup's, with the
    lifeline as stdin) started."""

    def __init__(
        self, spawn: Callable[[list[str], Mapping[str, str], tuple[int, ...]], Any], label: str, timeout: float
    ) -> None:
        """spawn(argv, env, fds): start the server process as a child (its handle is kept as .process); label: on
        its command line, `--run <label>` (the scenario file: what ps, and tests, find a run's processes by);
        timeout: s for it to say it is ready."""
        mine, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        try:
            env = {**os.environ, SOCKET_ENV: str(theirs.fileno())}
            argv = [sys.executable, "-P", "-m", "supervisor.cli.fork_server", "--run", label]
            self.process = spawn(argv, env, (theirs.fileno(),))
        finally:
            theirs.close()
        self.sock = mine
        self.gone = False
        self._lock = threading.RLock()
        self._status: dict[int, int] = {}
        try:
            if not self._ready(timeout):
                raise OSError("the fork server did not start")
        except BaseException:  # Ctrl-C while it starts too: not left running
            self.close()
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.process.pid, signal.SIGKILL)  # its own session: its group is its pid
            self.process.wait()
            raise

    def _ready(self, timeout: float) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end and self.process.poll() is None:
            if _readable(self.sock.fileno(), 0.05):
                return self.sock.recv(MAX_MESSAGE) == b'"ready"'
        return False

    def fork(
        self, args: list[str], env: Mapping[str, str], stdio: tuple[int, int], fds: tuple[int, ...]
    ) -> ForkedProcess:
        """A child running `cpf <args>` with stdin and stderr (stdio) and fds at their numbers; OSError if the
        server is gone or refused; TooManyDescriptors (the server is fine) if they do not fit in one message."""
        if len(stdio) + len(fds) > MAX_FDS:
            raise TooManyDescriptors(f"{len(stdio) + len(fds)} descriptors, more than one message passes ({MAX_FDS})")
        title = " ".join([sys.executable, "-P", *CLI, *args])  # the command line a spawned child would show
        request = {"argv": args, "title": title, "env": dict(env), "cwd": os.getcwd(), "targets": list(fds)}
        with self._lock:
            if self.gone:
                raise OSError("the fork server is gone")
            socket.send_fds(self.sock, [json.dumps(request).encode()], [*stdio, *fds])
            while True:
                message, received = self._receive(None)
                if message is None:
                    raise OSError("the fork server is gone")
                if "pid" in message:
                    return ForkedProcess(message["pid"], received[0], self)
                if "error" in message:
                    raise OSError(f"the fork server refused: {message['error']}")

    def status(self, pid: int, timeout: float) -> int | None:
        """The wait status of child pid, reading the server's messages for up to timeout s; None if not heard."""
        end = time.monotonic() + timeout
        with self._lock:
            while pid not in self._status and not self.gone and time.monotonic() < end:
                self._receive(max(0.0, end - time.monotonic()))
            return self._status.pop(pid, None)

    def _receive(self, timeout: float | None) -> tuple[dict[str, Any] | None, list[int]]:
        """One message (an exit is recorded on the way), or None if none came in timeout s or the server is gone."""
        if self.gone or not _readable(self.sock.fileno(), timeout):
            return None, []
        try:
            data, fds, _, _ = socket.recv_fds(self.sock, MAX_MESSAGE, MAX_FDS)
        except OSError:
            data, fds = b"", []
        if not data:
            self.gone = True
            return None, []
        message = json.loads(data)
        if "exit" in message:
            self._status[message["exit"]] = message["status"]
        return message, fds

    def close(self) -> None:
        with self._lock:
            self.gone = True
            self.sock.close()


class ForkedProcess:
    """What ProcessGroup needs of a subprocess.Popen, for a forked child."""

    def __init__(self, pid: int, pidfd: int, server: ForkServer) -> None:
        self.pid, self._pidfd, self._server = pid, pidfd, server
        self.returncode: int | None = None

    def poll(self) -> int | None:
        if self.returncode is None and self._ended(0.0):
            self._settle()
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        if self.returncode is None:
            if not self._ended(timeout):
                raise subprocess.TimeoutExpired(["forked", str(self.pid)], timeout or 0.0)
            self._settle()
        assert self.returncode is not None
        return self.returncode

    def _ended(self, timeout: float | None) -> bool:
        return _readable(self._pidfd, timeout)

    def _settle(self) -> None:
        status = self._server.status(self.pid, STATUS_WAIT)
        self.returncode = LOST if status is None else os.waitstatus_to_exitcode(status)
        with contextlib.suppress(OSError):
            os.close(self._pidfd)


def _readable(fd: int, timeout: float | None) -> bool:
    """poll, not select: a run of 255 one-process vehicles holds descriptors past select's 1024."""
    poller = select.poll()
    poller.register(fd, select.POLLIN)
    return bool(poller.poll(None if timeout is None else max(0, round(timeout * 1000))))
