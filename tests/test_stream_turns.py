"""comms.records.stream.in_stream: a vehicle's steps are taken once each, in order, by every reader (the supervisor's
intake and the broker). A step that skips one the vehicle has still to send is dropped as out of turn: taking it
turned the vehicle's own step into a replay and stalled the fleet (tests/test_forged_steps.py, end to end)."""

from __future__ import annotations

import pytest

from comms.broker.broker import Broker
from comms.records.bounded import cause_of
from comms.records.stream import BEYOND_WINDOW, OUT_OF_TURN, REPLAYED, STALE, in_stream


def _cause(k: int, taken: int | None, granted: int | None, past: int | None = None, first: int | None = None) -> str:
    with pytest.raises(ValueError) as err:
        in_stream(k, taken, granted, past, first)
    return cause_of(err.value)


def test_the_next_step_is_taken_and_a_skip_is_out_of_turn():
    in_stream(0, -1, 10)  # the first step of a vehicle whose reader expects step 0 (taken seeded at start - 1)
    in_stream(6, 5, 10)
    assert _cause(1, -1, 10) == OUT_OF_TURN  # a first step forged ahead of the vehicle's step 0
    assert _cause(7, 5, 10) == OUT_OF_TURN


def test_a_restarted_vehicles_next_step_is_after_what_the_reader_is_past():
    in_stream(31, 20, 40, past=30)  # back after a kill: its next step follows the reader's, not its own last
    assert _cause(33, 20, 40, past=30) == OUT_OF_TURN
    assert _cause(30, 20, 40, past=30) == STALE


def test_a_window_is_judged_by_its_first_step():
    in_stream(9, 5, 10, first=6)
    assert _cause(9, 5, 10, first=7) == OUT_OF_TURN
    assert _cause(9, 5, 10, first=5) == REPLAYED
    assert _cause(10, 5, 10, first=6) == BEYOND_WINDOW


def test_a_broker_expects_every_vehicles_first_step_from_its_start():
    """However it is built (its process, or a test's): seeded in Broker itself, not by its process's handler."""
    broker = Broker(core=None, vehicles=[1, 2], publishers=None, dt=0.1, start_step=50)  # type: ignore[arg-type]
    assert broker.books.taken == {1: 49, 2: 49}
