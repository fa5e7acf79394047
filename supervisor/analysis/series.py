"""Collects the state reports of a run into the arrays the summary needs, whichever engine produced them."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from comms.records.state import StateReport
from numerics.linalg import norm3
from supervisor.analysis.summary import Series

INITIAL_ROWS = 1024  # steps held before the first growth; the array doubles as the run goes
_COLUMNS = 7  # gamma, gamma_dot, |p - p_d|, surge force, pitch torque, yaw torque, surge speed
BYTES_PER_VEHICLE_STEP = 2 * _COLUMNS * 8  # what a run's series holds at its end: the builder's array and the Series


class SeriesBuilder:
    """Rows of (gamma, gamma_dot, |p - p_d|, the three inputs, surge speed) per step and vehicle, NaN where no state
    came in. The array grows with
    the steps that arrive (doubling, so amortised O(1) a state): nothing is allocated for the whole duration up
    front, and a run that stops early never held more than it recorded."""

    def __init__(self, vehicle_ids: Sequence[int], steps: int, dt: float) -> None:
        self.ids = tuple(vehicle_ids)
        self._column = {vid: col for col, vid in enumerate(self.ids)}
        self._steps = steps
        self._data = np.full((min(steps, INITIAL_ROWS), _COLUMNS, len(self.ids)), np.nan)
        self._dt = dt
        self.ages: dict[tuple[int, int], list[float]] = {}  # (sender, receiver) -> [sum, count, max]

    def _grow(self, k: int) -> None:
        """Room for row k (k < steps): at least double, at most the run's steps."""
        rows = min(self._steps, max(k + 1, 2 * len(self._data)))
        grown = np.full((rows, *self._data.shape[1:]), np.nan)
        grown[: len(self._data)] = self._data
        self._data = grown

    def add(self, state: StateReport) -> None:
        """Take in one state report of a vehicle of the fleet."""
        k, col = state.k, self._column[state.vehicle]
        if 0 <= k < self._steps:
            if k >= len(self._data):
                self._grow(k)
            row = (state.gamma, state.gamma_dot, _magnitude(state.error), *_inputs(state.tau), state.velocity[0])
            self._data[k, :, col] = row
        for held in state.estimate_age:
            book = self.ages.setdefault((held.vehicle, state.vehicle), [0.0, 0.0, 0.0])
            age = held.age
            book[0] += age
            book[1] += 1
            book[2] = max(book[2], age)

    def series(self) -> Series:
        """Every step of the run, NaN rows for steps no state reached."""
        d = np.full((self._steps, *self._data.shape[1:]), np.nan)
        d[: len(self._data)] = self._data
        times = np.arange(self._steps, dtype=np.float64) * self._dt
        return Series(self.ids, times, d[:, 0].copy(), d[:, 1].copy(), d[:, 2].copy(), d[:, 3:6].copy(), d[:, 6].copy())


def _inputs(tau: Sequence[float]) -> tuple[float, float, float]:
    """(surge, pitch, yaw) from a state's inputs: three, or a planar vehicle's two (surge, yaw); NaN for what a
    state of another shape leaves out."""
    if len(tau) == 2:
        return tau[0], math.nan, tau[1]
    u, q, r = (*tau[:3], math.nan, math.nan, math.nan)[:3]
    return u, q, r


def _magnitude(error: tuple[float, float, float]) -> float:
    """|error| as the report's data takes it from the log (numerics.linalg: the same bits on every CPU; numpy's
    vector norm was BLAS's dot, CPU-dependent in its last bit and ~1.8 us a call against 0.13 us), or math.hypot
    where its squares would overflow (a state's error is a diagnostic that need only be a number; 1e300 made a
    RuntimeWarning and inf)."""
    x, y, z = error
    if max(abs(x), abs(y), abs(z)) < 1e150:
        return norm3(x, y, z)
    return math.hypot(x, y, z)
