"""The live view's relay (supervisor.record.live_relay) in a child process of its own.

Why a process: in the supervisor's, the relay's thread waited for the interpreter lock the engine holds, and a
client saw each message 204-270 ms late (median, the in-process engine running flat out) against 2.4 ms without the
relay (benchmarks/bench_live.py). foxglove-sdk's server is Rust and passes frames to the relay without the lock.

The listening socket is bound here, before the child starts (so the port is known, and a port that is taken is an
OSError here, at once), and handed to the child; connections that come before it accepts wait in the backlog: no
readiness signal is needed. The child is a run's child like the others (supervisor.processes: its own session, the
lifeline, stopped with a deadline, then killed), its orders on its control pipe.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import subprocess
import sys

from supervisor.processes import Child, ProcessGroup
from supervisor.record.live_relay import BACKEND_WAIT, DRAIN_WAIT, RELAY_CONTROL_ENV, RELAY_SOCKET_ENV

NAME = "live relay"
log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)


class RelayProcess:
    """The relay on host:port (0: a free port; `port` is the one it got) in front of the server on backend_port of
    the same host. OSError if the port cannot be had."""

    def __init__(self, host: str, port: int, backend_port: int) -> None:
        sock = socket.create_server((host, port))
        fd = sock.fileno()
        self._group = ProcessGroup(env_of=lambda _: {RELAY_SOCKET_ENV: str(fd)}, fds_of=lambda _: (fd,))
        argv = [sys.executable, "-m", "supervisor.record.live_relay", f"ws://{host}:{backend_port}"]
        try:
            self._child: Child = self._group.spawn(NAME, argv, control_env=RELAY_CONTROL_ENV)
        except BaseException:
            self._group.stop()
            raise
        finally:
            self.port: int = sock.getsockname()[1]
            sock.close()  # the child's copy serves
        self._stopped = False

    def closing(self, code: int, reason: str) -> None:
        """The close code and reason each connection gets once the server is gone (before stopping the server)."""
        self._child.tell(f"closing {code} {reason}")

    def stop(self) -> None:
        """The relay passes on what the stopped server sent, closes every connection and ends, within its drain's
        deadline (then it is stopped as any child); again: nothing."""
        if self._stopped:
            return
        self._stopped = True
        try:
            self._child.tell("stop")
            self._child.close_control()
            with contextlib.suppress(subprocess.TimeoutExpired):
                self._child.process.wait(timeout=DRAIN_WAIT + BACKEND_WAIT)
            ended = self._child.how_it_ended()
            if ended is not None and ended != "exit code 0: no message":
                log.warning("live view: the relay ended with %s", ended)
        finally:
            self._group.stop()
