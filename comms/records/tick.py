"""The supervisor's clock tick: the record, its wire form and its checked reading, side by side.

`Tick.to_message` gives the dict on cpf/clock/tick (schema comms.records.schemas.TICK); `from_message` is its inverse,
checked (ValueError for anything malformed). What says nothing is left out of the message rather than null (viewers
read no nulls): no network (the scenario's graph), no alive list (every vehicle), no wall time (lockstep), no cap;
older logs' nulls read the same. Ticks in logs from before realtime delivery lack wall, speed and hold: they read as
lockstep (None, 1.0, False), and write back with speed and hold spelt out.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from comms.records.fields import Message, get, is_int, number
from comms.records.network import Network
from comms.records.records import Disturbances


@dataclass(frozen=True, slots=True)
class DisturbedVehicle:
    """One entry of a tick's `vehicles`: what faults do to one vehicle over the step
    (comms.records.records.Disturbances)."""

    vehicle: int
    cap: float | None  # gamma_dot_cap
    freeze: bool  # gamma_freeze
    offset: float  # gamma_offset
    skew: float  # clock_offset, s

    @classmethod
    def of(cls, vehicle: int, d: Disturbances) -> DisturbedVehicle:
        return cls(vehicle, d.gamma_dot_cap, d.gamma_freeze, d.gamma_offset, d.clock_offset)

    @property
    def disturbances(self) -> Disturbances:
        return Disturbances(self.cap, self.freeze, self.offset, self.skew)

    def to_message(self) -> Message:
        cap = {} if self.cap is None else {"cap": self.cap}  # no cap: left out (older logs have null)
        return {"vehicle": self.vehicle, **cap, "freeze": self.freeze, "offset": self.offset, "skew": self.skew}

    @classmethod
    def from_message(cls, item: object) -> DisturbedVehicle:
        if not isinstance(item, dict):
            raise ValueError("a vehicle entry is not a map")
        cap = None if item.get("cap") is None else number(item, "cap")
        return cls(get(item, "vehicle", int), cap, get(item, "freeze", bool), number(item, "offset"),
                   number(item, "skew"))  # fmt: skip


@dataclass(frozen=True, slots=True)
class Tick:
    """Step k starts at t. With it, what acts over the step: faults on vehicles (only those with any), the network
    (graph and link faults), the vehicles alive, whether the broker is up. Realtime runs also say when t is on the
    wall clock (time.time()) and how fast simulation time runs: wall + (t' - t) / speed. hold: a process is killed
    or restarted at the next tick, so this step's transmissions wait for it (realtime brokers otherwise send them
    before the next tick, which alone says who survived the step). until (lockstep): the tick grants the time
    window k .. until-1, over which all of this holds and nothing crosses the bus (supervisor.engine.windows).
    span (lockstep, on the bus only): the tick grants the broker steps k .. span-1, over which all of this holds
    (nothing external changes): the broker issues their ticks itself, in time windows it works out from the
    vehicles' reports (comms.broker.span), and hold then says the span's last step holds its packets."""

    WIRE_NAMES: ClassVar[dict[str, str]] = {"disturbed": "vehicles"}  # field -> its name in the message

    k: int
    t: float
    final: bool
    disturbed: dict[int, Disturbances]
    network: Network | None  # None: the scenario's graph, no link faults
    alive: list[int] | None  # None: every vehicle
    comms: bool
    wall: float | None = None  # realtime: the wall-clock time (time.time()) of t; None: lockstep
    speed: float = 1.0  # realtime: simulated seconds per wall-clock second
    hold: bool = False  # a process is killed or restarted at the next tick: this step's packets wait for it
    until: int | None = None  # lockstep time window: steps k .. until-1 run on this tick; None: step k alone
    span: int | None = None  # lockstep: the broker issues the ticks of steps k .. span-1 itself (comms.broker.span)
    longest: int | None = None  # with span: the broker's time windows of at most this many steps

    @property
    def end(self) -> int:
        """The first step after the window this tick grants (k + 1 for a tick of one step)."""
        return self.k + 1 if self.until is None else self.until

    @property
    def reach(self) -> int:
        """The first step after every step this tick covers: its span's end, else its window's."""
        return self.end if self.span is None else self.span

    def wall_of(self, t: float) -> float:
        """The wall-clock time of simulation time t (realtime runs only)."""
        assert self.wall is not None
        return self.wall + (t - self.t) / self.speed

    def to_message(self) -> Message:
        return {
            "t": self.t,
            "k": self.k,
            "final": self.final,
            "vehicles": [DisturbedVehicle.of(vid, d).to_message() for vid, d in sorted(self.disturbed.items())],
            **({} if self.network is None else {"network": self.network.to_message()}),
            **({} if self.alive is None else {"alive": self.alive}),
            "comms": self.comms,
            **({} if self.wall is None else {"wall": self.wall}),
            "speed": self.speed,
            "hold": self.hold,
            **({} if self.until is None else {"until": self.until}),  # the log keeps one tick per step, without it
            **({} if self.span is None else {"span": self.span}),  # on the bus only
            **({} if self.longest is None else {"longest": self.longest}),
        }

    @classmethod
    def from_message(cls, message: Message) -> Tick:
        entries = [DisturbedVehicle.from_message(item) for item in get(message, "vehicles", list)]
        net = message.get("network")  # absent (null in older logs): the scenario's graph
        alive = message.get("alive")  # absent (null in older logs): every vehicle
        if alive is not None and not (isinstance(alive, list) and all(is_int(v) for v in alive)):
            raise ValueError("field 'alive' is not a list of vehicle ids")
        hold = get(message, "hold", bool) if "hold" in message else False
        k = get(message, "k", int)
        until = get(message, "until", int) if message.get("until") is not None else None
        if until is not None and until <= k:
            raise ValueError(f"field 'until' is not after step {k}, got {until}")
        span = get(message, "span", int) if message.get("span") is not None else None
        if span is not None and span <= k:
            raise ValueError(f"field 'span' is not after step {k}, got {span}")
        longest = get(message, "longest", int) if message.get("longest") is not None else None
        if longest is not None and longest < 1:
            raise ValueError(f"field 'longest' is not a positive number of steps, got {longest}")
        return cls(
            k, number(message, "t"), get(message, "final", bool),
            {e.vehicle: e.disturbances for e in entries}, None if net is None else Network.from_message(net), alive,
            get(message, "comms", bool), *_realtime(message), hold, until, span, longest,
        )  # fmt: skip


def _realtime(message: Message) -> tuple[float | None, float]:
    """(wall, speed) of a tick; absent in lockstep ticks and in logs older than realtime delivery."""
    wall = None if message.get("wall") is None else number(message, "wall")
    speed = number(message, "speed") if "speed" in message else 1.0
    if speed <= 0.0:
        raise ValueError("field 'speed' is not positive")
    return wall, speed
