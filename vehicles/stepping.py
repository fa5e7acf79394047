"""What a vehicle's RK4 step passes between its parts (vehicles.agent's begin, rk4 and finish), whether one vehicle
steps (vehicles.agent.step) or many together as lanes (vehicles.lanes)."""

from __future__ import annotations

from typing import NamedTuple

from vehicles.geometry import Float3


class Begun(NamedTuple):
    """A step's start: z (see _GAMMA), an adaptive controller's memory, the current observer's state."""

    z: list[float]
    memory: object
    observer: tuple[float, ...]


class Stepped(NamedTuple):
    """What finish needs of the RK4 step: z after it, an adaptive controller's memory after it (learned from the
    step's four stages), and at its start v_tilde, the error the controller saw, its Lyapunov value and the inputs."""

    z: list[float]
    memory: object
    v_tilde: float
    seen_error: Float3
    lyapunov: float
    applied: Float3
