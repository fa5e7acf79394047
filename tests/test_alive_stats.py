"""Statistics while a vehicle is down: over the vehicles alive at each instant, never NaN because one is missing.

A vehicle that is down has no state: NaN in the run's Series (both engines), no record in the log (cpf report).
Three vehicles over 100 s (1 s steps); vehicle 3 is down on [40, 60) s, the phase "during vehicle_kill".
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from supervisor.analysis.figures import aligned
from supervisor.analysis.metrics import run_metrics
from supervisor.analysis.report import RunData, VehicleSeries
from supervisor.analysis.summary import Series, coordination_error, format_summary, summarize
from tests.conftest import run_meta

DURATION, TRANSIENT, TUBE = 100.0, 10.0, 1.2
FAULTS = [("vehicle_kill", 40.0, 60.0)]
T = np.arange(100, dtype=float)
DOWN = (T >= 40) & (T < 60)


def fleet() -> Series:
    """gamma_i = t + offset_i (offsets 0, 0.5, 2: coordination error 2 while vehicle 3 is alive, 0.5 without it);
    path errors 0.8, 0.9 and 1.1 m; gamma_dot 1, 1 and 2. Vehicle 3: NaN while down."""
    gamma = np.stack([T, T + 0.5, T + 2.0], axis=1)
    gamma_dot = np.tile([1.0, 1.0, 2.0], (T.size, 1))
    error = np.tile([0.8, 0.9, 1.1], (T.size, 1))
    for column in (gamma, gamma_dot, error):
        column[DOWN, 2] = np.nan
    return Series((1, 2, 3), T, gamma, gamma_dot, error)


def test_coordination_error_is_over_the_pairs_alive() -> None:
    gamma = np.array([[0.0, 1.0, np.nan], [np.nan, np.nan, 5.0], [1.0, 1.5, 3.0], [np.nan] * 3])
    got = coordination_error(gamma)
    np.testing.assert_array_equal(got[[0, 2]], [1.0, 2.0])
    assert math.isnan(got[1]) and math.isnan(got[3])  # fewer than two alive: no pair to compare


def test_phase_statistics_while_a_vehicle_is_down_are_over_the_vehicles_alive() -> None:
    summary = summarize(fleet(), DURATION, FAULTS, TRANSIENT, TUBE, 0.01)
    before, during, after = summary.phases
    assert during.name == "during vehicle_kill"
    assert (during.max_coordination_error, during.final_coordination_error) == (0.5, 0.5)
    assert during.max_path_error == 0.9
    assert during.mean_gamma_dot[:2] == (1.0, 1.0) and math.isnan(during.mean_gamma_dot[2])
    assert (before.max_coordination_error, after.max_path_error, after.mean_gamma_dot) == (2.0, 1.1, (1.0, 1.0, 2.0))
    assert summary.max_path_error_after_transient == 1.1


def test_a_vehicles_mean_rate_is_over_the_instants_it_was_alive() -> None:
    series = fleet()
    series.gamma_dot[:, 2] = np.where(T < 40, 3.0, 2.0)  # 3 before the kill, 2 after; NaN while down
    series.gamma_dot[DOWN, 2] = np.nan
    whole = summarize(series, DURATION, [], TRANSIENT, TUBE, 0.01).phases[0]
    assert whole.mean_gamma_dot[2] == pytest.approx((40 * 3.0 + 40 * 2.0) / 80)


def test_the_summary_prints_numbers_while_a_vehicle_is_down() -> None:
    text = format_summary(summarize(fleet(), DURATION, FAULTS, TRANSIENT, TUBE, 0.01))
    during = next(line for line in text.splitlines() if line.startswith("during vehicle_kill")).split()
    assert during[3:] == ["0.5", "0.5", "0.900", "1.000", "1.000", "-"]  # "-": vehicle 3's rate, it was down
    assert "nan" not in text
    assert "after the transient (from t = 10 s): max 1.100 m, tube 1.200 m (inside)" in text


def test_the_summary_says_why_there_is_no_path_error_to_judge() -> None:
    series = fleet()
    inside = format_summary(summarize(series, DURATION, [], 200.0, TUBE, 0.01))
    assert "after the transient (from t = 200 s): none (the run ends within it)" in inside
    series.path_error[T >= 90] = np.nan  # nobody alive after the transient
    nobody = format_summary(summarize(series, DURATION, [], 90.0, TUBE, 0.01))
    assert "after the transient (from t = 90 s): none (no vehicle was alive after it)" in nobody


def test_a_run_of_one_step_says_no_state_lies_after_the_transient_not_that_nobody_was_alive() -> None:
    """step = duration: one state, at t = 0, of vehicles alive throughout (a new user)."""
    one = Series((1, 2), np.zeros(1), np.zeros((1, 2)), np.ones((1, 2)), np.full((1, 2), 0.5))
    text = format_summary(summarize(one, 60.0, [], 20.0, TUBE, 0.01))
    assert "after the transient (from t = 20 s): none (no state lies after it: the last is at t = 0 s)" in text


def vehicle_series(vid: int, t: np.ndarray, gamma: np.ndarray, error: float) -> VehicleSeries:
    n = t.size
    errors = np.zeros((n, 3))
    errors[:, 0] = error
    zeros = np.zeros((n, 3))
    return VehicleSeries(vid, t, gamma, np.ones(n), zeros, zeros, errors, zeros, zeros, np.zeros(n))


def report_run() -> RunData:
    """The fleet as `cpf report` reads a log: a down vehicle has no records, so its series has a gap."""
    series = fleet()
    vehicles = {}
    for col, vid in enumerate(series.vehicle_ids):
        alive = ~np.isnan(series.gamma[:, col])
        vehicles[vid] = vehicle_series(vid, T[alive], series.gamma[alive, col], float(series.path_error[0, col]))
    meta = run_meta(step=1.0, duration=DURATION, tube_radius=TUBE, faults=({"kind": "vehicle_kill", "start": 40.0,
                    "end": 60.0},))  # fmt: skip
    return RunData(meta, vehicles, [], [(1, 2), (1, 3)])


def test_report_metrics_while_a_vehicle_is_down_are_over_the_vehicles_alive() -> None:
    metrics = run_metrics(report_run())  # no scenario in the meta: transient 50 s, the default
    coordination, path = metrics["coordination"], metrics["path_following"]
    during = coordination["phases"][1]
    assert (during["max_coordination_error"], during["max_path_error"]) == (0.5, 0.9)
    assert during["mean_gamma_dot"] == {"1": 1.0, "2": 1.0, "3": None}
    assert path == {"max_error_after_transient": 1.1, "tube_radius": TUBE, "inside_tube": True}
    assert coordination["steady_state_error"] == 2.0


def test_the_coordination_figure_draws_nothing_where_a_vehicle_was_down() -> None:
    run = report_run()
    t, gamma = aligned(run, lambda s: s.gamma)
    diff = gamma[:, 0] - gamma[:, 2]  # vehicle 1 - vehicle 3, as the pairwise figure draws it
    assert t.size == 100
    assert np.isnan(diff[DOWN]).all()  # not interpolated across the gap
    np.testing.assert_allclose(diff[~DOWN], -2.0)


def test_a_fleet_that_never_settles_is_said_in_words() -> None:
    """It printed 'below 0.01 from t = never s'."""
    text = format_summary(summarize(fleet(), DURATION, FAULTS, TRANSIENT, TUBE, 0.01))  # 2 apart: never below 0.01
    assert "coordination error never below 0.01 to the end of the first phase" in text
    assert "coordination error never below 0.01 to the end of the last phase" in text
    assert "never s" not in text


@pytest.mark.parametrize("huge", [1e30, -1e300, math.inf, 123456.789])
def test_the_summarys_columns_stay_aligned_whatever_the_values(huge: float) -> None:
    """gamma and gamma_dot of 1e30 ran the columns together ('whole run 0-60 1e+30 9.62e+2998107965...', issue 29)."""
    from supervisor.analysis.summary import PhaseStats, Summary

    phase = PhaseStats("whole run", 0.0, 60.0, huge, huge, huge, (huge, 0.497, math.nan))
    lines = format_summary(Summary((phase, phase), 0.5, 0.1, None, None, 0.01)).splitlines()
    header, rows = lines[0], lines[1:3]
    edges = [22, 36, 48, 60, 75]  # where each column ends (phase, span, max, end, path)
    for row in rows:
        for start, end in itertools.pairwise([0, *edges]):
            assert row[end - 1] != " " or start == 0, (row, header)  # right-aligned: a value ends at its column's end
            assert row[start] == " " or start == 0, (row, header)  # ... and leaves a space before it
        assert len(row.split()) == 2 + 1 + 3 + 3  # 'whole run', span, three numbers, three rates


@pytest.mark.parametrize(
    ("start", "end", "span"),
    [(0.0, 150.0, "0-150"), (150.0, 250.0, "150-250"), (10.0, 10.1, "10-10.1"), (0.1, 0.2, "0.1-0.2"),
     (59.9, 60.0, "59.9-60"), (10.0, 10.05, "10-10.05"), (0.0, 0.001, "0-0.001"), (12.5, 250.0, "12-250")],
)  # fmt: skip
def test_a_phase_span_has_the_decimals_that_tell_its_ends_apart(start: float, end: float, span: str) -> None:
    """Whole seconds printed a one-step phase as "10-10" (a new user); whole-second phases read as before."""
    t = np.arange(0.0, 300.0, 0.001)
    series = Series((1, 2), t, np.zeros((t.size, 2)), np.zeros((t.size, 2)), np.zeros((t.size, 2)))
    text = format_summary(summarize(series, 300.0, [("blackout", start, end)], TRANSIENT, TUBE, 0.01))
    during = next(line for line in text.splitlines() if line.startswith("during blackout"))
    assert during[22:36] == f"{span:>14}"
