"""The vehicle process's message handling without Zenoh: when it steps and what it takes in (vehicles.node)."""

from __future__ import annotations

from pathlib import Path

import pytest

from comms.records.messages import (
    COMMS_STEP_KEY,
    Message,
    batches_message,
    encode,
    rx_key,
    rx_message,
    state_key,
    tick_lead,
    tick_message,
)
from comms.records.records import Reception
from supervisor.config.fleet import initial_state, radio, vehicle_config
from supervisor.config.scenario import load_scenario
from tests.conftest import RecordingPublishers
from vehicles.node import _Vehicle
from vehicles.runtime import NodeState

REPO = Path(__file__).resolve().parent.parent
DT = 0.1
VID = 2
LEAD = tick_lead(DT, 1.0)


class FakeClock:
    """The vehicle process's wall clock (its `now`), set by the test."""

    def __init__(self, now: float) -> None:
        self.now = now

    def time(self) -> float:
        return self.now


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock(1000.0)


def vehicle(clock: FakeClock | None = None) -> tuple[_Vehicle, RecordingPublishers]:
    """The vehicle process's handler; on the test's clock if given, else on the wall clock (lockstep needs none)."""
    scenario = load_scenario(REPO / "configs" / "paper.toml")
    cfg = vehicle_config(scenario, VID)
    pubs = RecordingPublishers()
    initial = NodeState(initial_state(scenario, cfg))
    if clock is None:
        return _Vehicle(cfg, radio(scenario, VID), initial, [1], DT, pubs, 0), pubs
    return _Vehicle(cfg, radio(scenario, VID), initial, [1], DT, pubs, 0, now=clock.time), pubs


def send_tick(node: _Vehicle, k: int, wall: float | None, comms: bool = True) -> None:
    tick = tick_message(k, k * DT, False, comms=comms, wall=wall)
    serve_one(node, COMMS_STEP_KEY, encode(batches_message(tick, {} if wall is not None else {VID: []})))


def serve_one(node: _Vehicle, key: str, payload: bytes) -> None:
    """What comms.bus.bus.serve does with each message: hand it over, then run what is due."""
    node(key, payload)
    node.on_time()


def steps(pubs: RecordingPublishers) -> list[Message]:
    return [m for key, m in pubs.messages if key == state_key(VID)]


def reception(arrival: float) -> Reception:
    return Reception(VID, 1, 1, 0.0, arrival, 5.0, 1.0)


def test_lockstep_steps_as_soon_as_the_tick_is_in() -> None:
    node, pubs = vehicle()
    send_tick(node, 0, None)
    assert [m["k"] for m in steps(pubs)] == [0]
    assert node.due() is None


def test_realtime_steps_at_the_ticks_time_not_when_it_comes(clock: FakeClock) -> None:
    node, pubs = vehicle(clock)
    send_tick(node, 0, clock.now + 0.01)  # came 10 ms ahead
    assert steps(pubs) == [] and node.due() == pytest.approx(clock.now + 0.01)
    clock.now += 0.009
    node.on_time()
    assert steps(pubs) == []  # not its time yet
    clock.now += 0.001
    node.on_time()
    assert [m["k"] for m in steps(pubs)] == [0] and steps(pubs)[0]["step_lateness"] == pytest.approx(0.0, abs=1e-9)


def test_realtime_waits_no_longer_than_the_lead_when_its_clock_lags_the_supervisors(clock: FakeClock) -> None:
    node, pubs = vehicle(clock)
    send_tick(node, 0, clock.now + 100.0)  # by this host's clock the tick is 100 s early: its clock lags
    assert node.due() == pytest.approx(clock.now + LEAD)
    clock.now += LEAD
    node.on_time()
    assert [m["k"] for m in steps(pubs)] == [0]


def test_realtime_holds_a_reception_that_came_ahead_until_the_step_its_arrival_calls_for(clock: FakeClock) -> None:
    node, pubs = vehicle(clock)
    ahead = clock.now + 50.0  # the broker stamped it due 50 s from now: it came ahead
    early = rx_message(VID, 2, 0.15, [reception(0.15)], lambda t: ahead)  # arrives between t_1 and t_2
    serve_one(node, rx_key(VID), encode(early))
    send_tick(node, 0, clock.now)
    send_tick(node, 1, clock.now)
    assert [(m["k"], m["rx"]["receptions"]) for m in steps(pubs)] == [(0, []), (1, [])]  # held at k = 0 and 1
    send_tick(node, 2, clock.now)
    last = steps(pubs)[-1]
    assert last["rx"]["k"] == 2 and [r["sender"] for r in last["rx"]["receptions"]] == [1]
    assert last["rx_lateness"] == [pytest.approx(-50.0)]  # how far ahead it came
    assert node.pending.live == []


def test_realtime_takes_in_nothing_at_a_tick_the_broker_did_not_live_to(clock: FakeClock) -> None:
    """A reception held for step 1, when the broker dies at tick 1: it never reported it delivered, and lockstep
    would never hand it out."""
    node, pubs = vehicle(clock)
    serve_one(node, rx_key(VID), encode(rx_message(VID, 1, 0.05, [reception(0.05)], lambda t: clock.now)))
    send_tick(node, 0, clock.now)
    send_tick(node, 1, clock.now, comms=False)
    last = steps(pubs)[-1]
    assert last["k"] == 1 and last["rx"] is None and last["rx_lateness"] == []
    assert node.pending.live == []


def test_a_realtime_batch_with_one_malformed_delivery_is_dropped_whole(clock: FakeClock) -> None:
    node, _ = vehicle(clock)
    message = rx_message(VID, 1, 0.05, [reception(0.04), reception(0.05)], lambda t: clock.now)
    del message["receptions"][1]["due"]
    serve_one(node, rx_key(VID), encode(message))
    assert node.pending.live == [] and node.pending.drops.total == 1
