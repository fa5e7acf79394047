"""The fork server: one pre-imported process from which a run's children are forked instead of spawned
(`python -P -m supervisor.cli.fork_server --run <scenario>`: the scenario file is a label, for ps and tests).

A spawned vehicle process spends ~0.4 s of CPU importing Python, numpy, Zenoh and our modules before it does
anything (`python -X importtime`, 2 vCPU Xeon VM); fifty of them on 2 cores took ~10 s to start. This process
imports all that once (PRELOAD), then forks a child per request of the supervisor (supervisor.forked), which runs
the same `cpf` command line a spawned one would (supervisor.cli.main), with the same descriptors (handed over on a
Unix socket, SCM_RIGHTS, and put back at the same numbers), environment, working directory and session of its own.
It must hold no Zenoh session and start no thread: a fork copies only the forking thread, and Zenoh's runtime
starts lazily with the first session, in the child.

Issue 14's guarantees carry over. This process runs under the lifeline launcher like any child (the parent-death
signal to the supervisor, stdin the lifeline), and reads EOF on its stdin when the supervisor is gone: it then
gives its children GRACE to stop and exits. Each child asks for SIGKILL when this process dies (the parent-death
signal), until its own lifeline watch takes over (comms.bus.lifeline.watch withdraws the signal): from then on it
stops with the supervisor, not with this process, so a fork server killed during a run leaves the run going.

Protocol (SOCK_SEQPACKET, JSON): "ready" once imported; a request {argv, title, env, cwd, targets} with the
descriptors [stdin, stderr, *targets] is answered {pid} with the child's pidfd, or {error}; {exit: pid, status: wait
status} whenever a child ends.
"""

from __future__ import annotations

import atexit
import contextlib
import fcntl
import importlib
import json
import os
import selectors
import signal
import socket
import sys
import time
import traceback
from typing import Any

import setproctitle

from comms.bus.lifeline import GRACE, LIFELINE_ENV, ORPHANED, set_parent_death_signal
from supervisor.forked import MAX_FDS, MAX_MESSAGE, SOCKET_ENV

# What `cpf vehicle` and `cpf comms` import (measured with -X importtime on both); a module left out is only
# imported by each child itself.
PRELOAD = (
    "numpy",
    "zenoh",
    "msgspec",
    "setproctitle",
    "supervisor.cli",
    "vehicles.node",
    "vehicles.host",
    "vehicles.start",
    "comms.broker.broker",
    "comms.broker.broker_start",
    "comms.bus.access",
)
CLI_MAIN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "__main__.py")  # a spawned child's argv[0]


def main() -> None:
    for module in PRELOAD:
        importlib.import_module(module)
    # setproctitle claims the memory of our command line and environment while the environment is still where the
    # kernel put it; a child that clears its environment first can no longer retitle itself (measured: its cmdline
    # stayed ours).
    setproctitle.setproctitle(setproctitle.getproctitle())
    os.environ.pop(LIFELINE_ENV, None)  # our stdin is watched here, by the loop; the parent-death signal is kept
    sock = socket.socket(fileno=int(os.environ.pop(SOCKET_ENV)))
    _Server(sock).serve()


class _Server:
    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self.children: set[int] = set()
        self.wake_r, self.wake_w = os.pipe()
        for fd in (self.wake_r, self.wake_w):
            os.set_blocking(fd, False)
        signal.signal(signal.SIGCHLD, lambda *_: None)  # a handler, so that the wake-up fd hears of every end
        signal.set_wakeup_fd(self.wake_w)

    def serve(self) -> None:
        self.sock.send(b'"ready"')
        selector = selectors.DefaultSelector()
        selector.register(0, selectors.EVENT_READ, "lifeline")
        selector.register(self.wake_r, selectors.EVENT_READ, "children")
        selector.register(self.sock, selectors.EVENT_READ, "requests")
        while True:
            for key, _ in selector.select():
                if key.data == "children":
                    self._reap()
                elif key.data == "lifeline" and not _read(0):
                    return self._leave()  # the supervisor is gone
                elif key.data == "requests" and not self._request():
                    return self._leave()  # the supervisor closed its end: the run is over

    def _request(self) -> bool:
        try:
            data, fds, _, _ = socket.recv_fds(self.sock, MAX_MESSAGE, MAX_FDS)
        except ConnectionResetError:
            return False
        if not data:
            return False
        try:
            request = json.loads(data)
            pid = self._fork(request, fds)
        except Exception as exc:  # a request we cannot carry out: said, and the server goes on
            self._send({"error": f"{type(exc).__name__}: {exc}"})
        else:
            pidfd = os.pidfd_open(pid)
            self._send({"pid": pid}, [pidfd])
            os.close(pidfd)
        finally:
            for fd in fds:
                os.close(fd)
        return True

    def _fork(self, request: dict[str, Any], fds: list[int]) -> int:
        if len(fds) != 2 + len(request["targets"]):
            raise ValueError(f"{len(fds)} descriptors for {len(request['targets'])} targets")
        for stream in (sys.stdout, sys.stderr):
            stream.flush()  # nothing of ours written twice, by the child too
        me = os.getpid()
        pid = os.fork()
        if pid == 0:
            _child(request, fds, me)  # never returns
        self.children.add(pid)
        return pid

    def _reap(self) -> None:
        while _read(self.wake_r):
            pass
        for pid in list(self.children):
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                self.children.discard(pid)
                self._send({"exit": pid, "status": status})

    def _send(self, message: dict[str, Any], fds: list[int] | None = None) -> None:
        with contextlib.suppress(OSError):  # the supervisor gone: nobody to tell
            socket.send_fds(self.sock, [json.dumps(message).encode()], fds or [])

    def _leave(self) -> None:
        """Give the children GRACE (and a little) to end, each reported, then go: those still starting go with us
        (their parent-death signal), the others by their own lifeline."""
        end = time.monotonic() + GRACE + 0.5
        while self.children and time.monotonic() < end:
            self._reap()
            time.sleep(0.01)


def _read(fd: int) -> bytes:
    try:
        return os.read(fd, 4096)
    except OSError:  # nothing to read (non-blocking), or not readable: both as nothing
        return b""


def _child(request: dict[str, Any], fds: list[int], server: int) -> None:
    """In the forked child: become what `python -m supervisor.cli <argv>` under the lifeline launcher would be, run
    it, exit with its code. Never returns (the server's loop is not ours)."""
    code = 1
    try:
        os.setsid()
        set_parent_death_signal(signal.SIGKILL)
        if os.getppid() != server:
            os._exit(ORPHANED)  # the server died before the prctl: the signal will never come
        signal.set_wakeup_fd(-1)
        signal.signal(signal.SIGCHLD, signal.SIG_DFL)
        _place(fds, request["targets"])
        os.environ.clear()
        os.environ.update(request["env"])
        os.environ[LIFELINE_ENV] = "0"
        os.chdir(request["cwd"])
        sys.argv = [CLI_MAIN, *request["argv"]]
        setproctitle.setproctitle(request["title"])  # ps, top and /proc/<pid>/cmdline: its command, not ours
        code = _run(request["argv"])
    except BaseException:
        traceback.print_exc()
    finally:
        with contextlib.suppress(BaseException):
            atexit._run_exitfuncs()
            sys.stdout.flush()
            sys.stderr.flush()
        os._exit(code)


def _run(argv: list[str]) -> int:
    """supervisor.cli's entry, as `python -m supervisor.cli` runs it: its code, SystemExit's included."""
    from supervisor.cli import main

    try:
        return main(argv)
    except SystemExit as exc:
        if exc.code is None or isinstance(exc.code, int):
            return exc.code or 0
        print(exc.code, file=sys.stderr)
        return 1


def _place(fds: list[int], targets: list[int]) -> None:
    """stdin, /dev/null as stdout, stderr, and each target descriptor at its number, as Popen's pass_fds would
    leave them; every other descriptor closed."""
    null = os.open(os.devnull, os.O_WRONLY)
    wanted = [(0, fds[0]), (1, null), (2, fds[1]), *zip(targets, fds[2:], strict=True)]
    floor = 1 + max([3, *targets, *fds, null])
    moved = [(target, fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, floor)) for target, fd in wanted]
    for target, fd in moved:
        os.dup2(fd, target)  # inheritable, as passed fds are
    keep = {0, 1, 2, *targets}
    for name in os.listdir("/proc/self/fd"):
        if int(name) not in keep:
            with contextlib.suppress(OSError):
                os.close(int(name))


if __name__ == "__main__":
    main()
