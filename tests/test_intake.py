"""The supervisor's intake reads a vehicle's state through its record (comms.state.StateReport)."""

from __future__ import annotations

import math
from pathlib import Path

from comms.bus import Received
from comms.messages import encode, state_key, step_message
from comms.state import StateReport
from supervisor.config.scenario import parse_scenario
from supervisor.engine.intake import Intake
from supervisor.record.recorder import Recorder
from tests.conftest import CONFIGS

REPORT = StateReport(
    0.1, 1, 1, 4.25, 0.98, (1.0, -2.0, 3.0), (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (1.2, 0.1, 0.0),
    (0.0, 0.0, 0.3), (0.5, -0.25, 0.0), (10.0, 3.0), -0.02, 0.75, 6, ((2, 0.5),),
)  # fmt: skip


def test_a_state_is_booked_only_when_it_reads_as_a_state(tmp_path: Path) -> None:
    """A state the record refuses (a position that is not finite) is on the record but not booked as stepped."""
    sc = parse_scenario((CONFIGS / "paper.toml").read_text())
    with Recorder(tmp_path / "run.mcap") as rec:
        intake = Intake(sc, rec, None)
        broken = {**REPORT.to_message(), "position": [math.nan, 0.0, 0.0]}
        intake.take(Received(state_key(1), encode(step_message(broken, None, None))), 0.1)
        assert intake.states == {} and intake.last_seq == {}
        intake.take(Received(state_key(1), encode(step_message(REPORT.to_message(), None, None))), 0.1)
        assert intake.states == {1: {1}} and intake.last_seq == {1: 6}
