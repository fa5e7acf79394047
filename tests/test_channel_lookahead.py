"""What channel lookahead (comms.broker.lookahead) asks of the channel: Channel.ahead hands out what deliver would, time
after time, without changing the channel; no packet arrives sooner than least_delay after it was sent; and
first_spoilable names the first arrival a later transmission could still spoil, only when one could."""

from __future__ import annotations

import copy

from hypothesis import given, settings
from hypothesis import strategies as st

from comms.channel.channel import Channel, ChannelParams, LinkParams
from comms.channel.modem import ModemParams
from comms.records.wire import SIZE
from tests.test_channel import at, tx

SLOW = ModemParams(bitrate=240.0, preamble=0.1, half_duplex=True, collisions=True)  # 0.6 s per 15-byte packet
IDS = (1, 2, 3)

sends = st.lists(
    st.tuples(st.sampled_from(IDS), st.floats(0.0, 5.0), st.floats(-400.0, 400.0), st.floats(-400.0, 400.0)),
    min_size=1,
    max_size=12,
)


def channel_with(
    packets: list[tuple[int, float, float, float]], modem: ModemParams, jitter: float, links: dict | None = None
) -> Channel:
    """Every packet of the list sent (in time order) to the two other vehicles, the senders at (x, y), the others at
    fixed places; links: the links' own parameters."""
    channel = Channel(ChannelParams(modem=modem, jitter=jitter, links=links or {}), seed=7)
    places = {1: at(0.0), 2: at(300.0, 100.0), 3: at(-200.0, 250.0)}
    for seq, (sender, t, x, y) in enumerate(sorted(packets, key=lambda p: p[1]), start=1):
        where = {**places, sender: at(x, y)}
        message = tx(sender, seq, t, position=(x, y, 0.0))
        channel.transmit(message, SIZE, {j for j in IDS if j != sender}, where)
    return channel


@settings(max_examples=40, deadline=None)
@given(packets=sends, jitter=st.sampled_from([0.0, 0.3]), collide=st.booleans())
def test_ahead_hands_out_what_deliver_would(packets, jitter, collide) -> None:
    modem = SLOW if collide else ModemParams(bitrate=240.0, preamble=0.1)
    channel = channel_with(packets, modem, jitter)
    before = copy.deepcopy(channel)
    times = [0.1 * k for k in range(1, 80)]
    ahead = channel.ahead(times)
    kept = lambda c: (c._in_flight, c._heard, c._sending)  # noqa: E731
    assert kept(channel) == kept(before)  # left as it was
    delivered = [channel.deliver(t)[0] for t in times]
    assert ahead == delivered
    if not collide:  # every packet to both others, all in by 7.9 s (sent by 5 s, 0.6 s on the air, < 1 s flight)
        assert sum(map(len, delivered)) == 2 * len(packets)


@settings(max_examples=40, deadline=None)
@given(packets=sends, jitter=st.sampled_from([0.0, 0.3]))
def test_no_packet_arrives_sooner_than_the_least_delay(packets, jitter) -> None:
    channel = channel_with(packets, SLOW, jitter)
    least = channel.least_delay(SIZE)
    assert least == SLOW.airtime(SIZE) > 0.5
    sent = {seq: t for seq, (_, t, _, _) in enumerate(sorted(packets, key=lambda p: p[1]), start=1)}
    for arrival, _, seq, *_ in channel._in_flight:
        assert arrival >= sent[seq] + least


@settings(max_examples=40, deadline=None)
@given(packets=sends, extra=st.lists(st.floats(0.0, 3.0), min_size=6, max_size=6))
def test_no_packet_arrives_sooner_than_the_least_delay_of_its_links(packets, extra) -> None:
    """Every link its own extra delay; the bound over all six links holds for every packet, and is their least."""
    pairs = [(i, j) for i in IDS for j in IDS if i != j]
    own = {pair: LinkParams(extra_delay=x) for pair, x in zip(pairs, extra, strict=True)}
    channel = channel_with(packets, SLOW, 0.05, own)
    least = channel.least_delay(SIZE, pairs)
    assert least == SLOW.airtime(SIZE) + min(extra)
    sent = {seq: t for seq, (_, t, _, _) in enumerate(sorted(packets, key=lambda p: p[1]), start=1)}
    for arrival, _, seq, *_ in channel._in_flight:
        assert arrival >= sent[seq] + least


PLACES = {1: at(0.0), 2: at(300.0, 100.0), 3: at(-200.0, 250.0)}  # channel_with's


@settings(max_examples=150, deadline=None)
@given(
    packets=sends,
    t=st.floats(0.0, 6.0),
    later=st.tuples(st.sampled_from(IDS), st.floats(0.0, 2.0), st.floats(-400.0, 400.0), st.floats(-400.0, 400.0)),
    modem=st.sampled_from([SLOW, ModemParams(bitrate=240.0, preamble=0.1, collisions=True),
                           ModemParams(bitrate=240.0, preamble=0.1, half_duplex=True)]),
)  # fmt: skip
def test_no_transmission_at_t_or_later_spoils_an_arrival_before_the_first_spoilable(packets, t, later, modem) -> None:
    """What lookahead counts on, by the channel's own mechanics rather than first_spoilable's definition: with
    everything sent by t in the water, one more packet sent at t or later (any sender, anywhere) leaves every
    reception arriving before first_spoilable(t) as it was (collisions and half duplex, alone or together)."""
    sent = [p for p in packets if p[1] <= t]
    base = channel_with(sent, modem, 0.0)
    first = base.first_spoilable(t)
    other = copy.deepcopy(base)
    sender, wait, x, y = later
    extra = tx(sender, 99, t + wait, position=(x, y, 0.0))
    other.transmit(extra, SIZE, {j for j in IDS if j != sender}, {**PLACES, sender: at(x, y)})
    times = [0.1 * k for k in range(1, 100)]

    def before_first(batches: list[list]) -> list[list]:
        return [[r for r in b if r.seq != 99 and (first is None or r.arrival < first)] for b in batches]

    assert before_first(other.ahead(times)) == before_first(base.ahead(times))


@settings(max_examples=40, deadline=None)
@given(packets=sends, t=st.floats(0.0, 6.0))
def test_the_first_spoilable_arrival_is_the_first_after_t_and_only_with_collisions_or_half_duplex(packets, t) -> None:
    channel = channel_with(packets, SLOW, 0.0)
    after = [arrival for arrival, *_ in channel._in_flight if arrival > t + 1e-9]
    assert channel.first_spoilable(t) == min(after, default=None)
    assert channel_with(packets, ModemParams(bitrate=240.0, preamble=0.1), 0.0).first_spoilable(t) is None
