"""The supervisor's clock tick (cpf/clock/tick): one msgspec Struct, the message's only description.

From it come the message (`to_message`), its checked reading (`from_message`: msgspec's types, then `check` for what
a type cannot say; ValueError naming the field for anything malformed) and its JSON Schema (comms.records.schemas,
generated). What says nothing is left out of the message rather than null (viewers read no nulls): no network (the
scenario's graph), no alive list (every vehicle), no wall time (lockstep), no cap; older logs' nulls read the same.
Ticks in logs from before realtime delivery lack speed and hold: they read as lockstep (1.0, False), and write back
with speed and hold spelt out.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from typing import Annotated

import msgspec

from comms.records.fields import Finite, Message, as_message, read_as, read_as_or_older
from comms.records.network import Network
from comms.records.network import from_older_log as older_network
from comms.records.records import Disturbances

Positive = Annotated[float, msgspec.Meta(gt=0.0, le=sys.float_info.max)]


class DisturbedVehicle(msgspec.Struct, frozen=True, kw_only=True, omit_defaults=True):
    """One entry of a tick's `vehicles`: what faults do to one vehicle over the step
    (comms.records.records.Disturbances)."""

    vehicle: int
    cap: Finite | None = None  # gamma_dot_cap; none: left out (older logs have null)
    freeze: bool  # gamma_freeze
    offset: Finite  # gamma_offset
    skew: Finite  # clock_offset, s

    @classmethod
    def of(cls, vehicle: int, d: Disturbances) -> DisturbedVehicle:
        return cls(vehicle=vehicle, cap=d.gamma_dot_cap, freeze=d.gamma_freeze, offset=d.gamma_offset,
                   skew=d.clock_offset)  # fmt: skip

    @property
    def disturbances(self) -> Disturbances:
        return Disturbances(self.cap, self.freeze, self.offset, self.skew)

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, item: object) -> DisturbedVehicle:
        return read_as(item, cls)


class Tick(msgspec.Struct, frozen=True, kw_only=True, omit_defaults=True):
    """Step k starts at t. With it, what acts over the step: faults on vehicles (only those with any), the network
    (graph and link faults), the vehicles alive, whether the broker is up. Realtime runs also say when t is on the
    wall clock (time.time()) and how fast simulation time runs: wall + (t' - t) / speed. hold: a process is killed
    or restarted at the next tick, so this step's transmissions wait for it (realtime brokers otherwise send them
    before the next tick, which alone says who survived the step). until (lockstep): the tick grants the time
    window k .. until-1, over which all of this holds and nothing crosses the bus (supervisor.engine.windows).
    span (lockstep, on the bus only): the tick grants the broker steps k .. span-1, over which all of this holds
    (nothing external changes): the broker issues their ticks itself, in time windows it works out from the
    vehicles' reports (comms.broker.span), and hold then says the span's last step holds its packets. Built with
    `of`."""

    t: Finite
    k: int
    final: bool
    vehicles: tuple[DisturbedVehicle, ...]  # only vehicles with any fault acting, by id
    network: Network | None = None  # None: the scenario's graph, no link faults
    alive: tuple[int, ...] | None = None  # None: every vehicle
    comms: bool
    wall: Finite | None = None  # realtime: the wall-clock time (time.time()) of t; None: lockstep
    speed: Positive  # realtime: simulated seconds per wall-clock second (1.0 in lockstep)
    hold: bool  # a process is killed or restarted at the next tick: this step's packets wait for it
    until: int | None = None  # lockstep time window: steps k .. until-1 run on this tick; None: step k alone
    span: int | None = None  # on the bus only: the broker issues the ticks of steps k .. span-1 itself
    longest: Annotated[int, msgspec.Meta(ge=1)] | None = None  # with span: the broker's windows of at most this

    @classmethod
    def of(
        cls, k: int, t: float, final: bool, disturbed: Mapping[int, Disturbances] | None = None,
        network: Network | None = None, alive: list[int] | tuple[int, ...] | None = None, comms: bool = True,
        wall: float | None = None, speed: float = 1.0, hold: bool = False, until: int | None = None,
        span: int | None = None, longest: int | None = None,
    ) -> Tick:  # fmt: skip
        """disturbed: vehicle -> what faults do to it (only the vehicles with any fault acting)."""
        vehicles = tuple(DisturbedVehicle.of(v, d) for v, d in sorted((disturbed or {}).items()))
        return cls(t=t, k=k, final=final, vehicles=vehicles, network=network,
                   alive=None if alive is None else tuple(alive), comms=comms, wall=wall, speed=speed, hold=hold,
                   until=until, span=span, longest=longest)  # fmt: skip

    @property
    def disturbed(self) -> dict[int, Disturbances]:
        """vehicle -> what faults do to it over the step (only the vehicles with any fault acting)."""
        return {entry.vehicle: entry.disturbances for entry in self.vehicles}

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
        return as_message(self)

    @classmethod
    def from_message(cls, message: object) -> Tick:
        """The inverse of to_message, checked: ValueError naming the field for anything malformed."""
        return read_as_or_older(message, cls, _from_older_log).check()

    def check(self) -> Tick:
        """What the types cannot say: a window or a span ends after its first step."""
        for name, end in (("until", self.until), ("span", self.span)):
            if end is not None and end <= self.k:
                raise ValueError(f"field {name!r} is not after step {self.k}, got {end}")
        return self


def _from_older_log(message: object) -> Message | None:
    """A tick of an older log in today's form (lockstep where it says nothing of realtime; its network's links as
    pairs), None for anything else."""
    if not isinstance(message, dict):
        return None
    lockstep = {name: value for name, value in (("speed", 1.0), ("hold", False)) if name not in message}
    network = older_network(message.get("network"))
    if not lockstep and network is None:
        return None
    return {**message, **lockstep, **({} if network is None else {"network": network})}
