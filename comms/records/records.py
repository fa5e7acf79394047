"""The records comms carries between vehicles, the channel and the supervisor.

They are the protocol's vocabulary: vehicles build and consume them, the channel and broker move them. Those that
travel as messages (Transmission, LinkEvent) are msgspec Structs, each its message's only description (to_message,
from_message, the schema generated from it); the rest (Heard, Reception, Kinematics, ...) never leave a process.
Nothing here knows how a vehicle works, so comms depends on no vehicle code.
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
    read_as,
    slow_enough,
)

FloatArray = NDArray[np.float64]


Time = Annotated[float, msgspec.Meta(ge=0.0, le=MAX_TIME)]  # what the modem frame carries (comms.records.wire)
Float32 = Annotated[float, msgspec.Meta(ge=-MAX_FLOAT32, le=MAX_FLOAT32)]


class Transmission(msgspec.Struct, frozen=True):
    """A coordination message as it leaves a vehicle: its data and, for the channel emulator only, its kinematics.
    The message's only description (on a vehicle's tx key; its schema comms.records.schemas.TRANSMISSION is generated
    from it): what the modem frame cannot carry is refused as it is read. stamp: the time the message claims for its
    data, t unless the sender's clock is skewed; always written, t where a message (of an older sender) lacks it (a
    copy with another t, msgspec.structs.replace, keeps the stamp: give both)."""

    sender: int
    seq: Annotated[int, msgspec.Meta(ge=0)]
    t: Time  # transmission time (true simulation time), s
    gamma: Float32
    gamma_dot: Float32
    position: Finite3  # inertial, m
    velocity: Finite3  # inertial, m/s
    stamp: Time | msgspec.UnsetType = msgspec.UNSET  # null is refused

    def __post_init__(self) -> None:
        if isinstance(self.stamp, msgspec.UnsetType):
            msgspec.structs.force_setattr(self, "stamp", self.t)

    @property
    def data_time(self) -> float:
        return self.t if isinstance(self.stamp, msgspec.UnsetType) else self.stamp

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object, key_vehicle: int) -> Transmission:
        """The inverse of to_message, checked: ValueError naming the field for anything malformed."""
        return read_as(message, cls).check(key_vehicle)

    def check(self, key_vehicle: int) -> Transmission:
        """What the types cannot say: the sender owns the key it came on, its velocity is one no vehicle exceeds."""
        if self.sender != key_vehicle:
            raise ValueError(f"field 'sender': sender {self.sender} published on vehicle {key_vehicle}'s key")
        slow_enough("velocity", self.velocity)
        return self


class Heard(msgspec.Struct, frozen=True):
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


class Kinematics(msgspec.Struct, frozen=True):
    """What the channel knows of a vehicle at transmission time: inertial position and velocity (arrays, or three
    floats as the engines give them: the channel reads them as floats)."""

    position: FloatArray | tuple[float, float, float]
    velocity: FloatArray | tuple[float, float, float]


class Reception(msgspec.Struct, frozen=True):
    receiver: int
    sender: int
    seq: int
    stamp: float  # time of the data, as the packet carries it
    arrival: float
    gamma: float
    gamma_dot: float


class LinkEvent(msgspec.Struct, frozen=True, omit_defaults=True):
    """A packet's fate on one link: the message's only description (an item of a cpf/comms/events batch, or an
    older log's cpf/comms/event record; its schema comms.records.schemas.LINK_EVENT is generated from it). delay and
    reason are left out of the message where they say nothing (older logs have them null)."""

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
