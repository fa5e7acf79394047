"""The modem and the MAC, pure (no Zenoh): the wire frame, airtime, half duplex, collisions, TDMA, the event-triggered
policy, link statistics and bursty loss in the channel.

Timing tests run on a fine step grid through the same protocol the broker uses: the transmissions of an instant go
into the channel, then whatever has arrived by the next instant is delivered. Every run checks that each directed
link's books balance (sent = delivered + dropped).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np
import pytest

from comms.broker.stats import LinkStats
from comms.channel.channel import Channel, ChannelParams, LinkParams
from comms.channel.loss import Bernoulli, GilbertElliott
from comms.channel.modem import PRESETS, ModemParams, modem
from comms.records.records import Disturbances, Kinematics, LinkEvent, Reception, Transmission
from comms.records.wire import SIZE, decode_coordination, encode_coordination
from supervisor.config.fleet import initial_state, vehicle_config
from supervisor.config.scenario import load_scenario
from vehicles.estimates import Hold, NeighbourEstimate, Reference
from vehicles.runtime import NodeState, Radio, node_step
from vehicles.transmission import EventTriggeredPolicy, PeriodicPolicy, Tdma

C = 1500.0
PAPER = Path(__file__).resolve().parent.parent / "configs" / "paper.toml"
Position = tuple[float, float, float]


def message(
    sender: int,
    seq: int = 1,
    t: float = 0.0,
    gamma: float = 0.5,
    gamma_dot: float = 1.0,
    position: Position = (0.0, 0.0, 0.0),
) -> Transmission:
    return Transmission(sender, seq, t, gamma, gamma_dot, position, (0.0, 0.0, 0.0))


def still(where: Mapping[int, Position]) -> dict[int, Kinematics]:
    return {i: Kinematics(np.array(p, dtype=float), np.zeros(3)) for i, p in where.items()}


def balance(events: Iterable[LinkEvent]) -> dict[tuple[int, int], Counter[str]]:
    """Per directed link: sent, delivered and dropped counts; fails unless sent = delivered + dropped on each."""
    books: dict[tuple[int, int], Counter[str]] = {}
    for e in events:
        books.setdefault((e.sender, e.receiver), Counter())[e.kind] += 1
    for link, kinds in books.items():
        assert kinds["sent"] == kinds["delivered"] + kinds["dropped"] > 0, (link, kinds)
    return books


Send = tuple[float, int, set[int]]  # (time, sender, receivers)


def simulate(
    params: ChannelParams, where: Mapping[int, Position], sends: Sequence[Send], dt: float = 0.01, seed: int = 0
) -> tuple[list[Reception], list[LinkEvent]]:
    """Static vehicles at `where`; each (t, sender, receivers) transmits a 10-byte packet at t (on the dt grid).

    Runs until everything has landed, then closes the books; receptions and every link event, in order."""
    channel = Channel(params, seed)
    everyone = still(where)
    at_step: dict[int, list[tuple[int, set[int]]]] = {}
    for t, sender, receivers in sends:
        at_step.setdefault(round(t / dt), []).append((sender, receivers))
    seqs: Counter[int] = Counter()
    got: list[Reception] = []
    events: list[LinkEvent] = []
    steps = max(at_step) + round(20.0 / dt)  # 20 s: far more than any flight + airtime here
    for k in range(steps):
        t = k * dt
        for sender, receivers in sorted(at_step.get(k, []), key=lambda item: item[0]):
            seqs[sender] += 1
            sent = message(sender, seqs[sender], t, position=where[sender])
            events += channel.transmit(sent, 10, receivers, everyone)
        arrived, delivered = channel.deliver(t + dt)
        got += arrived
        events += delivered
    events += channel.flush(steps * dt)
    balance(events)
    return got, events


def fate(events: Iterable[LinkEvent], sender: int, receiver: int) -> list[str]:
    """What became of each packet on one link: 'delivered' or the drop reason."""
    return [
        "delivered" if e.kind == "delivered" else str(e.reason)
        for e in events
        if (e.sender, e.receiver) == (sender, receiver) and e.kind != "sent"
    ]


# --- the wire frame ---------------------------------------------------------------------------------------------


def test_wire_frame_round_trips_in_15_bytes():
    sent = Transmission(200, 1234, 98.765, 123.456789, -0.987654321, (1.0, 2.0, 3.0), (0.1, 0.2, 0.3))
    data = encode_coordination(sent)
    assert SIZE == 15 and len(data) == 15
    got = decode_coordination(data)
    assert (got.sender, got.seq, got.t) == (200, 1234, 98.765)
    assert got.gamma == float(np.float32(123.456789)) and got.gamma_dot == float(np.float32(-0.987654321))
    again = message(200, seq=1234, t=98.765, gamma=got.gamma, gamma_dot=got.gamma_dot)
    assert decode_coordination(encode_coordination(again)) == got  # float32 values travel exactly


def test_wire_frame_layout_is_little_endian_sender_seq_milliseconds_gamma_gamma_dot():
    data = encode_coordination(message(7, seq=0x0102, t=0.003, gamma=1.0, gamma_dot=-2.0))
    assert data[0] == 7
    assert data[1:3] == b"\x02\x01"
    assert data[3:7] == (3).to_bytes(4, "little")
    assert data[7:11] == np.float32(1.0).tobytes() and data[11:15] == np.float32(-2.0).tobytes()


def test_float32_rounding_of_gamma_is_bounded():
    rng = np.random.default_rng(1)
    values = np.concatenate([rng.uniform(-400.0, 400.0, 2000), rng.uniform(-1.0, 1.0, 500), [0.1, 131.9348065, 400.0]])
    rounded = 0
    for gamma in values.tolist():
        got = decode_coordination(encode_coordination(message(1, gamma=gamma, gamma_dot=gamma / 7.0)))
        assert abs(got.gamma - gamma) <= 1e-4 * abs(gamma)
        assert abs(got.gamma - gamma) <= 2.0**-24 * abs(gamma)  # float32: half an ulp, 24-bit significand
        assert abs(got.gamma_dot - gamma / 7.0) <= 2.0**-24 * abs(gamma / 7.0)
        assert abs(got.gamma - gamma) <= 2.5e-5 or abs(gamma) > 400.0  # the module's claim: 1e-4 is resolved at 400
        rounded += got.gamma != gamma
    assert rounded > len(values) * 0.9  # it is float32, not float64


@pytest.mark.parametrize(
    ("seq", "wrapped"), [(0, 0), (1, 1), (65535, 65535), (65536, 0), (65537, 1), (3 * 65536 + 7, 7)]
)
def test_seq_wraps_at_65536(seq, wrapped):
    assert decode_coordination(encode_coordination(message(1, seq=seq))).seq == wrapped


@pytest.mark.parametrize(("t", "decoded"), [(0.30000000000000004, 0.3), (1.0004, 1.0), (1.0006, 1.001), (0.0, 0.0)])
def test_time_travels_in_whole_milliseconds(t, decoded):
    assert decode_coordination(encode_coordination(message(1, t=t))).t == decoded


# --- airtime --------------------------------------------------------------------------------------------------------


def test_airtime_is_preamble_plus_bits_over_bitrate():
    assert ModemParams(bitrate=800.0, preamble=0.005).airtime(20) == pytest.approx(0.005 + 8 * 20 / 800, rel=1e-15)
    assert ModemParams(bitrate=80.0).airtime(32) == pytest.approx(3.2, rel=1e-15)
    assert ModemParams(bitrate=80.0, preamble=0.5).airtime(1) == pytest.approx(0.6, rel=1e-15)
    assert ModemParams(preamble=0.25).airtime(1000) == 0.25  # no bitrate: the data take no time
    assert ModemParams().airtime(1000) == 0.0


@pytest.mark.parametrize(("size", "on_air"), [(20, 32), (16, 16), (17, 32), (1, 16), (0, 16), (48, 48), (49, 64)])
def test_packets_are_padded_to_whole_frames(size, on_air):
    radio = ModemParams(bitrate=800.0, preamble=0.005, frame_bytes=16)
    assert radio.on_air_bytes(size) == on_air
    assert radio.airtime(size) == pytest.approx(0.005 + 8 * on_air / 800.0, rel=1e-15)
    assert ModemParams(bitrate=800.0).on_air_bytes(size) == size  # no frames: no padding


def test_presets():
    rate0 = PRESETS["whoi_micromodem_rate0"]
    assert rate0.airtime(32) == pytest.approx(3.2, rel=1e-15)  # one 32-byte frame at 80 bit/s
    assert rate0.airtime(SIZE) == pytest.approx(3.2, rel=1e-15)  # the 15-byte frame is padded to 32
    assert rate0.half_duplex and rate0.collisions and rate0.max_bytes == 32
    assert PRESETS["unet_800"].airtime(SIZE) == pytest.approx(0.005 + 8 * 16 / 800, rel=1e-15)
    assert PRESETS["unet_2400"].airtime(SIZE) == pytest.approx(0.005 + 8 * 64 / 2400, rel=1e-15)
    assert PRESETS["ideal"].airtime(SIZE) == 0.0 and not PRESETS["ideal"].half_duplex
    relaxed = modem("whoi_micromodem_rate0", half_duplex=False, bitrate=None)  # None leaves the preset's value
    assert not relaxed.half_duplex and relaxed.collisions and relaxed.bitrate == 80.0


def test_the_channel_charges_the_modem_airtime():
    params = ChannelParams(sound_speed=C, modem=PRESETS["whoi_micromodem_rate0"])
    got, events = simulate(params, {1: (0.0, 0.0, 0.0), 2: (1500.0, 0.0, 0.0)}, [(2.0, 1, {2})])
    assert [r.arrival for r in got] == [pytest.approx(2.0 + 1.0 + 3.2)]  # flight 1 s, then 3.2 s on air
    assert [e.delay for e in events if e.kind == "delivered"] == [pytest.approx(4.2)]


# --- half duplex ----------------------------------------------------------------------------------------------------

PAIR = {1: (0.0, 0.0, 0.0), 2: (150.0, 0.0, 0.0)}  # 0.1 s of flight


def one_second_packets(half_duplex: bool = False, collisions: bool = False) -> ChannelParams:
    """10-byte packets at 80 bit/s: exactly 1 s on air."""
    return ChannelParams(sound_speed=C, modem=ModemParams(bitrate=80.0, half_duplex=half_duplex, collisions=collisions))


def test_half_duplex_modem_cannot_hear_while_it_transmits():
    # 1 sends on [0, 1); 2's packet reaches 1 on [0.6, 1.6): 1 was still transmitting. 1's reaches 2 on [0.1, 1.1),
    # while 2 transmits on [0.5, 1.5): lost too.
    _, events = simulate(one_second_packets(half_duplex=True), PAIR, [(0.0, 1, {2}), (0.5, 2, {1})])
    assert fate(events, 2, 1) == ["half_duplex"] and fate(events, 1, 2) == ["half_duplex"]
    (drop,) = [e for e in events if (e.sender, e.kind) == (2, "dropped")]
    assert drop.t == pytest.approx(1.6)  # decided at the end of the packet


def test_a_full_duplex_modem_hears_the_same_packets():
    got, events = simulate(one_second_packets(half_duplex=False), PAIR, [(0.0, 1, {2}), (0.5, 2, {1})])
    assert fate(events, 2, 1) == ["delivered"] and fate(events, 1, 2) == ["delivered"]
    assert [(r.sender, r.arrival) for r in got] == [(1, pytest.approx(1.1)), (2, pytest.approx(1.6))]


def test_half_duplex_is_decided_per_receiver():
    # 2 sends at 1.0: its packet reaches 1 on [1.1, 2.1), after 1 is done; 1's reaches 2 on [0.1, 1.1), over 2's start.
    _, events = simulate(one_second_packets(half_duplex=True), PAIR, [(0.0, 1, {2}), (1.0, 2, {1})])
    assert fate(events, 2, 1) == ["delivered"] and fate(events, 1, 2) == ["half_duplex"]
    _, events = simulate(one_second_packets(half_duplex=True), PAIR, [(0.0, 1, {2}), (1.2, 2, {1})])
    assert fate(events, 2, 1) == ["delivered"] and fate(events, 1, 2) == ["delivered"]


# --- collisions -------------------------------------------------------------------------------------------------------

STAR = {1: (0.0, 0.0, 0.0), 2: (150.0, 0.0, 0.0), 3: (0.0, 300.0, 0.0)}  # 2 and 3 hear 1: 0.1 s and 0.2 s of flight


@pytest.mark.parametrize("collisions", [True, False])
def test_packets_overlapping_at_a_receiver_are_both_lost(collisions):
    got, events = simulate(one_second_packets(collisions=collisions), STAR, [(0.0, 2, {1}), (0.5, 3, {1})])
    # at 1: 2's packet on [0.1, 1.1), 3's on [0.7, 1.7)
    expected = "collision" if collisions else "delivered"
    assert fate(events, 2, 1) == [expected] and fate(events, 3, 1) == [expected]
    assert len(got) == (0 if collisions else 2)


@pytest.mark.parametrize(
    ("first", "second", "gap", "expected"),
    [
        (2, 3, 0.89, "collision"),  # 3's packet reaches 1 at 1.09, before 2's ends at 1.1
        (2, 3, 0.91, "delivered"),
        (3, 2, 1.09, "collision"),  # 2's packet reaches 1 at 1.19, before 3's ends at 1.2
        (3, 2, 1.11, "delivered"),  # more than airtime + flight-time difference: clear in either order
        (2, 3, 1.11, "delivered"),
    ],
)
def test_packets_spaced_by_more_than_airtime_and_flight_difference_do_not_collide(first, second, gap, expected):
    _, events = simulate(one_second_packets(collisions=True), STAR, [(0.0, first, {1}), (gap, second, {1})])
    assert fate(events, 2, 1) == [expected] and fate(events, 3, 1) == [expected]


def test_a_non_neighbour_transmission_collides_too():
    """4 is no neighbour of 1 (it talks to 5) but its packet is in the water at 1: everyone counts."""
    where = {**STAR, 4: (0.0, -150.0, 0.0), 5: (0.0, -1650.0, 0.0)}
    _, events = simulate(one_second_packets(collisions=True), where, [(0.0, 2, {1}), (0.3, 4, {5})])
    assert fate(events, 2, 1) == ["collision"]  # at 1: 2's on [0.1, 1.1), 4's on [0.4, 1.4)
    assert {(e.sender, e.receiver) for e in events if e.kind == "sent"} == {(2, 1), (4, 5)}
    _, alone = simulate(one_second_packets(collisions=True), where, [(0.0, 2, {1})])
    assert fate(alone, 2, 1) == ["delivered"]


def test_a_lost_packet_still_fills_the_water():
    params = ChannelParams(
        sound_speed=C,
        modem=ModemParams(bitrate=80.0, collisions=True),
        links={(2, 1): LinkParams(loss=Bernoulli(1.0))},
    )
    _, events = simulate(params, STAR, [(0.0, 2, {1}), (0.5, 3, {1})])
    assert fate(events, 2, 1) == ["loss"] and fate(events, 3, 1) == ["collision"]


def test_books_balance_in_a_busy_mixed_run():
    """Half duplex, collisions, loss and jitter all at once, 5 vehicles sending at random: every link's books close."""
    rng = np.random.default_rng(3)
    where = {i: (float(x), float(y), 0.0) for i, (x, y) in enumerate(rng.uniform(-500, 500, (5, 2)), start=1)}
    times = np.sort(rng.uniform(0.0, 30.0, 60)).tolist()
    senders = rng.integers(1, 6, 60).tolist()
    sends = [(round(t, 2), s, {j for j in where if j != s}) for t, s in zip(times, senders, strict=True)]
    radio = ModemParams(bitrate=400.0, half_duplex=True, collisions=True)
    params = ChannelParams(sound_speed=C, modem=radio, jitter=0.1, loss=Bernoulli(0.2))
    _, events = simulate(params, where, sends)
    books = balance(events)
    reasons = Counter(e.reason for e in events if e.kind == "dropped")
    assert {"loss", "half_duplex", "collision"} <= set(reasons)
    assert sum(k["sent"] for k in books.values()) == 4 * len(sends)


# --- TDMA -----------------------------------------------------------------------------------------------------------


def test_tdma_allows_each_vehicle_only_at_its_slot_starts_on_the_step_grid():
    dt, tdma = 0.1, Tdma(0.3, (2, 1, 3))  # slots of 3 steps, a frame of 9
    allowed = {i: [k for k in range(2000) if tdma.may_transmit(i, k * dt, dt)] for i in (1, 2, 3)}
    assert allowed[2] == list(range(0, 2000, 9))
    assert allowed[1] == list(range(3, 2000, 9))
    assert allowed[3] == list(range(6, 2000, 9))
    assert not any(tdma.may_transmit(i, t, dt) for i in (1, 2, 3) for t in (0.36, 0.67, 1.13))  # off the grid


def tdma_run(n: int, seed: int, slot_steps: int | None, dt: float = 0.1, duration: float = 500.0) -> Counter[str]:
    """n static vehicles within 1 km of each other, all neighbours, each wanting to transmit every step; Tdma decides.

    slot_steps None: the shortest slot on the grid that holds a packet's airtime plus the longest flight.
    Returns the counts of outcomes over every link ('sent', 'delivered', and drop reasons)."""
    rng = np.random.default_rng(seed)
    radio = modem("unet_800")  # 15 bytes in one 16-byte frame: 0.165 s
    airtime = radio.airtime(SIZE)
    directions = rng.normal(size=(n, 3))
    points = directions / np.linalg.norm(directions, axis=1)[:, None] * 500.0 * rng.uniform(0, 1, (n, 1)) ** (1 / 3)
    ids = [int(i) for i in rng.permutation(np.arange(1, n + 1))]
    everyone = {i: Kinematics(points[k], np.zeros(3)) for k, i in enumerate(sorted(ids))}
    flight = max(
        float(np.linalg.norm(np.subtract(a.position, b.position))) / C
        for a in everyone.values()
        for b in everyone.values()
    )
    assert 0.0 < flight <= 1000.0 / C
    steps = slot_steps if slot_steps is not None else math.ceil((airtime + flight) / dt)
    tdma = Tdma(steps * dt, tuple(ids))
    assert (tdma.slot >= airtime + flight) == (slot_steps is None)
    channel = Channel(ChannelParams(sound_speed=C, modem=radio, loss=Bernoulli(0.0)), seed)
    stats = LinkStats(sorted(ids), window=2 * tdma.slot * n)
    seqs: Counter[int] = Counter()
    sent_at: dict[int, list[int]] = {i: [] for i in ids}
    events: list[LinkEvent] = []
    total = round(duration / dt)
    for k in range(total):
        t = k * dt
        for i in sorted(ids):
            if tdma.may_transmit(i, t, dt):
                seqs[i] += 1
                sent_at[i].append(k)
                p = everyone[i].position
                tx = Transmission(i, seqs[i], t, t, 1.0, (float(p[0]), float(p[1]), float(p[2])), (0.0, 0.0, 0.0))
                events += channel.transmit(tx, SIZE, set(ids) - {i}, everyone)
        events += channel.deliver(t + dt)[1]
    events += channel.deliver(total * dt + 10.0)[1]  # let the last packets land
    events += channel.flush(total * dt + 10.0)
    stats.add(events)
    books = balance(events)
    assert len(books) == n * (n - 1)
    for i in ids:  # exactly one transmission per frame, at the vehicle's slot start
        assert np.all(np.diff(sent_at[i]) == steps * n) and sent_at[i][0] == ids.index(i) * steps
    if slot_steps is None:
        assert stats.delivered_connectivity(total * dt) == pytest.approx(n)  # complete graph: lambda_2 = n
    out: Counter[str] = Counter()
    for e in events:
        out[e.kind if e.kind != "dropped" else str(e.reason)] += 1
    return out


@pytest.mark.parametrize(("n", "seed"), [(3, 11), (4, 12), (5, 13), (6, 14)])
def test_tdma_with_a_long_enough_slot_delivers_every_packet(n, seed):
    outcome = tdma_run(n, seed, slot_steps=None)
    assert outcome["sent"] > 500 // n  # plenty of packets
    assert outcome["collision"] == 0 and outcome["half_duplex"] == 0
    assert outcome["delivered"] == outcome["sent"]


@pytest.mark.parametrize(("n", "seed"), [(3, 11), (6, 14)])
def test_tdma_with_a_slot_shorter_than_the_airtime_collides(n, seed):
    outcome = tdma_run(n, seed, slot_steps=1, duration=100.0)  # 0.1 s slots for 0.165 s packets
    assert outcome["collision"] > 0
    assert outcome["delivered"] < outcome["sent"]


def test_node_step_waits_for_its_tdma_slot():
    """A periodic wish (every 1 s) outside the slot waits for it: vehicle 1 owns slots starting at 0.3 + 0.9 m."""
    scenario = load_scenario(PAPER)
    cfg = vehicle_config(scenario, 1)
    node = NodeState(initial_state(scenario, cfg))
    radio = Radio(PeriodicPolicy(1.0), Tdma(0.3, (2, 1, 3)))
    dt = scenario.scenario.step
    sent: list[tuple[int, int]] = []
    pending: list[bool] = []
    for k in range(25):
        node, out = node_step(cfg, radio, node, k * dt, dt, [], scenario.neighbours(1), Disturbances())
        if out.transmission is not None:
            sent.append((k, out.transmission.seq))
            assert out.transmission.t == k * dt
        pending.append(node.pending)
    # wants at 0 -> slot at 0.3; wants again 1 s later (1.3) -> next slot at 2.1
    assert sent == [(3, 1), (21, 2)]
    assert pending[:3] == [True] * 3 and not pending[3] and pending[13:21] == [True] * 8 and not pending[21]


# --- the event-triggered policy ---------------------------------------------------------------------------------------

DT = 0.1
LAST = NeighbourEstimate(gamma=0.0, gamma_dot=1.0, stamp=0.0)  # predicted: gamma = t


def own(gamma: float, t: float) -> NeighbourEstimate:
    return NeighbourEstimate(gamma, 1.0, t)


def test_event_triggered_transmits_first_then_only_when_the_prediction_fails():
    policy = EventTriggeredPolicy(threshold=0.1)
    assert policy.due(0.0, DT, own(0.0, 0.0), None)
    assert not policy.due(5.0, DT, own(5.0, 5.0), LAST)  # exactly as predicted
    assert not policy.due(5.0, DT, own(5.09, 5.0), LAST)
    assert policy.due(5.0, DT, own(5.11, 5.0), LAST)
    assert policy.due(5.0, DT, own(4.89, 5.0), LAST)  # either side


def test_event_triggered_uses_its_predictor():
    reference = EventTriggeredPolicy(threshold=0.1, predictor=Reference(), v_r=0.5)  # predicts gamma = 0.5 t
    hold = EventTriggeredPolicy(threshold=0.1, predictor=Hold())  # predicts gamma = 0
    first_order = EventTriggeredPolicy(threshold=0.1)  # predicts gamma = t
    assert not reference.due(4.0, DT, own(2.05, 4.0), LAST) and first_order.due(4.0, DT, own(2.05, 4.0), LAST)
    assert not hold.due(4.0, DT, own(0.05, 4.0), LAST) and reference.due(4.0, DT, own(0.05, 4.0), LAST)


def test_event_triggered_respects_min_interval_and_heartbeat():
    policy = EventTriggeredPolicy(threshold=0.1, min_interval=2.0, heartbeat=3.0)
    assert not policy.due(1.9, DT, own(10.0, 1.9), LAST)  # far off, but too soon
    assert policy.due(2.0, DT, own(10.0, 2.0), LAST)
    assert not policy.due(2.9, DT, own(2.9, 2.9), LAST)  # as predicted, heartbeat not yet due
    assert policy.due(3.0, DT, own(3.0, 3.0), LAST)  # as predicted, but the heartbeat is
    quiet = EventTriggeredPolicy(threshold=0.1)
    assert not quiet.due(1000.0, DT, own(1000.0, 1000.0), LAST)  # no heartbeat: silence while the prediction holds


def test_event_triggered_threshold_decays():
    policy = EventTriggeredPolicy(threshold=0.1, threshold_decay=1.0, decay_rate=0.5)
    assert policy.h(0.0) == pytest.approx(1.1, rel=1e-15)
    assert policy.h(2.0) == pytest.approx(0.1 + math.exp(-1.0), rel=1e-15)
    assert policy.h(100.0) == pytest.approx(0.1, rel=1e-9)
    # the same 0.5 miss is tolerated early (h(1) = 0.707) and not later (h(2) = 0.468)
    assert not policy.due(1.0, DT, own(1.5, 1.0), LAST)
    assert policy.due(2.0, DT, own(2.5, 2.0), LAST)
    assert not policy.due(20.0, DT, own(20.1, 20.0), LAST) and policy.due(20.0, DT, own(20.11, 20.0), LAST)


def test_event_triggered_keeps_the_neighbours_prediction_within_the_threshold():
    """Along a wavy gamma(t), stepping the policy: after every step, what the neighbours predict is within h(t)."""
    policy = EventTriggeredPolicy(threshold=0.05, threshold_decay=0.5, decay_rate=0.1)
    last: NeighbourEstimate | None = None
    sent = 0
    for k in range(2000):
        t = k * DT
        now = NeighbourEstimate(t + 0.3 * math.sin(0.5 * t), 1.0 + 0.15 * math.cos(0.5 * t), t)
        if policy.due(t, DT, now, last):
            last, sent = now, sent + 1
        assert last is not None
        assert abs(now.gamma - (last.gamma + last.gamma_dot * (t - last.stamp))) <= policy.h(t)
    assert 10 < sent < 1000  # far fewer messages than steps, but some


# --- link statistics ------------------------------------------------------------------------------------------------


def test_link_stats_count_by_cause_with_delays():
    stats = LinkStats([1, 2, 3], window=10.0)
    stats.add([LinkEvent(float(s), 1, 2, s, "sent") for s in range(1, 6)])
    stats.add(
        [
            LinkEvent(1.2, 1, 2, 1, "delivered", delay=0.2),
            LinkEvent(2.6, 1, 2, 2, "delivered", delay=0.6),
            LinkEvent(3.0, 1, 2, 3, "dropped", reason="loss"),
            LinkEvent(4.9, 1, 2, 4, "dropped", reason="collision"),
            LinkEvent(5.9, 1, 2, 5, "dropped", reason="collision"),
            LinkEvent(0.0, 2, 1, 1, "sent"),
            LinkEvent(0.0, 2, 1, 1, "dropped", reason="burst"),
        ]
    )
    assert stats.books[(1, 2)].counts(1, 2).to_message() == {
        "sender": 1,
        "receiver": 2,
        "sent": 5,
        "delivered": 2,
        "dropped": {"collision": 2, "loss": 1},
        "mean_delay": pytest.approx(0.4),
        "max_delay": 0.6,
    }
    assert stats.books[(2, 1)].counts(2, 1).to_message()["dropped"] == {"burst": 1}
    assert "mean_delay" not in stats.books[(2, 1)].counts(2, 1).to_message()  # none delivered: left out
    links = stats.snapshot(6.0)["links"]
    assert isinstance(links, list)
    assert [(link["sender"], link["receiver"]) for link in links] == [(1, 2), (2, 1)]


def delivered(t: float, sender: int, receiver: int) -> LinkEvent:
    return LinkEvent(t, sender, receiver, 1, "delivered", delay=0.1)


def test_delivered_connectivity_is_zero_when_a_needed_link_delivered_nothing():
    stats = LinkStats([1, 2, 3], window=10.0)  # the graph 2 - 1 - 3
    stats.add([delivered(1.0 + 0.1 * k, 1, 2) for k in range(50)] + [delivered(1.0 + 0.1 * k, 2, 1) for k in range(50)])
    stats.add([LinkEvent(1.0, 1, 3, 1, "sent"), LinkEvent(1.0, 1, 3, 1, "dropped", reason="loss")])
    assert stats.delivered_connectivity(7.0) == pytest.approx(0.0, abs=1e-12)


def test_delivered_connectivity_is_the_graphs_when_every_link_delivered():
    path = LinkStats([1, 2, 3], window=10.0)
    path.add([delivered(1.0, 1, 2), delivered(2.0, 3, 1)])  # one direction is enough for an edge
    assert path.delivered_connectivity(5.0) == pytest.approx(1.0)  # path on 3 nodes: 2 - 2 cos(pi / 3)
    ring = LinkStats([1, 2, 3, 4, 5], window=10.0)
    ring.add([delivered(1.0, i, i % 5 + 1) for i in range(1, 6)] + [delivered(1.5, 9, 1)])  # 9: not in the fleet
    assert ring.delivered_connectivity(5.0) == pytest.approx(2.0 - 2.0 * math.cos(2.0 * math.pi / 5.0))
    full = LinkStats([1, 2, 3, 4], window=10.0)
    full.add([delivered(1.0, i, j) for i in range(1, 5) for j in range(1, 5) if i != j])
    assert full.delivered_connectivity(5.0) == pytest.approx(4.0)  # complete graph K_4


def test_delivered_connectivity_forgets_what_left_the_window():
    stats = LinkStats([1, 2, 3], window=10.0)
    stats.add([delivered(0.5, 1, 2), delivered(3.0, 1, 3)])
    assert stats.delivered_connectivity(10.4) == pytest.approx(1.0)  # window (0.4, 10.4]: both links
    assert stats.delivered_connectivity(10.5) == pytest.approx(0.0, abs=1e-12)  # (0.5, 10.5]: 1 - 2 is gone
    stats.add([delivered(11.0, 2, 1)])
    assert stats.delivered_connectivity(11.0) == pytest.approx(1.0)


# --- Gilbert-Elliott in the channel -------------------------------------------------------------------------------


def test_gilbert_elliott_loss_in_the_channel_is_bursty_at_its_long_run_rate():
    ge = GilbertElliott(0.2, 5.0)
    channel = Channel(ChannelParams(sound_speed=C, loss=ge), seed=17)
    everyone = still({1: (0.0, 0.0, 0.0), 2: (300.0, 0.0, 0.0), 3: (0.0, 600.0, 0.0)})
    n = 20_000
    events: list[LinkEvent] = []
    for seq in range(1, n + 1):
        events += channel.transmit(message(1, seq, seq * 0.1), SIZE, {2, 3}, everyone)
    events += channel.deliver(n * 0.1 + 10.0)[1]
    books = balance(events)
    assert {e.reason for e in events if e.kind == "dropped"} == {"burst"}
    rho = 1.0 - ge.p - ge.r  # lag-1 correlation of the chain: inflates the variance of the mean
    sigma = math.sqrt(0.2 * 0.8 / n * (1 + rho) / (1 - rho))
    for receiver in (2, 3):
        assert books[(1, receiver)]["sent"] == n
        lost = np.zeros(n, dtype=bool)
        lost[[e.seq - 1 for e in events if e.kind == "dropped" and e.receiver == receiver]] = True
        assert abs(lost.mean() - 0.2) < 4 * sigma
        edges = np.diff(np.concatenate(([0], lost.astype(int), [0])))
        runs = np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)
        sigma_run = math.sqrt(1 - ge.r) / ge.r / math.sqrt(len(runs))
        assert abs(runs.mean() - 5.0) < 4 * sigma_run  # bursts of 5 on average, not Bernoulli's 1.25


# --- what a faulty vehicle broadcasts (runtime.node_step with disturbances) -------------------------------------------


def broadcasts(dist_at: Callable[[int], Disturbances], steps: int = 12) -> list[tuple[float, Transmission]]:
    """(true gamma at t, transmission) of vehicle 1 of the paper, transmitting every step, under dist_at(k)."""
    scenario = load_scenario(PAPER)
    cfg = vehicle_config(scenario, 1)
    node, dt, out = NodeState(initial_state(scenario, cfg)), scenario.scenario.step, []
    for k in range(steps):
        gamma = node.vehicle.gamma
        node, step = node_step(cfg, Radio(PeriodicPolicy(dt)), node, k * dt, dt, [], [2, 3], dist_at(k))
        assert step.transmission is not None
        out.append((gamma, step.transmission))
    return out


def test_a_gamma_offset_shifts_what_is_sent_and_nothing_else():
    clean = broadcasts(lambda k: Disturbances())
    offset = broadcasts(lambda k: Disturbances(gamma_offset=0.7))
    for (gamma, tx), (_, plain) in zip(offset, clean, strict=True):
        assert tx.gamma == pytest.approx(gamma + 0.7, abs=1e-12) and plain.gamma == gamma
        assert tx.gamma_dot == plain.gamma_dot and tx.data_time == plain.data_time


def test_a_frozen_gamma_sensor_repeats_the_reading_it_stuck_at():
    sent = broadcasts(lambda k: Disturbances(gamma_freeze=3 <= k < 8))
    frozen = [tx.gamma for _, tx in sent[3:8]]
    assert frozen == [sent[3][0]] * 5  # the reading of step 3, five times
    assert [tx.gamma for _, tx in sent[8:]] == [gamma for gamma, _ in sent[8:]]  # live again
    assert len({gamma for gamma, _ in sent[3:8]}) == 5  # while the true gamma moved on


def test_a_skewed_clock_stamps_the_data_with_its_own_time():
    for k, (_, tx) in enumerate(broadcasts(lambda k: Disturbances(clock_offset=0.25))):
        assert tx.t == pytest.approx(k * 0.1) and tx.data_time == pytest.approx(k * 0.1 + 0.25)


def test_a_late_older_message_never_replaces_a_newer_estimate():
    from vehicles.agent import receive

    scenario = load_scenario(PAPER)
    state = initial_state(scenario, vehicle_config(scenario, 1))
    state = receive(state, 2, NeighbourEstimate(5.0, 1.0, 2.0))
    assert receive(state, 2, NeighbourEstimate(4.0, 1.0, 1.5)) is state  # reordered: older, ignored
    assert receive(state, 2, NeighbourEstimate(4.0, 1.0, 2.0)) is state  # same stamp: nothing new
    assert receive(state, 2, NeighbourEstimate(6.0, 1.0, 2.5)).estimates[2].gamma == 6.0
