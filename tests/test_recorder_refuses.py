"""The recorder refuses what would break its writer (record/recorder.py): a time that is not finite, negative, past
the run's end (beyond any MCAP time, 1e11 s), or a message that is not JSON is counted and dropped, and the log
still closes with its summary and index and reads back whole."""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import pytest

from supervisor.record.logfile import messages, verify
from supervisor.record.recorder import TIME_MARGIN, Recorder

DONE = "cpf/comms/done"
BAD_TIMES: list[Any] = [-1.0, 1e11, math.nan, math.inf, -math.inf, 2**70, "3", None, 1e300]
NOT_JSON: list[Any] = [{"t": 1.0, "x": {1, 2}}, {"t": 1.0, "x": 2**80}, {"t": 1.0, "x": object()}, {(1, 2): 3}]


def test_bad_times_and_values_are_refused_and_the_log_still_reads(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "run.mcap"
    with caplog.at_level(logging.WARNING), Recorder(path) as rec:
        assert rec.write(DONE, 0.5, {"t": 0.5})
        for t in BAD_TIMES:
            assert not rec.write(DONE, t, {"t": t if isinstance(t, float) and math.isfinite(t) else 0.0}), t
        for message in NOT_JSON:
            assert not rec.write(DONE, 1.0, message), message
        assert rec.write(DONE, 2.0, {"t": 2.0})
    verify(path)  # summary, index and every chunk whole
    assert [(m.topic, m.log_time, m.message) for m in messages(path)] == [
        (DONE, 500_000_000, {"t": 0.5}),
        (DONE, 2_000_000_000, {"t": 2.0}),
    ]
    assert rec.refused.total() == len(BAD_TIMES) + len(NOT_JSON) and rec.count == 2
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and f"{len(BAD_TIMES) + len(NOT_JSON)} message(s) not recorded" in warnings[0]
    assert f"on {DONE}: time outside" in warnings[0] and "not JSON" in warnings[0]


def test_the_run_end_bounds_the_times(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    with Recorder(path) as rec:
        rec.limit(400.0)
        assert rec.write(DONE, 400.0 + TIME_MARGIN, {"t": 1})
        assert not rec.write(DONE, 400.0 + TIME_MARGIN + 1e-3, {"t": 1})
        assert not rec.write(DONE, -1e-3, {"t": 1})
        assert rec.write(DONE, -1e-12, {"t": 1})  # rounds to 0 ns: a float's error, not a time before the run
    assert [m.log_time for m in messages(path)] == [0, int((400 + TIME_MARGIN) * 1e9)]  # in time order
    assert rec.refused.total() == 2


def test_what_the_supervisor_takes_from_the_bus_cannot_break_its_log(tmp_path: Path) -> None:
    """The issue's messages, through the Zenoh supervisor's intake: the log closes and reads; the bad ones are not in
    it."""
    from comms.bus.bus import Received
    from comms.records.messages import COMMS_STATS_KEY, encode
    from supervisor.config.scenario import load_scenario
    from supervisor.engine.intake import Intake
    from tests.conftest import CONFIGS

    scenario = load_scenario(CONFIGS / "paper.toml")
    path = tmp_path / "run.mcap"
    with Recorder(path) as rec:
        rec.limit(scenario.scenario.duration)
        intake = Intake(scenario, rec, None)
        for key, t in ((DONE, -1.0), (DONE, 1e11), (COMMS_STATS_KEY, math.inf), (COMMS_STATS_KEY, math.nan)):
            intake.take(Received(key, encode({"t": t, "sent": 1})), 1.0)
        good = {"t": 2.0, "window": 10.0, "horizon": 10.0, "lambda2": 0.0, "links": []}
        intake.take(Received(COMMS_STATS_KEY, encode(good)), 2.0)
    verify(path)
    assert [(m.topic, m.log_time) for m in messages(path)] == [(COMMS_STATS_KEY, 2_000_000_000)]
    assert intake.malformed.total() == 4 and rec.refused.total() == 0  # the intake's records refuse them first
