"""The bus inbox's wait (comms.bus.bus.Inbox.get) ends at its timeout whatever signals come meanwhile. In CPython 3.11
queue.SimpleQueue.get(timeout) blocks for ever when a signal interrupts its wait and the handler runs past the
timeout (it retries with a negative timeout, which means none): a realtime run's supervisor hung so for 50 min, its
main thread in SimpleQueue.get(timeout=0.003) with PyThread_acquire_lock_timed(microseconds=-1353)."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Iterator

import pytest

from comms.bus.bus import Inbox


@pytest.fixture
def slow_signal() -> Iterator[None]:
    """SIGUSR1 handled by a handler that outlasts the wait below; the handler before it put back after."""
    before = signal.signal(signal.SIGUSR1, lambda *_: time.sleep(0.05))
    try:
        yield
    finally:
        signal.signal(signal.SIGUSR1, before)


def test_a_wait_ends_at_its_timeout_when_a_slow_signal_handler_interrupts_it(slow_signal: None) -> None:
    inbox = Inbox()
    threading.Timer(0.01, lambda: os.kill(os.getpid(), signal.SIGUSR1)).start()
    late = threading.Timer(3.0, inbox.nudge)  # ends a wait that would otherwise never end (the old inbox's)
    late.start()
    start = time.monotonic()
    got = inbox.get(0.02)
    waited = time.monotonic() - start
    late.cancel()
    assert got is None and waited < 1.0  # the old inbox: "" after 3 s


def test_what_arrives_is_taken_in_order_and_an_empty_inbox_times_out() -> None:
    inbox = Inbox()
    for item in ("+a", "-a", ""):
        inbox._put(item)
    assert [inbox.get(0.01) for _ in range(4)] == ["+a", "-a", "", None]
    threading.Timer(0.02, inbox.nudge).start()
    assert inbox.get(5.0) == ""  # a wait ends when something comes
