"""A vehicle's state report of one sync step: the record, its wire form and its checked reading, side by side.

`to_message` gives the dict that travels on the vehicle's state key (msgpack on the bus, JSON in the log, schema
comms.schemas.STATE); `from_message` is its inverse, checked: what the broker needs (position, attitude, velocity,
which step, whether it transmitted) must be finite and physical, the diagnostics (gamma, errors, forces, Lyapunov
value) need only be numbers. Keys a step message adds around the state (tx, rx) are not the state's and are ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Any

import msgspec
import numpy as np

from comms.channel import Kinematics
from comms.fields import (
    Finite,
    Finite3,
    Message,
    Real,
    Real3,
    converted,
    get,
    is_int,
    number,
    orthonormal,
    rotation,
    slow_enough,
    vector3,
    velocity,
)

Float3 = tuple[float, float, float]
Rotation = Annotated[tuple[Finite, ...], msgspec.Meta(min_length=9, max_length=9)]  # R row-major


@dataclass(frozen=True, slots=True)
class StateReport:
    """What a vehicle says about itself at step k. position, rotation (R row-major, body to inertial) and velocity
    (body frame) place it in 3-D (a planar vehicle is embedded); tx_seq: its transmission of step k, or 0."""

    # The annotations are the checks msgspec does (comms.fields.converted); the rest are in from_message.
    t: Finite
    k: int
    vehicle: int
    gamma: Real
    gamma_dot: Real
    position: Finite3  # inertial, m
    rotation: Rotation  # 9 numbers
    velocity: Finite3  # body frame, m/s
    angular_velocity: Finite3  # body frame, rad/s
    error: Real3  # p - p_d(gamma), m (zero-padded for planar vehicles)
    tau: tuple[Real, ...]  # the inputs the vehicle got: the controller's, through its actuators if not ideal
    correction: Real  # v_tilde
    lyapunov: Real
    tx_seq: int
    estimate_age: tuple[tuple[int, Real], ...]  # (neighbour, how old the estimate held of it is, s)
    rx_lateness: tuple[Real, ...] | None = None  # realtime: s from each reception's arrival to its coming
    step_lateness: Finite | None = None  # realtime: s from t_k to the vehicle's starting its step
    # With navigation on ([navigation]), the navigation filter at t_k after its measurements: estimate [p_hat (3),
    # DVL bias (3)], then its covariance's upper triangle by rows (21); absent without navigation.
    nav_estimate: tuple[Real, ...] | None = None
    nav_fix: int | None = None  # 0: no position fix due, 1: a fix fused, 2: a fix due but lost
    # With a current observer (vehicles.current_observer), the current it estimates, inertial, m/s; absent without.
    current_estimate: Real3 | None = None

    @property
    def estimated_position(self) -> Float3 | None:
        """The position the controller believed, inertial, m (None: it knew the truth)."""
        e = self.nav_estimate
        return None if e is None else (e[0], e[1], e[2])

    @property
    def position_sigma(self) -> Float3 | None:
        """The filter's standard deviation of each position component, m (None without navigation)."""
        e = self.nav_estimate
        # The diagonal's first three entries in the upper triangle by rows of a 6 x 6 matrix: 0, 6, 11 after x.
        return None if e is None else (math.sqrt(e[6]), math.sqrt(e[12]), math.sqrt(e[17]))

    @property
    def kinematics(self) -> Kinematics:
        """Inertial position and velocity (R v): what the channel needs of the vehicle."""
        r, (u, v, w) = self.rotation, self.velocity
        inertial = np.array([r[i] * u + r[i + 1] * v + r[i + 2] * w for i in (0, 3, 6)])
        return Kinematics(np.array(self.position), inertial)

    def to_message(self) -> Message:
        message: Message = {
            "t": self.t,
            "k": self.k,
            "vehicle": self.vehicle,
            "gamma": self.gamma,
            "gamma_dot": self.gamma_dot,
            "position": list(self.position),
            "rotation": list(self.rotation),
            "velocity": list(self.velocity),
            "angular_velocity": list(self.angular_velocity),
            "error": list(self.error),
            "tau": list(self.tau),
            "correction": self.correction,
            "lyapunov": self.lyapunov,
            "tx_seq": self.tx_seq,
            "estimate_age": [[j, age] for j, age in self.estimate_age],
        }
        if self.rx_lateness is not None:
            message["rx_lateness"] = list(self.rx_lateness)
        if self.step_lateness is not None:
            message["step_lateness"] = self.step_lateness
        if self.nav_estimate is not None:
            message["nav_estimate"] = list(self.nav_estimate)
            message["nav_fix"] = self.nav_fix
        if self.current_estimate is not None:
            message["current_estimate"] = list(self.current_estimate)
        return message

    @classmethod
    def from_message(cls, message: Message, key_vehicle: int) -> StateReport:
        """The report, checked; its vehicle must own the key it came on. ValueError for anything malformed."""
        report = converted(message, cls)
        if report is None:
            return cls.checked(message, key_vehicle)
        if report.vehicle != key_vehicle:
            raise ValueError(f"vehicle {report.vehicle} published on vehicle {key_vehicle}'s key")
        orthonormal(report.rotation)
        slow_enough("velocity", report.velocity)
        return report

    @classmethod
    def checked(cls, message: Message, key_vehicle: int) -> StateReport:
        """from_message by hand-written checks, field by field: what says why a message is malformed."""
        vehicle = get(message, "vehicle", int)
        if vehicle != key_vehicle:
            raise ValueError(f"vehicle {vehicle} published on vehicle {key_vehicle}'s key")
        return cls(
            number(message, "t"), get(message, "k", int), vehicle, _real(message, "gamma"),
            _real(message, "gamma_dot"), vector3(message, "position"), tuple(rotation(message)),
            velocity(message, "velocity"), vector3(message, "angular_velocity"), _reals3(message, "error"),
            tuple(_reals(message, "tau")), _real(message, "correction"), _real(message, "lyapunov"),
            get(message, "tx_seq", int), _ages(message),
            None if message.get("rx_lateness") is None else tuple(_reals(message, "rx_lateness")),
            None if message.get("step_lateness") is None else number(message, "step_lateness"),
            None if message.get("nav_estimate") is None else tuple(_reals(message, "nav_estimate")),
            None if message.get("nav_fix") is None else get(message, "nav_fix", int),
            None if message.get("current_estimate") is None else _reals3(message, "current_estimate"),
        )  # fmt: skip


def _is_real(value: object) -> bool:
    """A float (finite or not) or an integer a float holds (no reader has to handle one beyond)."""
    if isinstance(value, float):
        return True
    return isinstance(value, int) and not isinstance(value, bool) and abs(value) <= _MAX_INT


_MAX_INT = 2**63  # the widest integer a log's JSON keeps


def _real(message: Message, name: str) -> float:
    """A number, finite or not: a diagnostic the broker does not compute with."""
    value: float = get(message, name, (int, float))
    if not _is_real(value):
        raise ValueError(f"field {name!r} is too large")
    return value


def _reals(message: Message, name: str) -> list[Any]:
    values = get(message, name, list)
    if not all(_is_real(v) for v in values):
        raise ValueError(f"field {name!r} is not a list of numbers")
    return values


def _reals3(message: Message, name: str) -> Float3:
    values = _reals(message, name)
    if len(values) != 3:
        raise ValueError(f"field {name!r} has {len(values)} items, not 3")
    return values[0], values[1], values[2]


def _ages(message: Message) -> tuple[tuple[int, float], ...]:
    pairs = get(message, "estimate_age", list)
    if not all(isinstance(p, list) and len(p) == 2 and is_int(p[0]) and _is_real(p[1]) for p in pairs):
        raise ValueError("field 'estimate_age' is not a list of [vehicle id, age] pairs")
    return tuple((j, age) for j, age in pairs)
