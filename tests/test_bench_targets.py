"""Smoke test of benchmarks/bench_targets.py: every case's scenario is valid and says what the issue asks (the
benchmark itself is run by `make bench`, never in tests)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from benchmarks import ROOT, bench_ready, bench_startup
from benchmarks.bench_targets import CASES, case_row, scenario_text
from supervisor.config.scenario import parse_scenario


def test_every_case_is_a_valid_scenario_of_its_size_and_message_rate() -> None:
    for case in CASES:
        scenario = parse_scenario(scenario_text(case), f"{case.name}.toml")
        assert scenario.scenario.duration == case.duration, case.name
        if case.vehicles:
            assert len(scenario.vehicle_ids) == case.vehicles, case.name
            assert scenario.comms.transmit.period == case.period, case.name


def test_the_thousand_auv_case_runs_in_process_and_is_bounded_by_its_vehicle_steps(tmp_path: Path) -> None:
    """ring1000-1hz runs in-process only (its target's engine); its row also gives the bound its vehicles' steps set:
    N x (a vehicle's step) of CPU per step of dt, on one core in-process, where they step as lanes (a vehicle's
    share of 200 stepped together), on every core over Zenoh, where each steps alone."""
    import pytest

    from benchmarks.bench_targets import step_bound, summary

    (case,) = [c for c in CASES if c.vehicles == 1000]
    assert case.engines == ("inprocess",)
    bound = step_bound(case, tmp_path, steps=20)
    assert bound["max_real_time_inprocess"] == pytest.approx(0.1 / (1000 * bound["vehicle_step_lanes_us"] * 1e-6))
    assert bound["max_real_time_zenoh"] == pytest.approx(
        bound["cores"] * 0.1 / (1000 * bound["vehicle_step_us"] * 1e-6)
    )
    row = case_row(case, case.name, [80.0, 90.0], [], [])
    row["bound"] = bound
    text = summary(row)
    assert "in-process  80.00 s (  0.8x, spread 10.00)" in text and "zenoh" not in text.split("[target")[0], text
    assert f"{bound['vehicle_step_lanes_us']:.0f} as lanes" in text
    sweep = {"case": "sweep", "runs": 2, "best_s": 6.0, "spread_s": 0.5, "extrapolated_1000_runs_min": 50.0,
             "target": "1000 runs <= 2 min (issue 26)"}  # fmt: skip
    assert summary(sweep).startswith("sweep: 2 runs in 6.0 s")  # (it was read as a case not run: KeyError)


def test_the_readiness_benchmark_sees_a_vehicle_come_alive() -> None:
    """Smoke run of benchmarks/bench_ready.py: one start spawned, one forked, each timed to its liveliness token (the
    numbers are the benchmark's, never asserted here)."""
    row = bench_ready.measure(1)
    for how in ("spawn", "fork"):
        assert len(row[f"{how}_ready_s_all"]) == 1 and row[f"{how}_ready_s_best"] > 0
    assert "forked" in bench_ready.summary(row)


def test_the_startup_benchmark_starts_a_fleet_forked_and_spawned() -> None:
    """Smoke run of benchmarks/bench_startup.py: 3 AUVs, 1 s, once each way."""
    row = bench_startup.measure(3, 1.0, 1)
    for how in ("fork", "spawn"):  # (memory is sampled every 0.2 s: a run this short may end unsampled)
        assert row[how]["startup_s"]["best"] > 0 and row[how]["real_time_factor"]["best"] > 0
    assert "fork start-up" in bench_startup.summary(row)


def test_every_lookahead_case_is_the_scenario_it_says() -> None:
    """benchmarks/bench_lookahead.py's cases: valid, on the links they name (its timing is `make bench`'s)."""
    from benchmarks import bench_lookahead

    for name, (file, overrides) in bench_lookahead.CASES.items():
        sc = parse_scenario(bench_lookahead.scenario_text(name), file, overrides)
        assert (sc.comms.tdma is None) == (name != "acoustic"), name
        if name == "delayed-links":
            assert [link.extra_delay for link in sc.comms.links] == [2.0] * 4 and len(sc.graph.edges) == 2
        if name == "every-step":
            assert sc.comms.bitrate == 60 and sc.comms.transmit.period is None


def test_the_sweep_split_replays_the_same_run_for_less() -> None:
    """benchmarks/bench_sweep_split.py on a short paper run: the replayed run gives the same row (measure raises
    otherwise) and costs less than the whole one; its figures are `make bench`'s."""
    from benchmarks import bench_sweep_split

    result = bench_sweep_split.measure(ROOT / "configs" / "paper.toml", 1, duration=5.0)
    assert result["vehicle_steps"] == 3 * 50
    assert 0.0 < result["rest_cpu_s"] < result["whole_cpu_s"]
    assert "with a vehicle step that cost nothing" in bench_sweep_split.summary(result)


def test_the_parse_benchmark_reads_whole_step_messages_as_the_broker_does(tmp_path: Path) -> None:
    """benchmarks/bench_parse.py's broker and vehicle rows on a short paper run: each vehicle's step message of each
    step carries that step's state, transmission and reception batch, and the broker reads every one in one pass;
    each step's batches message carries every vehicle's receptions, and each vehicle reads its own in one pass."""
    from benchmarks import bench_parse
    from comms.broker import step_reading
    from comms.records.bus_records import read_batches

    short = tmp_path / "paper.toml"
    short.write_text((ROOT / "configs" / "paper.toml").read_text().replace("duration = 400.0", "duration = 2.0"))
    found = bench_parse.logged(short)
    payloads = bench_parse.step_messages(found)
    assert len(payloads) == 3 * 20
    for payload, vid in payloads:
        window = step_reading.read_window(payload)
        assert window is not None and window[0][-1].tx is not None and window[0][-1].rx is not None, vid
    batches = bench_parse.batches_messages(found, 0.1)
    assert len(batches) == 3 * 20
    heard = [read_batches(payload, vid, 0.1) for payload, vid in batches]
    assert all(read is not None and read[1] is not None for read in heard)
    assert sum(len(read[1][0].receptions) for read in heard if read and read[1]) > 0  # the paper's links deliver
    text = bench_parse.summary(bench_parse.measure(short))
    assert "broker's step message" in text and "vehicle's batches message" in text


def test_the_lanes_benchmark_checks_every_lane_against_the_scalar_call(monkeypatch: Any) -> None:
    """benchmarks/bench_lanes.py on a few lanes, for the paper's AUV and one with lift: the array call gives each
    lane the scalar call's bits (measure raises otherwise: seen here with the array result one ulp off)."""
    import numpy as np
    import pytest

    from benchmarks import bench_lanes

    for path in (ROOT / "configs" / "paper.toml", ROOT / "configs" / "ring10_1hz.toml"):
        row = bench_lanes.measure(path, 5)
        assert row["array_us_per_lane"] > 0 and row["scalar_us_per_lane"] > 0
    assert "the same bits" in bench_lanes.summary(row)
    real = bench_lanes.plant_rates

    def one_ulp_off(*args: Any) -> Any:
        out = real(*args)
        return (np.nextafter(out[0], np.inf), *out[1:]) if isinstance(out[0], np.ndarray) else out

    steps = bench_lanes.measure_steps(ROOT / "configs" / "paper.toml", 4, 2)
    assert steps["lanes_us"] > 0 and "(the same state messages)" in bench_lanes.steps_summary([steps])
    monkeypatch.setattr(bench_lanes, "plant_rates", one_ulp_off)
    with pytest.raises(AssertionError, match="lane 0"):
        bench_lanes.measure(ROOT / "configs" / "paper.toml", 5)
