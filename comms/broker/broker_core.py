"""The broker's work at each sync step, as plain code shared by the broker process and the in-process engine.

At sync instant t_k: first the transmissions of step k-1 (all stamped t_{k-1}) enter the channel in sender order,
encoded as the modem would carry them, with every vehicle's kinematics of t_{k-1}; then everything arriving no
later than t_k is handed out, one batch per vehicle. Only links of the current graph carry messages. Link
statistics are kept all along and snapshotted every stats window.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from comms.broker.stats import LinkStats
from comms.channel.channel import Channel
from comms.records.messages import Message
from comms.records.network import Network
from comms.records.plausible import Plausible
from comms.records.records import Kinematics, LinkEvent, Reception, Transmission
from comms.records.wire import carried, encode_coordination, message_size


@dataclass
class BrokerCore:
    channel: Channel
    neighbours: dict[int, list[int]]  # the current graph: who hears whom
    stats: LinkStats
    plausible: dict[int, Plausible] = field(default_factory=dict)  # each vehicle's bounds (comms.records.plausible)
    wide: bool = False  # the fleet's message has its sender in two bytes (comms.records.wire.wide_for)
    _next_snapshot: float | None = None  # the first snapshot after one full window
    _least: dict[Network | None, float] = field(default_factory=dict)  # least_delay's, by network

    def submit(
        self,
        transmissions: Iterable[Transmission],
        kinematics: Mapping[int, Kinematics],
        network: Network | None = None,
    ) -> list[LinkEvent]:
        """Put one step's transmissions in the water; kinematics: every live vehicle's, at the transmission time;
        network: the graph and link faults in force then (None: the scenario's graph, no faults)."""
        events: list[LinkEvent] = []
        wide, alive, transmit = self.wide, kinematics.keys(), self.channel.transmit
        for tx in sorted(transmissions, key=_sender):
            wire = encode_coordination(tx, wide)
            gamma, gamma_dot = carried(wire, wide)  # what receivers will read: float32 values
            as_sent = Transmission(  # not dataclasses.replace: the same record, a fraction of the cost
                tx.sender, tx.seq, tx.t, gamma, gamma_dot, tx.position, tx.velocity, tx.stamp
            )
            heard_by = network.neighbours(tx.sender) if network else self.neighbours.get(tx.sender, [])
            receivers = alive & heard_by  # a set, as set(heard_by) & set(kinematics) was, without building two
            if network is not None and tx.sender in network.silent:
                events += _silenced(tx, receivers)
                continue
            events += transmit(as_sent, len(wire), receivers, kinematics, network)
        self.stats.add(events)
        return events

    def deliver(self, t: float, vehicles: Sequence[int]) -> tuple[dict[int, list[Reception]], list[LinkEvent]]:
        """Receptions due by t, per vehicle (every vehicle gets a batch, possibly empty)."""
        self.stats.note_alive(vehicles)
        receptions, events = self.channel.deliver(t)
        self.stats.add(events)
        return _batches(receptions, vehicles), events

    def ahead(self, times: Sequence[float], vehicles: Sequence[int]) -> list[dict[int, list[Reception]]]:
        """The batches deliver would hand out at each of times in turn, if nothing were transmitted meanwhile; the
        channel and the statistics are left as they are (channel lookahead: comms.broker.lookahead)."""
        return [_batches(receptions, vehicles) for receptions in self.channel.ahead(times)]

    def least_delay(self, network: Network | None = None) -> float:
        """A lower bound on any packet's delay under network (None: the scenario's graph, no faults): the channel's
        over the directed links packets travel then (Channel.least_delay); worked out once per network."""
        if network not in self._least:
            if network is None:
                links = [(i, j) for i, heard_by in self.neighbours.items() for j in heard_by]
            else:
                links = [(i, j) for i in self.neighbours for j in network.neighbours(i)]
            self._least[network] = self.channel.least_delay(message_size(self.wide), links)
        return self._least[network]

    def finish(self, t: float, reason: str = "end_of_run") -> list[LinkEvent]:
        """End of run (or of this broker): what is still in flight is dropped, so every link's books balance."""
        events = self.channel.flush(t, reason)
        self.stats.add(events)
        return events

    def snapshot_due(self, t: float, final: bool = False) -> Message | None:
        """The link statistics, once per window and at the end; lambda_2 over the vehicles alive at every delivery
        of the window (each the tick's)."""
        if self._next_snapshot is None:
            self._next_snapshot = self.stats.window
        if not final and t + 1e-9 < self._next_snapshot:
            return None
        self._next_snapshot = t + self.stats.window
        return self.stats.snapshot(t, self.stats.window_alive())

    @property
    def counts(self) -> dict[str, int]:
        return self.stats.totals()


def _sender(tx: Transmission) -> int:
    return tx.sender


def _batches(receptions: Iterable[Reception], vehicles: Sequence[int]) -> dict[int, list[Reception]]:
    """Receptions per receiver: every vehicle gets a batch, possibly empty."""
    batches: dict[int, list[Reception]] = {i: [] for i in vehicles}
    for r in receptions:
        batches.setdefault(r.receiver, []).append(r)
    return batches


def _silenced(tx: Transmission, receivers: set[int]) -> list[LinkEvent]:
    """A silent modem: the vehicle believes it sent; nothing entered the water."""
    events = []
    for j in sorted(receivers):
        events.append(LinkEvent(tx.t, tx.sender, j, tx.seq, "sent"))
        events.append(LinkEvent(tx.t, tx.sender, j, tx.seq, "dropped", reason="modem_silent"))
    return events
