"""The series builder (supervisor.analysis.series): whatever order the states come in (the in-process engine's in
step order, the Zenoh supervisor's a window of steps of one vehicle after another), a vehicle's step again, a step
out of range, the array holds each vehicle's latest state of each step."""

from __future__ import annotations

import random

import numpy as np
import pytest

from comms.records.state import StateReport
from supervisor.analysis.series import SeriesBuilder, _inputs, _magnitude

IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
IDS = (3, 1, 7)
STEPS = 1500  # past the builder's first rows: it grows on the way


def _state(rng: random.Random, k: int, vehicle: int, planar: bool) -> StateReport:
    error = (rng.uniform(-2, 2), rng.uniform(-2, 2), 0.0 if planar else rng.uniform(-2, 2))
    tau = (rng.uniform(-9, 9), rng.uniform(-9, 9)) if planar else (rng.uniform(-9, 9),) * 3
    velocity = (rng.uniform(0, 2), 0.0, 0.0)
    return StateReport(k * 0.1, k, vehicle, rng.uniform(0, 9), rng.uniform(0, 1), (0.0,) * 3, IDENTITY, velocity,
                       (0.0,) * 3, error, tau, 0.0, 0.0, 0, ())  # fmt: skip


def _one_at_a_time(states: list[StateReport]) -> np.ndarray:
    """What the builder held when each state went in on its own: the row of the latest state of each step."""
    data = np.full((STEPS, 7, len(IDS)), np.nan)
    for s in states:
        if 0 <= s.k < STEPS:
            row = (s.gamma, s.gamma_dot, _magnitude(s.error), *_inputs(s.tau), s.velocity[0])
            data[s.k, :, IDS.index(s.vehicle)] = row
    return data


def _states(rng: random.Random, order: str) -> list[StateReport]:
    """States of IDS over the run (vehicle 7 gone after step 900), some steps again, some outside the run; in step
    order (the in-process engine), in windows of 100 steps vehicle after vehicle (the Zenoh supervisor's intake), or
    shuffled."""
    states = [_state(rng, k, v, rng.random() < 0.3) for k in range(0, STEPS, 7) for v in IDS if v != 7 or k < 900]
    again = [_state(rng, s.k, s.vehicle, False) for s in rng.sample(states, 40)]
    states += [_state(rng, k, 1, False) for k in (-1, STEPS, STEPS + 5)]  # outside the run: not in the series
    if order == "windows":
        states.sort(key=lambda s: (s.k // 100, s.vehicle, s.k))
    elif order == "shuffled":
        rng.shuffle(states)
    for repeat in again:  # a vehicle's step again, right after it (a restarted process): its latest counts
        states.insert(
            next(n for n, s in enumerate(states) if (s.k, s.vehicle) == (repeat.k, repeat.vehicle)) + 1, repeat
        )
    return states


@pytest.mark.parametrize("order", ["steps", "windows", "shuffled"])
def test_the_series_holds_each_vehicles_latest_state_of_each_step_in_any_order(order):
    rng = random.Random(order)
    states = _states(rng, order)
    builder = SeriesBuilder(IDS, STEPS, 0.1)
    for s in states:
        builder.add(s)
    series = builder.series()
    assert series.inputs is not None and series.surge is not None
    want = _one_at_a_time(states)
    got = np.stack([series.gamma, series.gamma_dot, series.path_error, *np.moveaxis(series.inputs, 1, 0),
                    series.surge], axis=1)  # fmt: skip
    np.testing.assert_array_equal(got, want)
    assert np.isnan(got).any() and not np.isnan(got[:, 0]).all()
