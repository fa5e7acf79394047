"""The vehicle process: the only Zenoh code of a vehicle. It moves messages; the math is vehicles.runtime.

Per sync step k it needs the supervisor's tick (time, faults acting on it) and, in lockstep, its reception batch for
k: both come in the one batches message the broker publishes for the whole fleet at each step (the supervisor
publishes it while the broker is down). It runs vehicles.step.step_records, then publishes one step message: its
state, the transmission it made (if any) and the receptions it took in. In realtime the broker sends each reception
as soon as the channel has decided it, usually ahead of its arrival: the vehicle holds it until the step its arrival
calls for, and reports how late each one reached it against its arrival (negative: how far ahead). comms.bus.bus.serve
runs its life: it stops on the stop message, or by itself when the supervisor's liveliness token disappears (no
orphans).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from comms.bus.bus import Ending, Extras, Publishers, Timed, serve
from comms.channel.channel import intake_step
from comms.records.bus_records import read_batches
from comms.records.drops import Drops
from comms.records.messages import (
    COMMS_STEP_KEY,
    Message,
    Tick,
    decode,
    parse_window,
    rx_key,
    state_key,
    step_message,
    tick_lead,
    vehicle_alive_key,
    vehicle_done_key,
    window_message,
)
from comms.records.receptions import Delivery, RxBatch
from comms.records.records import Disturbances, Heard
from comms.records.reports import VehicleDone
from vehicles.agent import VehicleConfig
from vehicles.runtime import NodeState, Radio
from vehicles.step import step_records
from vehicles.transmission import earliest_transmission

log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)


@dataclass(frozen=True, slots=True)
class _Live:
    """A realtime reception as it reached the vehicle: taken in at `step`; `late` s after its arrival (wall clock;
    negative: it came ahead and was held)."""

    step: int
    delivery: Delivery
    late: float


@dataclass
class _Pending:
    """Ticks and receptions that arrived ahead of the step that needs them."""

    ticks: dict[int, Tick] = field(default_factory=dict)
    start_at: dict[int, float] = field(default_factory=dict)  # realtime: when to begin each step (wall clock)
    batches: dict[int, tuple[list[Heard], Message | None]] = field(default_factory=dict)  # by step
    live: list[_Live] = field(default_factory=list)  # realtime: receptions held until their step
    drops: Drops = field(default_factory=lambda: Drops(log, "vehicle"))  # what it dropped, by key and by cause

    def ready(self, k: int) -> bool:
        return k in self.ticks

    def receptions(self, tick: Tick, vid: int, k: int) -> tuple[list[Heard], Message | None, list[float]]:
        """What the vehicle takes in at step k of this tick's window, the batch to report (None: the broker is
        down), lateness (s)."""
        heard, batch = self.batches.pop(k)
        if tick.wall is None:
            return heard, batch, []
        live = [r for r in self.live if r.step <= tick.k]  # realtime: what has arrived by this step's instant
        self.live = [r for r in self.live if r.step > tick.k]
        if not tick.comms:  # the broker died before it could report them delivered: lockstep never hands them out
            return [], None, []
        taken = RxBatch(tick.t, tick.k, vid, tuple(r.delivery for r in live))
        return taken.heard, taken.to_message(), [r.late for r in live]


def run_vehicle(
    cfg: VehicleConfig,
    initial: NodeState,
    radio: Radio,
    neighbours: Sequence[int],
    dt: float,
    connect: Sequence[str],
    start_step: int = 0,
    hello: Message | None = None,
    extras: Extras | None = None,
    ending: Ending | None = None,
) -> int:
    """Serve one vehicle from step start_step (a restarted process resumes mid-run) until told to stop or the
    supervisor disappears; returns the exit code. neighbours: the scenario's, until a tick says otherwise.
    hello: the answer to the supervisor's question which scenario the vehicle runs (comms.records.messages.Hello);
    extras: its credentials and the site's Zenoh config (comms.bus.bus.Extras); ending: a vehicle host's hold on it
    (vehicles.host)."""
    vid = cfg.vehicle_id

    def handler(publishers: Publishers) -> Timed:
        return _Vehicle(cfg, radio, initial, neighbours, dt, publishers, start_step)

    keys = (COMMS_STEP_KEY, rx_key(vid))
    return serve(f"vehicle {vid}", connect, keys, vehicle_alive_key(vid), handler, hello, extras, ending)


class _Vehicle:
    """The vehicle as comms.bus.bus.serve drives it: it steps once it has the tick of its next step and, in realtime,
    once that step's wall-clock time has come (ticks go out ahead, so the bus's latency is not in the step's), or
    at the latest the tick's lead after the tick came (its host's clock may lag the supervisor's)."""

    def __init__(
        self,
        cfg: VehicleConfig,
        radio: Radio,
        node: NodeState,
        neighbours: Sequence[int],
        dt: float,
        publishers: Publishers,
        k: int,
        now: Callable[[], float] = time.time,
    ) -> None:
        """now: the wall clock (s since the epoch, as the supervisor stamps realtime ticks); tests drive their own."""
        self.cfg, self.radio, self.node, self.neighbours, self.dt = cfg, radio, node, neighbours, dt
        self.publishers, self.k, self.pending, self.now = publishers, k, _Pending(), now
        self.promised: int | None = None  # the first step it said it may transmit at (None: said nothing yet)

    def __call__(self, key: str, payload: bytes) -> None:
        _take(key, payload, self.cfg.vehicle_id, self.pending, self.dt, self.now)  # comms.bus.bus.serve then: on_time

    def due(self) -> float | None:
        return self.pending.start_at.get(self.k)

    def final_report(self) -> tuple[str, Message]:
        """Its end-of-run report (comms.bus.bus.serve publishes it on the stop message): what it dropped, by key."""
        vid = self.cfg.vehicle_id
        drops = self.pending.drops
        by_key, by_cause = drops.reported()
        report = VehicleDone(self.k * self.dt, self.k, vid, by_key, by_cause)
        return vehicle_done_key(vid), report.to_message()

    def on_time(self) -> None:
        """Run every step whose tick is in and whose time has come: a lockstep tick's whole time window at once."""
        while self.pending.ready(self.k):
            start_at = self.pending.start_at.get(self.k)
            if start_at is not None and start_at > self.now():
                return
            self.pending.start_at.pop(self.k, None)
            tick = self.pending.ticks.pop(self.k)
            steps = [self._step(tick, k) for k in range(tick.k, tick.end)]
            self.k = tick.end
            node = self.node
            last = None if node.last_sent is None else node.last_sent.stamp
            next_tx = earliest_transmission(self.radio.policy, self.radio.tdma, self.cfg.vehicle_id, self.k - 1,
                                            self.dt, last, node.pending)  # fmt: skip
            self.promised = next_tx
            self.publishers.put(state_key(self.cfg.vehicle_id), window_message(steps, next_tx))

    def _step(self, tick: Tick, k: int) -> Message:
        """Step k of the tick's window on what was taken in; its step message (state, transmission, receptions)."""
        vid = self.cfg.vehicle_id
        heard, batch, lateness = self.pending.receptions(tick, vid, k)
        dist = tick.disturbed.get(vid, Disturbances())
        current = tick.network.neighbours(vid) if tick.network is not None else self.neighbours
        started = self.now() if tick.wall is not None else 0.0
        t = tick.t if k == tick.k else k * self.dt
        self.node, out = step_records(self.cfg, self.radio, self.node, k, t, self.dt, heard, current, dist)
        if out.transmission is not None and self.promised is not None and k < self.promised:  # windows count on it
            policy = getattr(self.radio.policy, "label", type(self.radio.policy).__name__)
            raise RuntimeError(
                f"vehicle {vid} transmitted at step {k}, before step {self.promised} it said it would: {policy}'s "
                "earliest() must not be later than the first step its due() is true"
            )
        state = out.state
        if tick.wall is not None:
            state["rx_lateness"] = lateness
            state["step_lateness"] = started - tick.wall  # how late the vehicle began its step of t_k
        return step_message(state, out.tx, batch)


def _take(key: str, payload: bytes, vid: int, pending: _Pending, dt: float, now: Callable[[], float]) -> None:
    """File an incoming message by step; a malformed one is counted and dropped, with nothing of it filed."""
    try:
        if key == COMMS_STEP_KEY:
            tick, batches = _batches(payload, vid, dt)
            if not tick.final:
                pending.ticks[tick.k] = tick
                if tick.wall is not None:  # its time, but never more than the lead after it came: a host whose
                    # clock lags the supervisor's must not hold the whole fleet back
                    pending.start_at[tick.k] = min(tick.wall, now() + tick_lead(dt, tick.speed))
                for k in range(tick.k, tick.end):
                    batch = None if batches is None else batches[k - tick.k]
                    pending.batches[k] = ([], None) if batch is None else (batch.heard, batch.to_message())
        elif key == rx_key(vid):
            _file_rx(decode(payload), pending, dt, now())
        else:
            decode(payload)  # a key the vehicle does not read: counted if malformed, as any
    except (ValueError, RecursionError) as exc:  # RecursionError: never past the bounded reader, counted if so
        pending.drops.drop(key, exc)


def _batches(payload: bytes, vid: int, dt: float) -> tuple[Tick, list[RxBatch] | None]:
    """The tick of a batches message and vid's reception batch of each step of its window (None: the broker is
    down), every one read before anything is filed: in one msgspec pass (comms.records.bus_records.read_batches),
    the slow way where it refuses, which raises ValueError naming what is wrong."""
    read = read_batches(payload, vid, dt)
    if read is not None:
        return read
    tick, batches = parse_window(decode(payload), vid, dt)
    return tick, None if batches is None else [RxBatch.from_message(batch) for batch in batches]


def _file_rx(message: Message, pending: _Pending, dt: float, now: float) -> None:
    """Realtime deliveries, as they come (usually ahead of their arrival), with how late each reached the vehicle
    (now: the wall clock as it came)."""
    timed = RxBatch.from_message(message).timed()
    pending.live += [_Live(intake_step(d.arrival, dt), d, now - due) for d, due in timed]
