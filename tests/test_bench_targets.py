"""Smoke test of benchmarks/bench_targets.py: every case's scenario is valid and says what the issue asks (the
benchmark itself is run by `make bench`, never in tests)."""

from __future__ import annotations

from benchmarks.bench_targets import CASES, scenario_text
from supervisor.config.scenario import parse_scenario


def test_every_case_is_a_valid_scenario_of_its_size_and_message_rate() -> None:
    for case in CASES:
        scenario = parse_scenario(scenario_text(case), f"{case.name}.toml")
        assert scenario.scenario.duration == case.duration, case.name
        if case.vehicles:
            assert len(scenario.vehicle_ids) == case.vehicles, case.name
            assert scenario.comms.transmit.period == case.period, case.name
