"""What a vehicle's RK4 step passes between its parts (vehicles.agent's begin, rk4 and finish), whether one vehicle
steps (vehicles.agent.step) or many together as lanes (vehicles.lanes)."""

from __future__ import annotations

from typing import NamedTuple

from vehicles.geometry import Float3
from vehicles.path_following import ControlOutput


class Begun(NamedTuple):
    """A step's start: z (see _GAMMA), an adaptive controller's memory, the current observer's state."""

    z: list[float]
    memory: object
    observer: tuple[float, ...]


class Stepped(NamedTuple):
    """What finish needs of the RK4 step: z after it, its four stages (z, the controller's outputs, the inputs the
    vehicle got), and at its start v_tilde, the error the controller saw, its Lyapunov value and the inputs."""

    z: list[float]
    stages: list[tuple[list[float], ControlOutput, Float3]]
    v_tilde: float
    seen_error: Float3
    lyapunov: float
    applied: Float3
