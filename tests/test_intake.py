"""The supervisor's intake reads a vehicle's state through its record (comms.records.state.StateReport)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from comms.bus.bus import Received
from comms.records.events import LinkEvents
from comms.records.messages import COMMS_EVENTS_KEY, encode, state_key, step_message
from comms.records.records import LinkEvent
from comms.records.state import NeighbourAge, StateReport
from supervisor.config.scenario import parse_scenario
from supervisor.engine.intake import Intake
from supervisor.record.recorder import Recorder
from tests.conftest import CONFIGS

REPORT = StateReport(
    0.1, 1, 1, 4.25, 0.98, (1.0, -2.0, 3.0), (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (1.2, 0.1, 0.0),
    (0.0, 0.0, 0.3), (0.5, -0.25, 0.0), (10.0, 3.0), -0.02, 0.75, 6, (NeighbourAge(2, 0.5),),
)  # fmt: skip


def test_a_state_is_booked_only_when_it_reads_as_a_state(tmp_path: Path) -> None:
    """A state the record refuses (a position that is not finite) is not booked as stepped; as its vehicle's next
    step, it is the vehicle's fault (issue 29): what follows from it is dropped, and the run decides
    (scenario.on_vehicle_loss); a state that reads is booked."""
    sc = parse_scenario((CONFIGS / "paper.toml").read_text())
    with Recorder(tmp_path / "run.mcap") as rec:
        intake = Intake(sc, rec, None)
        broken = {**REPORT.to_message(), "position": [math.nan, 0.0, 0.0]}
        intake.take(Received(state_key(1), encode(step_message(broken, None, None))), 0.1)
        assert intake.states == {} and intake.last_seq == {} and list(intake.faulty) == [1]
        intake.take(Received(state_key(1), encode(step_message(REPORT.to_message(), None, None))), 0.1)
        assert intake.states == {} and intake.drops.by_cause == {"not finite": 1, "faulty vehicle": 1}
        intake = Intake(sc, rec, None)
        intake.take(Received(state_key(1), encode(step_message(REPORT.to_message(), None, None))), 0.1)
        assert intake.states == {1: {1}} and intake.last_seq == {1: 6}


def test_a_window_waits_for_the_deliveries_of_its_step_that_come_after_its_states(tmp_path: Path) -> None:
    """The broker publishes a step's link events after the batches the vehicles step on, so the supervisor may have
    every state of step k before its events: lambda_2 of a stats window ending at k is taken only once they are in
    (the paper's graph 2 - 1 - 3: lambda_2 = 1 with both links delivering, 0 if taken without them)."""
    sc = parse_scenario((CONFIGS / "paper.toml").read_text())
    end = sc.comms.stats_window  # the first window's end
    delivered = [LinkEvent(end - 0.05, s, 1, 7, "delivered", delay=0.05) for s in (2, 3)]
    with Recorder(tmp_path / "run.mcap") as rec:
        intake = Intake(sc, rec, None)
        alive = sc.vehicle_ids
        intake.window(end - sc.scenario.step, alive)
        intake.window(end, alive)  # the step's states are in, its events not yet
        assert intake.books.lambda2 == []
        intake.take(Received(COMMS_EVENTS_KEY, encode(LinkEvents(end, 100, tuple(delivered)).to_message())), end)
        assert intake.books.lambda2 == [{"t": end, "lambda2": pytest.approx(1.0)}]
        intake.window(end + sc.scenario.step, alive)
        intake.close_windows()  # the end of the run: nothing waits any longer
        assert not intake.windows
