"""A vehicle's state report of one sync step: one msgspec Struct, the message's only description.

From it come the message on the vehicle's state key (msgpack on the bus), the log's JSON (`to_message`, written by
the recorder: an optional field is left out when absent, never null), the JSON Schema of the log's channel
(comms.records.schemas, generated from this struct) and the checks: msgspec checks every type as it reads
(`from_message`, or its decoders of the bus: comms.records.bus_records), and `check` adds what a type cannot say (the
vehicle owns its key, a rotation, a speed). What the broker needs (position, attitude, velocity, which step, whether it
transmitted) must be finite and physical; the diagnostics (gamma, errors, forces, Lyapunov value) need only be numbers.
Keys a step message adds around the state (tx, rx) are not the state's and are ignored.

Adding a field is one line here (optional, `= None`, if older logs lack it) and a test.
"""

from __future__ import annotations

import math
from typing import Annotated

import msgspec

from comms.records.bounded import dropped
from comms.records.fields import (
    Finite,
    Finite3,
    Message,
    Real,
    Real3,
    as_message,
    orthonormal,
    read_as_or_older,
    slow_enough,
)
from comms.records.records import Kinematics
from comms.records.stream import NOT_FINITE

Float3 = tuple[float, float, float]
Rotation = Annotated[tuple[Finite, ...], msgspec.Meta(min_length=9, max_length=9)]  # R row-major


class NeighbourAge(msgspec.Struct, frozen=True):
    """How old the estimate a vehicle holds of one neighbour is (an object in the message, so that viewers can plot
    it)."""

    vehicle: int
    age: Real  # s: t minus the time stamp of the data held


# What the wall clock did to a realtime run, measured on the way: no pure function of the vehicle's inputs gives it, so
# a re-simulation (supervisor.engine.resim) compares everything else.
WALL_CLOCK_FIELDS = ("rx_lateness", "step_lateness")


class StateReport(msgspec.Struct, frozen=True, omit_defaults=True):
    """What a vehicle says about itself at step k. position, rotation (R row-major, body to inertial) and velocity
    (body frame) place it in 3-D (a planar vehicle is embedded); tx_seq: its transmission of step k, or 0."""

    t: Finite  # s
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
    estimate_age: tuple[NeighbourAge, ...]  # of each neighbour's estimate held
    rx_lateness: tuple[Real, ...] | None = None  # realtime: s (wall clock) from each reception's arrival to its coming
    step_lateness: Finite | None = None  # realtime: s (wall clock) from t_k to the vehicle's starting its step
    # With navigation on ([navigation]), the navigation filter at t_k after its measurements: estimate [p_hat (3),
    # DVL bias (3)], then its covariance's upper triangle by rows (21); absent without navigation.
    nav_estimate: tuple[Real, ...] | None = None
    nav_fix: int | None = None  # 0: no position fix due, 1: a fix fused, 2: a fix due but lost
    # With a current observer (vehicles.current_observer), the current it estimates, inertial, m/s; absent without.
    current_estimate: Real3 | None = None
    # While a frozen_gamma fault holds its gamma sensor, the reading it stuck at, (gamma, gamma_dot): what it
    # broadcasts; a restarted process takes it up from here (the sensor's, not the process's). Absent otherwise.
    frozen: tuple[Real, Real] | None = None

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
        # In floats, not arrays: every vehicle's at every step, and the channel reads them as floats.
        inertial = (r[0] * u + r[1] * v + r[2] * w, r[3] * u + r[4] * v + r[5] * w, r[6] * u + r[7] * v + r[8] * w)
        return Kinematics(self.position, inertial)

    def to_message(self) -> Message:
        """The message: the struct's fields as JSON types (lists, where msgspec.to_builtins keeps tuples), in order,
        the absent optional ones left out."""
        return as_message(self)

    @classmethod
    def from_message(cls, message: object, key_vehicle: int) -> StateReport:
        """The report, checked; its vehicle must own the key it came on. ValueError for anything malformed, naming
        the field (msgspec's message: "Expected `float`, got `str` - at `$.gamma`")."""
        return read_as_or_older(message, cls, _from_older_log).check(key_vehicle)

    def check(self, key_vehicle: int) -> StateReport:
        """What the types cannot say: the vehicle owns the key (ValueError otherwise), R is a rotation, the velocity
        one no vehicle exceeds."""
        if self.vehicle != key_vehicle:
            raise ValueError(f"vehicle {self.vehicle} published on vehicle {key_vehicle}'s key")
        orthonormal(self.rotation)
        slow_enough("velocity", self.velocity)
        self._finite()
        return self

    def _finite(self) -> None:
        """ValueError (dropped: not finite) for a NaN or an infinity in a diagnostic (the fields typed Finite refuse
        them as they are read): a value the log could only write as null, and no neighbour or figure could use."""
        for name in ("gamma", "gamma_dot", "correction", "lyapunov", "step_lateness"):
            value = getattr(self, name)
            if value is not None and not math.isfinite(value):
                raise dropped(NOT_FINITE, f"field {name!r} is {value}")
        for name in ("error", "tau", "rx_lateness", "nav_estimate", "current_estimate"):
            values = getattr(self, name)
            if values is not None and not all(map(math.isfinite, values)):
                raise dropped(NOT_FINITE, f"field {name!r} holds a NaN or an infinity")
        if not all(math.isfinite(held.age) for held in self.estimate_age):
            raise dropped(NOT_FINITE, "field 'estimate_age' holds a NaN or an infinity")


def _from_older_log(message: object) -> Message | None:
    """A state of a log written before estimate ages were objects ([vehicle, age] pairs), in today's form; None for
    anything else."""
    ages = message.get("estimate_age") if isinstance(message, dict) else None
    if not (isinstance(ages, list) and ages and all(isinstance(a, list) and len(a) == 2 for a in ages)):
        return None
    assert isinstance(message, dict)
    return {**message, "estimate_age": [{"vehicle": a[0], "age": a[1]} for a in ages]}
