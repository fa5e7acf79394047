"""The acoustic-link broker process: every coordination message goes vehicle -> broker -> neighbour.

Thin Zenoh adapter around comms.broker.broker_core. Each vehicle's step message carries its state and its transmission.
Lockstep: at tick k the broker waits until it holds every vehicle's step message of k-1, submits those
transmissions to the channel and publishes one batches message for the whole fleet (tick k and every vehicle's
receptions: each vehicle waits for this one message per step), then the step's link events (one message, after: the
supervisor's books wait for them, the vehicles do not).
Realtime (the ticks carry the wall clock): a step's transmissions are submitted as soon as its messages are in, and
every reception that they decide is published on its vehicle's rx key at once, usually ahead of its arrival,
stamped with the wall-clock time it is due (its arrival); the vehicle holds it until the step its arrival calls
for. None is handed out before every transmission that could still spoil it (collisions, half-duplex) is in the
water. Sending ahead takes the bus's latency out of the delivery time.
On the final tick it flushes the channel and reports how many events it published.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

import msgspec

from comms.broker.broker_core import BrokerCore
from comms.broker.lookahead import Replay, quiet_from
from comms.broker.span import Grants
from comms.broker.step_reading import VehicleStep, read_steps
from comms.broker.windows import lookahead_end
from comms.bus.bus import Extras, Handler, Publishers, serve
from comms.channel.channel import ARRIVAL_SLACK, intake_step
from comms.records.drops import Drops
from comms.records.events import LinkEvents
from comms.records.messages import (
    COMMS_ALIVE,
    COMMS_DONE_KEY,
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    COMMS_STEP_KEY,
    ROOT,
    TICK_KEY,
    Message,
    Tick,
    batches_message,
    decode,
    parse_tick,
    rx_key,
    rx_message,
    tx_key,
    vehicle_of_key,
)
from comms.records.records import Kinematics, LinkEvent, Reception, Transmission
from comms.records.reports import CommsDone
from comms.records.state import StateReport
from comms.records.stream import at_step_time, in_stream

log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)


@dataclass
class _Books:
    """What has arrived, filed by step, until the step that needs it is handled."""

    ticks: dict[int, Tick] = field(default_factory=dict)
    raw_ticks: dict[int, dict[str, object]] = field(default_factory=dict)  # as received: forwarded to the vehicles
    states: dict[int, dict[int, tuple[StateReport, Transmission | None]]] = field(default_factory=dict)
    published: int = 0
    drops: Drops = field(default_factory=lambda: Drops(log, "comms"))  # what the broker dropped, by key and cause
    taken: dict[int, int] = field(default_factory=dict)  # vehicle -> its latest step taken in
    last: dict[int, StateReport] = field(default_factory=dict)  # vehicle -> its latest state taken in

    @property
    def malformed(self) -> int:
        """Messages (and transmissions) dropped, whatever the cause."""
        return self.drops.total


class Broker:
    def __init__(
        self, core: BrokerCore, vehicles: Sequence[int], publishers: Publishers, dt: float, start_step: int = 0
    ) -> None:
        self.core = core
        self.vehicles = list(vehicles)
        self.publishers = publishers
        self.dt = dt
        self.books = _Books()
        self.books.taken.update(dict.fromkeys(self.vehicles, start_step - 1))  # each vehicle's next step: start_step
        self.next_k = start_step  # a restarted broker resumes mid-run, with nothing of the past in flight
        self.submitted = start_step - 1  # the last step whose transmissions are in the water
        self.clock: Tick | None = None  # the latest tick handled: realtime deliveries are timed by it
        self.latest_tick = start_step - 1  # the latest tick taken in: no vehicle can step beyond it (and the next)
        self.unpublished: list[LinkEvent] = []  # link events not yet published (one events message per step)
        self.stepped: list[LinkEvents] = []  # a window's earlier steps' events, each step's batch, not yet published
        self.grants = Grants(dt)  # lockstep spans: the ticks the broker issues itself (comms.broker.span)
        self.replay: Replay | None = None  # a window run past transmissions, to replay (comms.broker.lookahead)

    def take(self, key: str, payload: bytes) -> None:
        """File one incoming message; count and drop it if malformed or on a key its sender does not own."""
        owned = vehicle_of_key(key)
        try:
            if owned is not None and owned[1] == "state":
                # Checked whole, as the supervisor's intake checks it (a malformed next_tx or earlier step: dropped);
                # the earlier steps are read only for a window run past transmissions (comms.broker.lookahead).
                steps, next_tx, first = read_steps(payload, owned[0], whole=self.replay is not None)
                for step in steps:  # the earlier steps not read: the first of them is the message's first
                    self._file(step, first if len(steps) == 1 else step.report.k)
                self.grants.report(owned[0], steps[-1].report.k, next_tx)
            elif key == TICK_KEY:
                message = decode(payload)
                tick = parse_tick(message)
                if tick.span is not None:
                    self.grants.add(tick)
                else:
                    self.books.ticks[tick.k], self.books.raw_ticks[tick.k] = tick, message
                self.latest_tick = max(self.latest_tick, tick.reach - 1)  # a window's (a span's) last step
            else:
                decode(payload)  # a key the broker does not read: counted if malformed, as any
        except (ValueError, RecursionError) as exc:  # RecursionError: never past the bounded reader, counted if so
            self.books.drops.drop(key, exc)

    def _file(self, step: VehicleStep, first: int) -> None:
        """One step of a vehicle's step message, with the transmission it made: checked, then filed. first: the
        message's first step (that of a window whose earlier steps are not read), else the step's own."""
        report = step.report
        # each step once, in order, none skipped; one beyond the latest tick would be held forever
        in_stream(report.k, self.books.taken.get(report.vehicle), self.latest_tick + 1, self.submitted, first)
        self._plausible(report)
        self.books.taken[report.vehicle] = report.k
        self.books.states.setdefault(report.k, {})[report.vehicle] = (report, self._tx(step))

    def _plausible(self, report: StateReport) -> None:
        """ValueError (dropped: implausible) for a state beyond its vehicle's bounds: it never reaches the channel."""
        bounds = self.core.plausible.get(report.vehicle)
        if bounds is not None:
            bounds.check(report, self.books.last.get(report.vehicle), self.dt)
        self.books.last[report.vehicle] = report

    def _tx(self, step: VehicleStep) -> Transmission | None:
        """The transmission a step message carries; a malformed one is counted and dropped, the state still counts."""
        report, transmission = step.report, step.tx
        if step.tx_error is not None:
            self.books.drops.drop(tx_key(report.vehicle), step.tx_error, "transmission")
            return None
        if transmission is None:
            return None
        try:
            at_step_time(transmission.t, report.k, self.dt, "the transmission's")  # the channel times it from t
            bounds = self.core.plausible.get(report.vehicle)
            if bounds is not None:
                bounds.check_tx(transmission, report, self.dt)
            return transmission
        except ValueError as exc:
            self.books.drops.drop(tx_key(report.vehicle), exc, "transmission")
            return None

    def advance(self) -> bool:
        """Do everything the messages so far allow; True once the final tick is done."""
        while True:
            if self.replay is not None and self._can_submit(self.replay.end - 1):
                self._replay(self.replay)
            elif self._realtime() and self._can_submit(self.submitted + 1):
                self._submit(self.submitted + 1)
                self._release()
            elif self._tick_of(self.next_k) is not None and self._can_submit(self.next_k - 1):
                tick = self._handle(*self._next_tick())  # still filed while it runs: it says who is alive
                self.books.ticks.pop(self.next_k, None)
                self.books.raw_ticks.pop(self.next_k, None)
                self.grants.forget_before(self.next_k - 1)
                self.next_k = tick.end
                if tick.final:
                    return True
            else:
                return False

    def _next_tick(self) -> tuple[Tick, dict[str, object] | None]:
        """The tick of step next_k and its wire form: the supervisor's own, or one the broker issues in a span (its
        wire form None: made once its window is settled, _handle)."""
        k = self.next_k
        tick = self.books.ticks.get(k)
        if tick is not None:
            return tick, self.books.raw_ticks[k]
        tick = self.grants.tick(k, self.vehicles)
        assert tick is not None  # advance asked _tick_of first
        return tick, None

    def _looked_ahead(self, tick: Tick) -> Tick:
        """A tick the broker issues, its window run past the first transmission as far as the channel allows
        (comms.broker.lookahead); as it is if it cannot be (a kill or restart next: hold)."""
        grant = self.grants.governing(tick.k)
        if grant is None or grant.hold:
            return tick
        quiet = quiet_from(self.core.channel, tick.end - 1, self.dt, self.core.least_delay(tick.network))
        end = lookahead_end(tick.k, tick.end, grant.reach, grant.longest, quiet)
        return tick if end == tick.end else msgspec.structs.replace(tick, until=end)

    def _realtime(self) -> bool:
        return self.clock is not None and self.clock.wall is not None

    def _tick_of(self, k: int) -> Tick | None:
        """The tick step k runs on: the latest handled one if k is in its window, else one filed for k."""
        clock = self.clock
        if clock is not None and clock.k <= k < clock.end:
            return clock
        return self.books.ticks.get(k) or self.grants.governing(k)

    def _expected(self, k: int) -> list[int]:
        """Vehicles whose step message of step k counts: alive then and still alive at the next tick (if it is
        known; a tick that holds its step's packets makes sure it is)."""
        then, after = self._tick_of(k), self._tick_of(k + 1)
        before = then.alive if then is not None and then.alive is not None else self.vehicles
        if after is None or after.alive is None:
            return list(before)
        now = set(after.alive)
        return [v for v in before if v in now]

    def _can_submit(self, k: int) -> bool:
        """Whether step k's transmissions can go in the water: every expected vehicle's message of k is in."""
        if k <= self.submitted:
            return True
        tick = self._tick_of(k)
        if tick is None or (tick.hold and self._tick_of(k + 1) is None):
            return False
        states = self.books.states.get(k, {})
        return all(v in states for v in self._expected(k))

    def _submit(self, k: int) -> None:
        """Step k's transmissions (under the network in force then) into the channel."""
        arrived = self.books.states.pop(k, {})
        states = {v: arrived[v] for v in self._expected(k) if v in arrived}
        sent = [tx for _, tx in states.values() if tx is not None]
        where: dict[int, Kinematics] = {v: report.kinematics for v, (report, _) in states.items()}
        tick = self._tick_of(k)
        self.unpublished += self.core.submit(sent, where, tick.network if tick else None)
        self.submitted = k

    def _handle(self, tick: Tick, raw: dict[str, object] | None) -> Tick:
        """A tick (lockstep: of a time window, inside which no vehicle transmits but at its last step, unless the
        broker runs it past them: comms.broker.lookahead): the last step's transmissions into the water, then every
        reception arriving by each step of the window, step by step (nothing can be submitted between them, so this
        is what stepping one step at a time would hand out). raw: its wire form (None: a tick the broker issues,
        whose window it may still run further). Returns the tick as handled."""
        if tick.k - 1 > self.submitted:
            self._submit(tick.k - 1)
        self.states_before(tick.k)
        ahead = False
        if raw is None:
            plain = tick.end
            tick = self._looked_ahead(tick)
            raw, ahead = tick.to_message(), tick.end > plain
        self.clock = tick
        if tick.end - tick.k > 1:
            self._handle_window(tick, raw, ahead)
        else:
            self._handle_step(tick, raw)
        return tick

    def _handle_step(self, tick: Tick, raw: dict[str, object]) -> None:
        """A tick of one step (the final one: the channel flushed and the broker's end-of-run report)."""
        batches = self._deliver(tick.t)
        if tick.final:
            self.unpublished += self.core.finish(tick.t)
            self._publish_events(tick)
            self._publish_stats(tick.t, final=True)
            drops = self.books.drops
            keys, causes = drops.reported()
            done = CommsDone(tick.t, tick.k, self.books.published, drops.total, causes, keys)
            self.publishers.put(COMMS_DONE_KEY, done.to_message())
            return
        if tick.wall is not None:  # realtime: late deliveries go out as such; the batches message is the tick
            self._publish_live(tick, batches)
            batches = {}  # a vehicle named nowhere has nothing: realtime vehicles take in their own deliveries
        self._step_out(tick, batches_message(raw, batches))
        self._publish_stats(tick.t)

    def _handle_window(self, tick: Tick, raw: dict[str, object], ahead: bool) -> None:
        """A lockstep tick of several steps: one batch per step, the statistics snapshotted at each step's time, the
        link events a batch per step too. ahead: a window run past transmissions, whose steps after the first are
        handed out as the channel would deliver them with nothing sent meanwhile, and replayed once its states are
        in (_replay)."""
        last = tick.k + 1 if ahead else tick.end
        batches = []
        for k in range(tick.k, last):
            t = tick.t if k == tick.k else k * self.dt
            batches.append(self._deliver(t))
            self._close_step(t, k)
        if ahead:
            alive = tick.alive if tick.alive is not None else self.vehicles
            handed = self.core.ahead([k * self.dt for k in range(last, tick.end)], alive)
            self.replay = Replay(tick.k, tick.end, handed)
            batches += handed
        self._step_out(tick, batches_message(raw, batches))

    def _close_step(self, t: float, k: int) -> None:
        """Step k of a window done: the statistics snapshotted at its time; its link events one batch, as single
        steps publish them (the log keeps them so, whatever the windows)."""
        self._publish_stats(t)
        if self.unpublished:
            self.stepped.append(LinkEvents(t, k, tuple(self.unpublished)))
            self.unpublished = []

    def _replay(self, window: Replay) -> None:
        """A window run past transmissions, once all its states are in: its steps after the first as stepping runs
        them (the transmissions of the step before into the water, the step's deliveries, its statistics and
        events), each step's deliveries those handed out at its start, or the lookahead was wrong."""
        self.replay = None
        for k in range(window.k + 1, window.end):
            self._submit(k - 1)
            t = k * self.dt
            if self._deliver(t) != window.handed[k - window.k - 1]:
                raise RuntimeError(f"channel lookahead: the receptions of step {k} changed after they were handed out")
            self._close_step(t, k)
        self._publish_stepped()

    def _step_out(self, tick: Tick, batches: Message) -> None:
        """The batches message (what every vehicle waits for), then the tick's link events: off the fleet's critical
        path (the supervisor's books wait for them instead: supervisor.engine.intake). Before it when a process is
        killed or restarted next (hold): the supervisor acts once this step's states are in, which the batches
        message makes possible, and a broker killed with its events unsent would lose them."""
        if tick.hold:
            self._publish_events(tick)
            self.publishers.put(COMMS_STEP_KEY, batches)
        else:
            self.publishers.put(COMMS_STEP_KEY, batches)
            self._publish_events(tick)

    def states_before(self, k: int) -> None:
        """Forget the states of steps before k: those of a window's earlier steps are never submitted."""
        for old in [j for j in self.books.states if j < k]:
            del self.books.states[old]

    # --- realtime deliveries ---------------------------------------------------------------------------------

    def _release(self) -> None:
        """Hand out, ahead of their arrival, every reception the submitted transmissions decide: arrivals up to the
        next step's instant (step submitted+1's packets, not in yet, could spoil any later one)."""
        assert self.clock is not None and self.clock.wall is not None
        self._publish_live(self.clock, self._deliver((self.submitted + 1) * self.dt - 2 * ARRIVAL_SLACK))

    def _deliver(self, t: float) -> dict[int, list[Reception]]:
        """Receptions arriving by t, per vehicle alive at the latest tick; their events wait for the next tick's."""
        clock = self.clock
        alive = clock.alive if clock is not None and clock.alive is not None else self.vehicles
        batches, delivered = self.core.deliver(t, alive)
        self.unpublished += delivered
        return batches

    def _publish_live(self, clock: Tick, batches: dict[int, list[Reception]]) -> None:
        for v, receptions in batches.items():
            if receptions:
                k = intake_step(receptions[-1].arrival, self.dt)
                self.publishers.put(rx_key(v), rx_message(v, k, receptions[-1].arrival, receptions, clock.wall_of))

    # --- reports ---------------------------------------------------------------------------------------------

    def _publish_stats(self, t: float, final: bool = False) -> None:
        snapshot = self.core.snapshot_due(t, final)
        if snapshot is not None:
            self.publishers.put(COMMS_STATS_KEY, snapshot)

    def _publish_events(self, tick: Tick) -> None:
        """The events not yet published: a window's, step by step; then the rest, as the tick's step's."""
        if self.unpublished:
            self.stepped.append(LinkEvents(tick.t, tick.k, tuple(self.unpublished)))
            self.unpublished = []
        self._publish_stepped()

    def _publish_stepped(self) -> None:
        for batch in self.stepped:
            self.publishers.put(COMMS_EVENTS_KEY, batch.to_message())
            self.books.published += len(batch.events)
        self.stepped = []


def run_broker(
    core: BrokerCore,
    vehicles: Sequence[int],
    dt: float,
    connect: Sequence[str],
    start_step: int = 0,
    hello: Message | None = None,
    extras: Extras | None = None,
) -> int:
    """Serve the channel from step start_step until the stop message or the supervisor's disappearance. hello: the
    answer to the supervisor's question which scenario (and seed) the broker runs (comms.records.messages.Hello);
    extras: its credentials and the site's Zenoh config (comms.bus.bus.Extras)."""

    def handler(publishers: Publishers) -> Handler:
        broker = Broker(core, vehicles, publishers, dt, start_step)

        def handle(key: str, payload: bytes) -> None:
            broker.take(key, payload)
            broker.advance()

        return handle

    keys = (TICK_KEY, f"{ROOT}/vehicle/*/state")
    # the supervisor's name for it: a stop that refuses it names it so (bus.serve: exit 2)
    return serve("comms broker", connect, keys, COMMS_ALIVE, handler, hello, extras)
