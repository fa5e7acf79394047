"""The vehicle process's message handling without Zenoh: when it steps and what it takes in (vehicles.node)."""

from __future__ import annotations

import time
from pathlib import Path

from comms.bus import Publishers
from comms.channel import Reception
from comms.messages import (
    COMMS_STEP_KEY,
    Message,
    batches_message,
    decode,
    encode,
    rx_key,
    rx_message,
    state_key,
    tick_message,
)
from supervisor.fleet import initial_state, radio, vehicle_config
from supervisor.scenario import load_scenario
from vehicles.node import _Vehicle
from vehicles.runtime import NodeState

REPO = Path(__file__).resolve().parent.parent
DT = 0.1
VID = 2


class RecordingPublishers(Publishers):
    def __init__(self) -> None:
        self.messages: list[tuple[str, Message]] = []

    def put(self, key: str, message: Message) -> None:
        self.messages.append((key, decode(encode(message))))


def vehicle() -> tuple[_Vehicle, RecordingPublishers]:
    scenario = load_scenario(REPO / "configs" / "paper.toml")
    cfg = vehicle_config(scenario, VID)
    pubs = RecordingPublishers()
    node = _Vehicle(cfg, radio(scenario, VID), NodeState(initial_state(scenario, cfg)), [1], DT, pubs, 0)
    return node, pubs


def send_tick(node: _Vehicle, k: int, wall: float | None) -> None:
    tick = tick_message(k, k * DT, False, wall=wall)
    node(COMMS_STEP_KEY, encode(batches_message(tick, {} if wall is not None else {VID: []})))


def steps(pubs: RecordingPublishers) -> list[Message]:
    return [m for key, m in pubs.messages if key == state_key(VID)]


def reception(arrival: float) -> Reception:
    return Reception(VID, 1, 1, 0.0, arrival, 5.0, 1.0)


def test_lockstep_steps_as_soon_as_the_tick_is_in() -> None:
    node, pubs = vehicle()
    send_tick(node, 0, None)
    assert [m["k"] for m in steps(pubs)] == [0]
    assert node.due() is None


def test_realtime_steps_at_the_ticks_time_not_when_it_comes() -> None:
    node, pubs = vehicle()
    start = time.time() + 100.0  # t = 0 is 100 s away
    send_tick(node, 0, start)
    assert steps(pubs) == [] and node.due() == start
    node.on_time()
    assert steps(pubs) == []  # still not its time
    send_tick(node, 1, start - 200.0 + DT)  # a tick whose time has come waits for the step before it
    assert steps(pubs) == []


def test_realtime_holds_a_reception_that_came_ahead_until_the_step_its_arrival_calls_for() -> None:
    node, pubs = vehicle()
    start = time.time() - 10.0  # every step's time has come
    ahead = time.time() + 50.0  # the broker stamped it due later than now: it came ahead
    early = rx_message(VID, 2, 0.15, [reception(0.15)], lambda t: ahead)  # arrives between t_1 and t_2
    node(rx_key(VID), encode(early))
    send_tick(node, 0, start)
    send_tick(node, 1, start)
    assert [(m["k"], m["rx"]["receptions"]) for m in steps(pubs)] == [(0, []), (1, [])]  # held at k = 0 and 1
    send_tick(node, 2, start)
    last = steps(pubs)[-1]
    assert last["rx"]["k"] == 2 and [r["sender"] for r in last["rx"]["receptions"]] == [1]
    assert len(last["rx_lateness"]) == 1 and -50.0 < last["rx_lateness"][0] < -49.0  # how far ahead it came
    assert node.pending.live == []
