"""Ctrl-C and SIGTERM during a run are taken at a safe point (supervisor/engine/interrupts.py): the handler only
records the request while an engine runs, and the engine stops at its next step or wait; outside a run it raises."""

from __future__ import annotations

import contextlib
import io
import signal

import pytest

from supervisor.engine import interrupts
from supervisor.engine.progress import Progress


@pytest.fixture(autouse=True)
def no_request(monkeypatch):
    monkeypatch.setattr(interrupts, "_requested", False)
    monkeypatch.setattr(interrupts, "_deferred", 0)
    monkeypatch.setattr(interrupts, "_stopping", False)


def test_outside_a_run_the_handler_raises_at_once():
    with pytest.raises(KeyboardInterrupt):
        interrupts.handle(signal.SIGINT, None)


def test_inside_a_run_the_request_waits_for_the_next_step():
    line = Progress(10.0, stream=io.StringIO())
    with interrupts.deferred():
        interrupts.handle(signal.SIGINT, None)  # e.g. while the recorder writes a record: nothing raised there
        with pytest.raises(KeyboardInterrupt):
            line.update(1.0)
        line.update(2.0)  # taken once: the cleanup after it is not interrupted again


def test_an_engine_entry_point_defers(monkeypatch):
    seen = []

    @interrupts.deferring
    def run() -> str:
        interrupts.handle(signal.SIGTERM, None)
        seen.append("went on")
        interrupts.check()
        return "never"

    with pytest.raises(KeyboardInterrupt):
        run()
    assert seen == ["went on"]
    interrupts.handle(signal.SIGINT, None)  # stopping: its cleanup is not interrupted again (issue 29)
    interrupts.reset()  # the next command
    with pytest.raises(KeyboardInterrupt):  # raised at once again
        interrupts.handle(signal.SIGINT, None)


def test_a_stop_swallowed_before_a_run_stops_the_run_as_it_begins():
    """The KeyboardInterrupt of a Ctrl-C during start-up can land where Python ignores it (a weakref callback of an
    import): the run then began and went on to its end with exit 0 (a double Ctrl-C, 1 try in 3 of the suite's)."""
    with contextlib.suppress(KeyboardInterrupt):  # swallowed where it landed
        interrupts.handle(signal.SIGINT, None)
    interrupts.handle(signal.SIGINT, None)  # the second press: recorded, not raised
    with pytest.raises(KeyboardInterrupt), interrupts.deferred():
        pytest.fail("the run began")
    assert interrupts._deferred == 0


def test_a_second_signal_while_the_first_unwinds_is_not_raised_again():
    """A double Ctrl-C during start-up: the second came inside the first one's cleanup (or the CLI's except) and
    ended the process by the signal or with a traceback."""
    with pytest.raises(KeyboardInterrupt):
        interrupts.handle(signal.SIGINT, None)
    interrupts.handle(signal.SIGINT, None)  # in the cleanup: recorded, not raised
    interrupts.check()  # nor at a safe point of that cleanup
