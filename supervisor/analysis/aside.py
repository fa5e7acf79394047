"""One call made in a forked child while this process goes on, its result pickled back.

`cpf report` spends about as long importing matplotlib (1.8 s) as reading an 8-vehicle log (2 s), each on one core:
reading the log in a child while this process imports overlaps them (tests/test_report.py holds the result to the
one read here). The result comes back through a pipe (an 8-vehicle, 450 s run: 20 MB, 0.15 s to pickle and unpickle);
an exception raised in the child is raised here, as raised by the call.

Forked only where that is safe and useful, as supervisor.analysis.drawing: no other thread alive (a lock it held would
stay held in the child), and fork available; otherwise the call is made here at once. The child ignores Ctrl-C (its
parent stops it), dies with its parent (the parent-death signal) and is killed when the block is left early.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import threading
from collections.abc import Callable, Iterator
from typing import Any, Generic, TypeVar

from comms.bus.lifeline import ORPHANED, set_parent_death_signal
from supervisor.errors import CpfError

T = TypeVar("T")


class Pending(Generic[T]):
    """The call's result, once: result() waits for the child (or holds what the call gave here)."""

    def __init__(self, pid: int | None, fd: int | None, here: tuple[bool, Any] | None = None) -> None:
        self.pid, self.fd, self.here = pid, fd, here

    def result(self) -> T:
        ok, value = self.here if self.here is not None else self._collect()
        self.here = (ok, value)
        if not ok:
            raise value
        return value

    def _collect(self) -> tuple[bool, Any]:
        assert self.fd is not None and self.pid is not None
        with os.fdopen(self.fd, "rb", closefd=True) as pipe:
            self.fd = None
            payload = pipe.read()  # to the end: the child has written and closed, or died
        _, status = os.waitpid(self.pid, 0)
        self.pid = None
        if not payload:  # killed (SIGKILL, the OOM killer): the command's failure in one line, not a traceback
            how = f"killed by signal {os.WTERMSIG(status)}" if os.WIFSIGNALED(status) else f"status {status}"
            return False, CpfError(f"the process reading the log aside ended with no result ({how})")
        ok, value = pickle.loads(payload)
        return bool(ok), value

    def stop(self) -> None:
        """Kill the child if it is still there (the block left before its result)."""
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
        if self.pid is not None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.pid, signal.SIGKILL)
            os.waitpid(self.pid, 0)
            self.pid = None


@contextlib.contextmanager
def aside(call: Callable[..., T], *args: Any) -> Iterator[Pending[T]]:
    """call(*args) in a forked child while the block runs; `.result()` inside the block waits for it."""
    if threading.active_count() > 1 or not hasattr(os, "fork"):
        yield Pending(None, None, _made(call, *args))
        return
    read, write = os.pipe()
    parent = os.getpid()
    pending: Pending[T] | None = None
    try:
        # A Ctrl-C just after the fork would run cpf's handler in the child before it ignores SIGINT (a traceback
        # printed from threading's after-fork hook, seen once in 2500 tests): held until the child ignores it.
        with signals_held():
            pid = os.fork()
            if pid == 0:  # the child: never returns into the caller's code
                os.close(read)
                _child(parent, write, call, *args)
            os.close(write)
            pending = Pending(pid, read)
        yield pending
    finally:
        if pending is not None:
            pending.stop()


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM held back (delivered on leaving), here and in the processes forked meanwhile (which
    unblock them once they have their own handlers: _child, supervisor.analysis.drawing's workers)."""
    held = {signal.SIGINT, signal.SIGTERM}
    before = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def _made(call: Callable[..., T], *args: Any) -> tuple[bool, Any]:
    try:
        return True, call(*args)
    except Exception as exc:  # raised where the result is asked for, as from the child
        return False, exc


def _child(parent: int, fd: int, call: Callable[..., Any], *args: Any) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group: the parent stops this
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})  # held by signals_held
    if set_parent_death_signal(signal.SIGKILL) and os.getppid() != parent:
        os._exit(ORPHANED)  # the parent died before the prctl: the signal would never come
    code = 0
    try:
        outcome = _made(call, *args)
        try:
            payload = pickle.dumps(outcome, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:  # an exception that does not pickle: said in words
            payload = pickle.dumps((False, RuntimeError(f"{outcome[1]!r} (not picklable: {exc})")))
        with os.fdopen(fd, "wb", closefd=True) as pipe:
            pipe.write(payload)
    except BaseException:  # the parent is gone (broken pipe) or the write failed: nothing to tell
        code = 1
    finally:
        os._exit(code)  # no atexit handlers, no flushing of buffers inherited from the parent
