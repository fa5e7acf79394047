"""`cpf resim --closed-loop`: the recorded channel's decisions, the re-simulated fleet's gammas.

Plain `cpf resim` is open loop across the fleet: each vehicle hears, at each step, exactly the receptions the log
recorded, with the gammas its neighbours sent in the run, whatever the re-simulated neighbours now do. With
--closed-loop each recorded reception keeps what the channel decided (who heard which transmission, and when: the
same losses, collisions and delays), but carries what the re-simulated sender transmitted at that time, carried as
the modem carries it (float32, comms.records.wire). A transmission is known by its sender and its data time: a
reception is taken in a step after the one it was sent in, so the sender has been re-simulated by then.

A reception whose sender did not transmit at that time in the re-simulation (a setting that moves its
transmissions: an event-triggered threshold, another period) has nothing to carry: it is dropped and counted,
and the summary says how many. Where the channel's decisions do not depend on what changed (an ideal or a
range-free channel and a periodic policy), the closed loop is the run the new settings would have given.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from comms.records.records import Heard, Transmission
from comms.records.wire import decode_coordination, encode_coordination


@dataclass
class ClosedLoop:
    """The re-simulated transmissions so far, and the recorded receptions left without one."""

    sent: dict[tuple[int, float], tuple[float, float]] = field(default_factory=dict)  # (sender, data time) -> carried
    unmatched: int = 0

    def transmitted(self, tx: Transmission | None) -> None:
        if tx is not None:
            # wide takes any id; the floats it carries are those of the fleet's own message, which differs in the
            # sender's width alone
            carried = decode_coordination(encode_coordination(tx, wide=True), wide=True)
            self.sent[(tx.sender, tx.data_time)] = (carried.gamma, carried.gamma_dot)

    def heard(self, batch: list[Heard]) -> list[Heard]:
        """The recorded receptions with the re-simulated senders' values (those without one dropped, counted)."""
        out = []
        for h in batch:
            now = self.sent.get((h.sender, h.stamp))
            if now is None:
                self.unmatched += 1
            else:
                out.append(Heard(h.sender, h.stamp, now[0], now[1]))
        return out
