"""Channel lookahead: lockstep windows that run past the fleet's transmissions (pure; comms.broker.broker asks).

A window [a, b) used to stop at the first step n at which a vehicle may transmit (comms.broker.windows), because a
transmission made inside it could reach a receiver, or spoil a reception, before its end. The channel says when
that can happen (comms.channel.channel decides a packet at its delivery, from the airtimes in the water by then):
- nothing sent at n or later arrives before t_n plus the least delay of a packet: its airtime and the least extra
  delay of the links in force (the time of flight and jitter can be zero: two vehicles can be at one place);
- a transmission at t_n can spoil only packets arriving after t_n (half duplex at a transmitting receiver,
  collisions), and only if either is modelled.
So the window may run to b = the first step whose intake either could change (quiet_from). The broker hands out
every reception of [a, b) at its start (Channel.ahead: what deliver would hand out with nothing sent meanwhile),
lets the fleet step through it, transmitting, and once every state of b-1 is in it replays the window's steps
a+1 .. b-1 as stepping would: step j-1's transmissions into the water, step j's deliveries (checked equal to those
handed out), the statistics and link events of step j. The records are those of stepping one step at a time
(tests/test_windows_e2e.py). The gain: a fleet sending more often than its packets take to arrive, over a channel
without collisions, still runs windows of about the least delay; with collisions or half duplex the next arrival
in flight cuts the window, as a packet sent then could spoil it; on TDMA a slot holds its packet, and on the ideal
channel (no airtime, no extra delay) a packet arrives at the next step: no gain there. Every bound starts from the
transmission's time, which must be its step's (comms.records.stream.at_step_time: a forged one is dropped).
"""

from __future__ import annotations

from dataclasses import dataclass

from comms.channel.channel import Channel, intake_step
from comms.records.records import Reception

# s taken off t_n + least delay: a vehicle stamps t_n as k dt or as its tick's t, which may differ in the last bit
STAMP_MARGIN = 1e-6


@dataclass(frozen=True, slots=True)
class Replay:
    """A window [k, end) run past transmissions: the batches handed out at its steps k+1 .. end-1, to replay."""

    k: int
    end: int
    handed: list[dict[int, list[Reception]]]


def quiet_from(channel: Channel, n: int, dt: float, least_delay: float) -> int:
    """The first step after n whose intake a transmission made at step n or later could change: least_delay (of a
    packet on the links in force: BrokerCore.least_delay) after t_n, or the arrival of the first packet in flight
    that such a transmission could spoil."""
    t_n = n * dt
    quiet = intake_step(t_n + least_delay - STAMP_MARGIN, dt)
    if quiet <= n + 1:  # no window can pass n (the ideal channel): the packets in flight need not be looked at
        return quiet
    first = channel.first_spoilable(t_n)
    return quiet if first is None else min(quiet, intake_step(first, dt))
