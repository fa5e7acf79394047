"""Collects the state messages of a run into the arrays the summary needs, whichever engine produced them."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from comms.messages import Message
from supervisor.analysis.summary import Series


class SeriesBuilder:
    def __init__(self, vehicle_ids: Sequence[int], steps: int, dt: float) -> None:
        self.ids = tuple(vehicle_ids)
        self._column = {vid: col for col, vid in enumerate(self.ids)}
        self._data = np.full((steps, 3, len(self.ids)), np.nan)  # gamma, gamma_dot, |p - p_d|
        self._dt = dt
        self.ages: dict[tuple[int, int], list[float]] = {}  # (sender, receiver) -> [sum, count, max]

    def add(self, state: Message) -> None:
        """Take in one state message (already validated by whoever received it)."""
        k, col = state["k"], self._column[state["vehicle"]]
        if 0 <= k < len(self._data):
            error = state["error"]
            self._data[k, :, col] = (state["gamma"], state["gamma_dot"], float(np.linalg.norm(error)))
        for sender, age in state.get("estimate_age", []):
            book = self.ages.setdefault((sender, state["vehicle"]), [0.0, 0.0, 0.0])
            book[0] += age
            book[1] += 1
            book[2] = max(book[2], age)

    def series(self) -> Series:
        times = np.arange(len(self._data), dtype=np.float64) * self._dt
        d = self._data
        return Series(self.ids, times, d[:, 0].copy(), d[:, 1].copy(), d[:, 2].copy())
