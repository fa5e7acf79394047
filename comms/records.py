"""The records comms carries between vehicles, the channel and the supervisor, as plain frozen dataclasses.

They are the protocol's vocabulary: vehicles build and consume them, the channel and broker move them, the log keeps
their wire form (comms.messages). Nothing here knows how a vehicle works, so comms depends on no vehicle code.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Transmission:
    """A coordination message as it leaves a vehicle: its data and, for the channel emulator only, its kinematics."""

    sender: int
    seq: int
    t: float  # transmission time (true simulation time), s
    gamma: float
    gamma_dot: float
    position: tuple[float, float, float]  # inertial, m
    velocity: tuple[float, float, float]  # inertial, m/s
    stamp: float | None = None  # the time the message claims for its data; None: t (a skewed clock differs)

    @property
    def data_time(self) -> float:
        return self.t if self.stamp is None else self.stamp


@dataclass(frozen=True, slots=True)
class Heard:
    """A reception as the vehicle sees it: who, the data and the time of the data."""

    sender: int
    stamp: float
    gamma: float
    gamma_dot: float


@dataclass(frozen=True, slots=True)
class Disturbances:
    """What faults do to a vehicle during a step (the tick carries them). gamma_dot_cap: the paper's unannounced
    slowdown; the others corrupt what it broadcasts: a frozen gamma sensor, a gamma offset, a skewed clock (s)."""

    gamma_dot_cap: float | None = None
    gamma_freeze: bool = False
    gamma_offset: float = 0.0
    clock_offset: float = 0.0
