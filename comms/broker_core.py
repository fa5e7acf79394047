"""The broker's work at each sync step, as plain code shared by the broker process and the in-process engine.

At sync instant t_k: first the transmissions of step k-1 (all stamped t_{k-1}) enter the channel, in sender order,
with every vehicle's kinematics of t_{k-1}; then everything arriving no later than t_k is handed out, one batch per
vehicle. Only links of the current graph carry messages.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from comms.channel import Channel, Kinematics, LinkEvent, Reception
from comms.messages import coordination_payload_size
from vehicles.transmission import Transmission


@dataclass
class BrokerCore:
    channel: Channel
    neighbours: dict[int, list[int]]  # the current graph: who hears whom
    counts: dict[str, int] = field(default_factory=lambda: {"sent": 0, "delivered": 0, "dropped": 0})

    def submit(self, transmissions: Iterable[Transmission], kinematics: Mapping[int, Kinematics]) -> list[LinkEvent]:
        """Put one step's transmissions on the channel; kinematics: every vehicle's, at the transmission time."""
        events: list[LinkEvent] = []
        for tx in sorted(transmissions, key=lambda tx: tx.sender):
            receivers = {j: kinematics[j] for j in self.neighbours.get(tx.sender, []) if j in kinematics}
            events += self.channel.transmit(tx, coordination_payload_size(tx), receivers)
        return self._counted(events)

    def deliver(self, t: float, vehicles: Sequence[int]) -> tuple[dict[int, list[Reception]], list[LinkEvent]]:
        """Receptions due by t, per vehicle (every vehicle gets a batch, possibly empty)."""
        receptions, events = self.channel.deliver(t)
        batches: dict[int, list[Reception]] = {i: [] for i in vehicles}
        for r in receptions:
            batches.setdefault(r.receiver, []).append(r)
        return batches, self._counted(events)

    def finish(self, t: float) -> list[LinkEvent]:
        """End of run: what is still in flight is dropped, so every link's books balance."""
        return self._counted(self.channel.flush(t))

    def _counted(self, events: list[LinkEvent]) -> list[LinkEvent]:
        for event in events:
            self.counts[event.kind] += 1
        return events
