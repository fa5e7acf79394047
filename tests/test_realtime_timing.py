"""supervisor.engine.realtime_timing: how a realtime run kept to the wall clock, from the vehicles' records."""

from __future__ import annotations

import pytest

from comms.records.messages import Message, rx_message
from comms.records.records import Reception
from supervisor.engine.realtime_timing import RealtimeTiming, fell_behind, format_timing

DT = 0.1


def batch(k: int, *arrivals: float) -> Message:
    """A realtime reception batch as a vehicle records it: taken in at step k."""
    return rx_message(2, k, k * DT, [Reception(2, 1, 1, 0.0, a, 5.0, 1.0) for a in arrivals], lambda t: 100.0 + t)


def test_delivery_error_counts_only_lateness_and_steps_taken_late_come_from_arrival_steps() -> None:
    timing = RealtimeTiming(DT)
    timing.add_state({"k": 3, "rx_lateness": [-0.004, 0.002, -0.001], "step_lateness": 0.0005})
    timing.add_state({"k": 4, "rx_lateness": [0.010], "step_lateness": 0.0015})
    timing.add_rx(batch(3, 0.25, 0.29))  # due at k = 3: on time
    timing.add_rx(batch(4, 0.28))  # due at k = 3, taken at k = 4
    out = timing.as_dict()
    assert out["deliveries"] == 4 and out["receptions"] == 3 and out["taken_in_a_step_late"] == 1
    assert out["max_ms"] == pytest.approx(10.0) and out["p50_ms"] == pytest.approx(1.0)  # errors 0, 2, 0, 10 ms
    assert out["ahead_share"] == pytest.approx(0.5)
    assert out["step_lateness_p50_ms"] == pytest.approx(1.0)
    line = format_timing(out)
    assert "1 of 3 receptions taken in a step late" in line and "max 10.00 ms" in line and "50% came ahead" in line


def test_fields_that_are_not_numbers_are_left_out_and_never_raise() -> None:
    timing = RealtimeTiming(DT)
    timing.add_state({"rx_lateness": ["x", None, True, float("nan"), 0.001], "step_lateness": "late"})
    timing.add_state({"rx_lateness": 5})
    timing.add_rx({**batch(3, 0.2), "k": "3"})
    timing.add_rx({**batch(3, 0.2), "receptions": ["not a map"]})
    bad_arrival = batch(3, 0.2, 0.25)
    bad_arrival["receptions"][1]["arrival"] = None
    timing.add_rx(bad_arrival)  # left out whole
    out = timing.as_dict()
    assert out["deliveries"] == 1 and out["receptions"] == 0 and out["step_lateness_p50_ms"] is None
    assert format_timing(out).endswith("no steps")


def test_a_run_without_deliveries_says_so() -> None:
    assert format_timing(RealtimeTiming(DT).as_dict()).startswith("realtime: no deliveries")


def test_a_realtime_run_that_cannot_keep_its_speed_says_so(tmp_path, paper_text) -> None:
    """--speed 50 on a machine that gave 2.6x said nothing (a new user): a warning with what it ran at. The paper in
    process goes at ~100x here; 100000x no machine gives."""
    from tests.conftest import shortened
    from tests.procs import cpf

    scenario = tmp_path / "p.toml"
    scenario.write_text(shortened(paper_text, 2.0))
    args = ["run", str(scenario), "--engine", "inprocess", "--clock", "realtime", "--quiet", "--out", "r.mcap"]
    done = cpf(*args, "--speed", "100000", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "the run fell behind --speed 100000: it ran at " in done.stderr, done.stderr
    kept = cpf(*args, "--speed", "2", cwd=tmp_path)
    assert kept.returncode == 0 and "fell behind" not in kept.stderr, kept.stderr


def test_falling_behind_is_below_the_kept_share_of_the_speed() -> None:
    assert fell_behind(10.0, 1.0, 10.0) is None and fell_behind(10.0, 1.04, 10.0) is None
    assert fell_behind(10.0, 1.1, 10.0) is not None
