"""Ctrl-C and SIGTERM, taken where a run can stop cleanly.

Python's own SIGINT handling raises KeyboardInterrupt wherever the main thread happens to be. In a run that can be
inside the MCAP writer between a record's length and its bytes, which left a log whose tick message was garbage (seen
in the test suite), or inside a library that swallows the exception, which left the run going on to its end (seen
twice). So while an engine runs (`deferred()`), the CLI's handler (`handle`) only records the request, and the
engine raises KeyboardInterrupt at its safe points (`check()`: every step, and every wait on the bus). Outside a run
the handler raises at once, as Python's does.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable, Iterator
from types import FrameType
from typing import ParamSpec, TypeVar

P = ParamSpec("P")
R = TypeVar("R")

_requested = False
_deferred = 0
_stopping = False  # a KeyboardInterrupt has been raised: the process is stopping, its cleanup is not interrupted


def handle(signum: int, frame: FrameType | None) -> None:
    """The handler the CLI installs for SIGINT and SIGTERM. A second signal while the first one's KeyboardInterrupt
    unwinds (a double Ctrl-C during start-up: children being stopped, the log closed) is not raised again: raised
    inside the cleanup, or inside the CLI's own `except KeyboardInterrupt`, it ended the process by the signal (-2)
    or with a traceback instead of one line and exit 130 (issue 29)."""
    global _requested
    _requested = True
    if not _deferred and not _stopping:
        _interrupt()


def reset() -> None:
    """A command starts: no request, not stopping (the CLI's main, once per command)."""
    global _requested, _stopping
    _requested, _stopping = False, False


def _interrupt() -> None:
    global _requested, _stopping
    _requested, _stopping = False, True
    raise KeyboardInterrupt


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Inside, a signal only records the request: the run stops at its next `check()`. A run that begins after a stop
    was raised stops at once: that KeyboardInterrupt was swallowed where it landed (in a callback whose exceptions
    Python ignores, an import's module-lock weakref: "Exception ignored in ...", seen by
    tests/test_double_interrupt.py), and the run went on to its end, exit 0."""
    global _deferred
    if not _deferred and _stopping:
        raise KeyboardInterrupt
    _deferred += 1
    try:
        yield
    finally:
        _deferred -= 1


def deferring(run: Callable[P, R]) -> Callable[P, R]:
    """An engine's entry point, run inside `deferred()`."""

    @functools.wraps(run)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        with deferred():
            return run(*args, **kwargs)

    return wrapper


def running() -> bool:
    """Whether a run is under way (inside `deferred()`): a signal now stops it at its next safe point."""
    return _deferred > 0


def stopping() -> bool:
    """Whether a stop was asked for since the command began (raised already or still to come)."""
    return _requested or _stopping


def check() -> None:
    """A safe point: KeyboardInterrupt if a stop was asked for (once: cleanup after it is not interrupted again)."""
    if _requested and not _stopping:
        _interrupt()
