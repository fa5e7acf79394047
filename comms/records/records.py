"""The records comms carries between vehicles, the channel and the supervisor, as plain frozen dataclasses.

They are the protocol's vocabulary: vehicles build and consume them, the channel and broker move them, the log keeps
their wire form (a record's to_message / from_message where it has one,
comms.records.messages otherwise). Nothing here knows how a vehicle works, so comms depends on no vehicle code.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal, get_args

import msgspec
import numpy as np
from numpy.typing import NDArray

from comms.records.fields import (
    MAX_FLOAT32,
    MAX_TIME,
    Finite,
    Finite3,
    Message,
    as_message,
    carried,
    converted,
    get,
    read_as,
    slow_enough,
    vector3,
    velocity,
)

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

    def to_message(self) -> Message:
        """The wire form on a vehicle's tx key (schema comms.records.schemas.TRANSMISSION); stamp is always written."""
        return {
            "t": self.t,
            "stamp": self.data_time,
            "sender": self.sender,
            "seq": self.seq,
            "gamma": self.gamma,
            "gamma_dot": self.gamma_dot,
            "position": list(self.position),
            "velocity": list(self.velocity),
        }

    @classmethod
    def from_message(cls, message: Message, key_vehicle: int) -> Transmission:
        """The inverse of to_message, checked: the sender must own the key it came on, and the modem frame must be
        able to carry it. ValueError for anything malformed."""
        wire = converted(message, _TransmissionWire)
        if wire is None:
            return cls.checked(message, key_vehicle)
        if wire.sender != key_vehicle:
            raise ValueError(f"sender {wire.sender} published on vehicle {key_vehicle}'s key")
        stamp = None if isinstance(wire.stamp, msgspec.UnsetType) or wire.stamp == wire.t else wire.stamp
        velocity = slow_enough("velocity", wire.velocity)
        return cls(wire.sender, wire.seq, wire.t, wire.gamma, wire.gamma_dot, wire.position, velocity, stamp)

    @classmethod
    def checked(cls, message: Message, key_vehicle: int) -> Transmission:
        """from_message by hand-written checks, field by field: what says why a message is malformed."""
        sender = get(message, "sender", int)
        if sender != key_vehicle:
            raise ValueError(f"sender {sender} published on vehicle {key_vehicle}'s key")
        seq = get(message, "seq", int)
        if seq < 0:
            raise ValueError("field 'seq' is negative")
        t = carried(message, "t", 0.0, MAX_TIME)
        stamp = carried(message, "stamp", 0.0, MAX_TIME) if "stamp" in message else t
        return cls(
            sender, seq, t, carried(message, "gamma", -MAX_FLOAT32, MAX_FLOAT32),
            carried(message, "gamma_dot", -MAX_FLOAT32, MAX_FLOAT32), vector3(message, "position"),
            velocity(message, "velocity"), None if stamp == t else stamp,
        )  # fmt: skip


Time = Annotated[float, msgspec.Meta(ge=0.0, le=MAX_TIME)]  # what the modem frame carries (comms.records.wire)
Float32 = Annotated[float, msgspec.Meta(ge=-MAX_FLOAT32, le=MAX_FLOAT32)]


class _TransmissionWire(msgspec.Struct, frozen=True):
    """A transmission as its message has it (stamp always written, but old messages may lack it; null is refused),
    with the checks of Transmission.checked as msgspec types (comms.records.fields.converted)."""

    sender: int
    seq: Annotated[int, msgspec.Meta(ge=0)]
    t: Time
    gamma: Float32
    gamma_dot: Float32
    position: Finite3
    velocity: Finite3
    stamp: Time | msgspec.UnsetType = msgspec.UNSET


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


EventKind = Literal["sent", "delivered", "dropped"]
EVENT_KINDS: tuple[EventKind, ...] = get_args(EventKind)


@dataclass(frozen=True, slots=True)
class Kinematics:
    """What the channel knows of a vehicle at transmission time: inertial position and velocity."""

    position: FloatArray
    velocity: FloatArray


@dataclass(frozen=True, slots=True)
class Reception:
    receiver: int
    sender: int
    seq: int
    stamp: float  # time of the data, as the packet carries it
    arrival: float
    gamma: float
    gamma_dot: float


class LinkEvent(msgspec.Struct, frozen=True, omit_defaults=True):
    """A packet's fate on one link: the message's only description (a cpf/comms/event log record, an item of a
    cpf/comms/events batch; its schema comms.records.schemas.LINK_EVENT is generated from it). delay and reason are left
    out of the message where they say nothing (older logs have them null)."""

    t: Finite
    sender: int
    receiver: int
    seq: int
    kind: EventKind
    delay: Finite | None = None  # delivered: arrival - transmission time
    reason: str | None = None  # dropped: why

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object) -> LinkEvent:
        """The inverse of to_message, checked: ValueError naming the field for anything malformed."""
        return read_as(message, cls)
