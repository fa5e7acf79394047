"""A vehicle over a time window (vehicles.node, no Zenoh): it steps the window's steps on its own, with each step's
receptions, and reports them in one message that splits back into what single steps report; it says when it may
transmit next; and it refuses to transmit before the step it said (the promise the windows count on, broken)."""

from __future__ import annotations

from pathlib import Path

import pytest

from comms.records.messages import (
    COMMS_STEP_KEY,
    Message,
    batches_message,
    encode,
    split_window,
    state_key,
    tick_message,
)
from comms.records.records import Reception
from supervisor.config.fleet import initial_state, radio, vehicle_config
from supervisor.config.scenario import load_scenario
from tests.conftest import RecordingPublishers
from vehicles.guard import Guarded
from vehicles.node import _Vehicle
from vehicles.runtime import NodeState

REPO = Path(__file__).resolve().parent.parent
DT, VID = 0.1, 2
HEARD = {3: [Reception(1, VID, 1, 0.0, 0.25, 5.0, 1.0)], 7: [Reception(1, VID, 2, 0.5, 0.65, 5.5, 1.0)]}  # by step


def vehicle(period: float) -> tuple[_Vehicle, RecordingPublishers]:
    scenario = load_scenario(REPO / "configs" / "paper.toml", (f"comms.transmit.period={period}",))
    cfg = vehicle_config(scenario, VID)
    pubs = RecordingPublishers()
    return _Vehicle(cfg, radio(scenario, VID), NodeState(initial_state(scenario, cfg)), [1], DT, pubs, 0), pubs


def run(node: _Vehicle, a: int, b: int) -> None:
    """The batches message of the window a .. b-1 (each step's receptions from HEARD), then what serve does."""
    tick = tick_message(a, a * DT, False, until=b if b > a + 1 else None)
    batches = [{VID: HEARD.get(k, [])} for k in range(a, b)]
    node(COMMS_STEP_KEY, encode(batches_message(tick, batches if b > a + 1 else batches[0])))
    node.on_time()


def reported(pubs: RecordingPublishers) -> list[Message]:
    return [m for key, m in pubs.messages if key == state_key(VID)]


def test_a_window_reports_what_single_steps_report():
    single, single_pubs = vehicle(1.0)
    for k in range(11):
        run(single, k, k + 1)
    windowed, window_pubs = vehicle(1.0)
    run(windowed, 0, 1)  # transmits at 0: may again at 10
    run(windowed, 1, 11)  # steps 1 .. 10, transmitting at 10
    messages = reported(window_pubs)
    assert len(messages) == 2 and windowed.k == single.k == 11
    steps = [step for m in messages for step in split_window(m)[0]]
    expected = reported(single_pubs)
    strip = lambda m: {key: v for key, v in m.items() if key not in ("next_tx", "earlier")}  # noqa: E731
    assert [strip(m) for m in steps] == [strip(m) for m in expected]
    assert [m["rx"]["receptions"] != [] for m in steps] == [k in HEARD for k in range(11)]
    assert [m["next_tx"] for m in messages] == [10, 20] == [expected[0]["next_tx"], expected[10]["next_tx"]]
    assert steps[10]["tx"] is not None and all(m["tx"] is None for m in steps[1:10])


def test_a_window_run_past_transmissions_reports_what_single_steps_report():
    """Channel lookahead (comms.broker.lookahead): a window may hold transmissions at or after the step the vehicle
    said it may transmit at; each is in its own step's message, as stepping makes them."""
    single, single_pubs = vehicle(0.3)
    for k in range(11):
        run(single, k, k + 1)
    windowed, window_pubs = vehicle(0.3)
    run(windowed, 0, 1)  # transmits at 0: may again at 3
    run(windowed, 1, 11)  # steps 1 .. 10, transmitting at 3, 6 and 9
    steps = [step for m in reported(window_pubs) for step in split_window(m)[0]]
    strip = lambda m: {key: v for key, v in m.items() if key not in ("next_tx", "earlier")}  # noqa: E731
    assert [strip(m) for m in steps] == [strip(m) for m in reported(single_pubs)]
    assert [k for k, m in enumerate(steps) if m["tx"] is not None] == [0, 3, 6, 9]


def test_a_transmission_before_the_step_the_vehicle_said_is_refused():
    node, _ = vehicle(0.5)
    run(node, 0, 1)
    assert node.promised == 5
    node.promised = 8  # as if its policy's earliest step had said 8 and it then transmitted at 5
    said = r"vehicle 2 transmitted at step 5, before step 8 it said it would: .*earliest\(\) must not be later"
    with pytest.raises(RuntimeError, match=said):
        run(node, 1, 10)


class _Trigger:
    def __init__(self, earliest: object) -> None:
        self.value = earliest

    def due(self, t: float, dt: float, now: object, last: object) -> bool:
        return True

    def earliest(self, lo: int, dt: float, last: float) -> object:
        return self.value


@pytest.mark.parametrize("value", [float("nan"), float("inf"), 2.5, "3", True, None])
def test_a_trigger_whose_earliest_is_not_a_step_is_named(value: object) -> None:
    """A user's earliest() returning NaN ended the vehicle in 'cannot convert float NaN to integer' (found by a new
    user), naming no one: now the guard's one line names the trigger."""
    guarded = Guarded(_Trigger(value), "transmission my_pkg:Trigger")
    with pytest.raises(FloatingPointError, match=r"transmission my_pkg:Trigger earliest\(\) returned .*, not a step"):
        guarded.earliest(1, 0.1, 0.0)
    assert Guarded(_Trigger(7.0), "t").earliest(1, 0.1, 0.0) == 7 == Guarded(_Trigger(7), "t").earliest(1, 0.1, 0.0)
