"""Smoke test of benchmarks/bench_targets.py: every case's scenario is valid and says what the issue asks (the
benchmark itself is run by `make bench`, never in tests)."""

from __future__ import annotations

from benchmarks import bench_ready
from benchmarks.bench_targets import CASES, scenario_text
from supervisor.config.scenario import parse_scenario


def test_every_case_is_a_valid_scenario_of_its_size_and_message_rate() -> None:
    for case in CASES:
        scenario = parse_scenario(scenario_text(case), f"{case.name}.toml")
        assert scenario.scenario.duration == case.duration, case.name
        if case.vehicles:
            assert len(scenario.vehicle_ids) == case.vehicles, case.name
            assert scenario.comms.transmit.period == case.period, case.name


def test_the_readiness_benchmark_sees_a_vehicle_come_alive() -> None:
    """Smoke run of benchmarks/bench_ready.py: one start, timed to its liveliness token (the number is the
    benchmark's, never asserted here)."""
    row = bench_ready.measure(1)
    assert len(row["ready_s_all"]) == 1 and row["ready_s_best"] > 0
