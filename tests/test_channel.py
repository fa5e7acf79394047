"""The acoustic channel as a pure model: time of flight, airtime, the seeded Channel and the broker's per-step work."""

from __future__ import annotations

import math
import subprocess
import sys
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from comms.broker.broker_core import BrokerCore
from comms.broker.stats import LinkStats
from comms.channel.acoustics import airtime, time_of_flight
from comms.channel.channel import ARRIVAL_SLACK, Channel, ChannelParams
from comms.channel.loss import Bernoulli
from comms.channel.modem import ModemParams
from comms.records.records import FloatArray, Kinematics, LinkEvent, Reception, Transmission
from comms.records.wire import SIZE, encode_coordination
from supervisor.config.scenario import parse_scenario
from supervisor.errors import ScenarioError

C = 1500.0
ORIGIN = (0.0, 0.0, 0.0)
STILL = (0.0, 0.0, 0.0)


def vec(*xs: float) -> FloatArray:
    return np.array(xs, dtype=float)


def tx(
    sender: int,
    seq: int = 1,
    t: float = 0.0,
    position: tuple[float, float, float] = ORIGIN,
    velocity: tuple[float, float, float] = STILL,
    gamma: float = 0.25,
    gamma_dot: float = 0.75,
) -> Transmission:
    return Transmission(sender, seq, t, gamma, gamma_dot, position, velocity)


def at(x: float, y: float = 0.0, z: float = 0.0, velocity: tuple[float, float, float] = STILL) -> Kinematics:
    return Kinematics(vec(x, y, z), vec(*velocity))


def residual(sender: FloatArray, receiver: FloatArray, velocity: FloatArray, c: float, tau: float) -> float:
    """|p_rx + v tau - p_tx| - c tau: zero for the true time of flight."""
    return float(np.linalg.norm(receiver + velocity * tau - sender)) - c * tau


def send(channel: Channel, message: Transmission, size: int, receivers: Mapping[int, Kinematics]) -> list[LinkEvent]:
    """Transmit to exactly these receivers, the only other vehicles in the water."""
    return channel.transmit(message, size, set(receivers), receivers)


def link_balance(events: Iterable[LinkEvent]) -> dict[tuple[int, int], Counter[str]]:
    books: dict[tuple[int, int], Counter[str]] = {}
    for event in events:
        books.setdefault((event.sender, event.receiver), Counter())[event.kind] += 1
    return books


# --- time of flight ---------------------------------------------------------------------------------------------


def test_time_of_flight_between_static_ends_is_distance_over_c():
    assert time_of_flight(vec(0, 0, 0), vec(300, 400, 0), vec(0, 0, 0), C) == pytest.approx(500 / C, rel=1e-15)
    assert time_of_flight(vec(1, 2, 3), vec(1, 2, 3 - 1500), vec(0, 0, 0), C) == pytest.approx(1.0, rel=1e-15)


def test_time_of_flight_of_coincident_ends_is_zero():
    assert time_of_flight(vec(5, 5, 5), vec(5, 5, 5), vec(0, 0, 0), C) == 0.0
    assert time_of_flight(vec(5, 5, 5), vec(5, 5, 5), vec(1, 2, 0), C) == 0.0


@pytest.mark.parametrize(
    ("velocity", "direction"),
    [
        ((2.0, 0.0, 0.0), +1),  # straight away from the sender
        ((-2.0, 0.0, 0.0), -1),  # straight toward it
        ((1.5, -1.0, 0.5), +1),  # partly away
        ((-1.5, 1.0, -0.5), -1),  # partly toward
        ((0.0, 3.0, 0.0), +1),  # across: the distance still grows
        ((0.0, 0.0, -300.0), +1),  # fast (a fifth of c) and across
    ],
)
def test_time_of_flight_to_a_moving_receiver_solves_its_equation(velocity, direction):
    sender, receiver, v = vec(10.0, -20.0, 5.0), vec(1010.0, -20.0, 5.0), vec(*velocity)
    static = 1000.0 / C
    tau = time_of_flight(sender, receiver, v, C)
    assert tau > 0
    assert abs(residual(sender, receiver, v, C, tau)) <= 1e-12 * C * tau
    assert (tau - static) * direction > 0


def test_time_of_flight_along_the_line_of_sight_has_the_closed_form():
    d, v = 1200.0, 3.0
    assert time_of_flight(vec(0, 0, 0), vec(d, 0, 0), vec(v, 0, 0), C) == pytest.approx(d / (C - v), rel=1e-12)
    assert time_of_flight(vec(0, 0, 0), vec(d, 0, 0), vec(-v, 0, 0), C) == pytest.approx(d / (C + v), rel=1e-12)


def test_time_of_flight_uses_the_sound_speed_given():
    assert time_of_flight(vec(0, 0, 0), vec(1480, 0, 0), vec(0, 0, 0), 1480.0) == pytest.approx(1.0, rel=1e-15)


coordinate = st.integers(-5_000_000, 5_000_000).map(lambda mm: mm / 1000)  # m, on a millimetre grid
speed_component = st.floats(-10.0, 10.0, allow_nan=False)


@settings(max_examples=200, deadline=None, database=None)
@given(
    st.tuples(coordinate, coordinate, coordinate),
    st.tuples(coordinate, coordinate, coordinate),
    st.tuples(speed_component, speed_component, speed_component),
)
def test_time_of_flight_solves_its_equation_for_any_auv_speed(sender, receiver, velocity):
    p_tx, p_rx, v = vec(*sender), vec(*receiver), vec(*velocity)
    distance = float(np.linalg.norm(p_rx - p_tx))
    tau = time_of_flight(p_tx, p_rx, v, C)
    assert tau >= 0
    assert abs(residual(p_tx, p_rx, v, C, tau)) <= 1e-9 * max(distance, 1.0)
    # |v| <= sqrt(3) * 10 m/s: the receiver changes the answer by at most that fraction of c
    assert abs(tau - distance / C) <= distance / C * 20.0 / (C - 20.0) + 1e-12


def test_time_of_flight_is_never_negative_even_for_a_vanishing_distance():
    assert time_of_flight(vec(0, 0, -2.3e-247), vec(0, 0, 0), vec(0, 0, -1), C) >= 0


# --- airtime ----------------------------------------------------------------------------------------------------


def test_airtime_is_bits_over_bitrate():
    assert airtime(32, 80.0) == pytest.approx(3.2, rel=1e-15)
    assert airtime(0, 80.0) == 0.0
    assert airtime(1, 8.0) == pytest.approx(1.0)


def test_airtime_without_a_bitrate_is_zero():
    assert airtime(32, None) == 0.0
    assert airtime(10_000, None) == 0.0


# --- the channel --------------------------------------------------------------------------------------------------


def test_lossless_channel_delivers_every_link_at_airtime_plus_flight():
    channel = Channel(ChannelParams(sound_speed=C, modem=ModemParams(bitrate=80.0)), seed=3)
    receivers = {2: at(1500.0), 3: at(0.0, 3000.0)}  # 1 s and 2 s of flight
    sent = send(channel, tx(1, seq=7, t=10.0), 20, receivers)  # 20 bytes at 80 bit/s: 2 s on air

    assert sent == [LinkEvent(10.0, 1, 2, 7, "sent"), LinkEvent(10.0, 1, 3, 7, "sent")]
    assert channel.deliver(12.999) == ([], [])
    got, events = channel.deliver(13.0)
    assert got == [Reception(2, 1, 7, 10.0, pytest.approx(13.0), 0.25, 0.75)]  # type: ignore[arg-type]
    assert [(e.kind, e.sender, e.receiver, e.seq) for e in events] == [("delivered", 1, 2, 7)]
    assert events[0].t == pytest.approx(13.0) and events[0].delay == pytest.approx(3.0)
    got, events = channel.deliver(100.0)
    assert [(r.receiver, r.arrival) for r in got] == [(3, pytest.approx(14.0))]
    assert events[0].delay == pytest.approx(4.0)
    assert channel.deliver(1e9) == ([], [])
    assert channel.flush(1e9) == []


def test_only_the_receivers_given_are_offered_the_packet():
    channel = Channel(ChannelParams(sound_speed=C), seed=0)
    everyone = {1: at(0.0), 2: at(1500.0), 3: at(0.0, 3000.0), 4: at(10.0)}
    sent = channel.transmit(tx(1, seq=2), 16, {3}, everyone)  # 2 and 4 are in the water, not neighbours
    assert sent == [LinkEvent(0.0, 1, 3, 2, "sent")]
    got, events = channel.deliver(1e9)
    assert [(r.sender, r.receiver) for r in got] == [(1, 3)]
    assert [(e.kind, e.receiver) for e in events] == [("delivered", 3)]


def test_arrival_uses_the_sender_position_and_the_moving_receiver():
    channel = Channel(ChannelParams(sound_speed=C), seed=0)
    sender_at = (100.0, 200.0, -10.0)
    receiver = at(900.0, -400.0, 30.0, velocity=(1.5, 0.5, -0.2))
    send(channel, tx(4, t=2.0, position=sender_at, velocity=(9.0, 9.0, 9.0)), 16, {5: receiver})
    (got,), _ = channel.deliver(10.0)
    expected = 2.0 + time_of_flight(vec(*sender_at), receiver.position, receiver.velocity, C)
    assert got.arrival == pytest.approx(expected, rel=1e-15)
    static = 2.0 + time_of_flight(vec(*sender_at), receiver.position, vec(0, 0, 0), C)
    assert got.arrival != pytest.approx(static, rel=1e-9)  # the receiver's motion is accounted for


def test_jitter_adds_a_delay_within_its_bounds():
    jitter = 0.5
    channel = Channel(ChannelParams(sound_speed=C, jitter=jitter), seed=11)
    n = 2000
    for seq in range(1, n + 1):
        send(channel, tx(1, seq=seq, t=float(seq)), 16, {2: at(1500.0)})
    got, events = channel.deliver(float(n + 10))
    extra = np.array([r.arrival - r.stamp - 1.0 for r in got])
    assert len(got) == n
    assert np.all(extra >= -1e-12) and np.all(extra <= jitter + 1e-12)
    assert extra.std() > 0.1  # it is random, not a constant offset
    assert abs(extra.mean() - jitter / 2) < 4 * jitter / math.sqrt(12 * n)  # uniform: sigma = jitter / sqrt(12)
    assert [e.delay for e in events] == pytest.approx([r.arrival - r.stamp for r in got])


def test_deliver_returns_only_what_has_arrived_in_arrival_order():
    channel = Channel(ChannelParams(sound_speed=C), seed=0)
    # three senders at different distances from receiver 9, transmitting at different times
    send(channel, tx(1, t=0.0, position=(3000.0, 0.0, 0.0)), 16, {9: at(0.0)})  # arrives 2.0
    send(channel, tx(2, t=0.5, position=(0.0, 750.0, 0.0)), 16, {9: at(0.0)})  # arrives 1.0
    send(channel, tx(3, t=1.0, position=(0.0, 0.0, 750.0)), 16, {9: at(0.0)})  # arrives 1.5
    send(channel, tx(4, t=0.0, position=(150.0, 0.0, 0.0)), 16, {9: at(0.0)})  # arrives 0.1

    first, _ = channel.deliver(0.05)
    assert first == []
    early, early_events = channel.deliver(1.5)
    assert [r.sender for r in early] == [4, 2, 3]
    assert [e.sender for e in early_events] == [4, 2, 3]
    assert all(r.arrival <= 1.5 + ARRIVAL_SLACK for r in early)
    late, _ = channel.deliver(10.0)
    assert [r.sender for r in late] == [1]


def test_an_arrival_at_the_sync_instant_counts_up_to_the_rounding_slack():
    channel = Channel(ChannelParams(sound_speed=C), seed=0)
    send(channel, tx(1, t=0.0, position=(150.0, 0.0, 0.0)), 16, {2: at(0.0)})  # arrival 0.1 (rounded)
    send(channel, tx(3, t=0.0, position=(150.0 + 1e-3, 0.0, 0.0)), 16, {2: at(0.0)})  # 0.1 + 6.7e-7 s
    got, _ = channel.deliver(0.1)
    assert [r.sender for r in got] == [1]
    got, _ = channel.deliver(0.1 + 1e-6)
    assert [r.sender for r in got] == [3]


def test_packet_bytes_overrides_the_size_for_airtime():
    fixed = Channel(ChannelParams(sound_speed=C, modem=ModemParams(bitrate=80.0), packet_bytes=32), seed=0)
    encoded = Channel(ChannelParams(sound_speed=C, modem=ModemParams(bitrate=80.0)), seed=0)
    for seq, size in enumerate((10, 1000), start=1):
        send(fixed, tx(1, seq=seq, t=0.0), size, {2: at(1500.0)})
        send(encoded, tx(1, seq=seq, t=0.0), size, {2: at(1500.0)})
    assert [r.arrival for r in fixed.deliver(1e6)[0]] == pytest.approx([1.0 + 3.2, 1.0 + 3.2])
    assert [r.arrival for r in encoded.deliver(1e6)[0]] == pytest.approx([1.0 + 1.0, 1.0 + 100.0])


def test_bernoulli_loss_rate_is_the_configured_one():
    p, n = 0.2, 4000
    channel = Channel(ChannelParams(sound_speed=C, loss=Bernoulli(p)), seed=5)
    events: list[LinkEvent] = []
    for seq in range(1, n + 1):
        events += send(channel, tx(1, seq=seq, t=float(seq)), 16, {2: at(100.0), 3: at(0.0, 100.0)})
    drops = [e for e in events if e.kind == "dropped"]
    links = 2 * n
    assert sum(e.kind == "sent" for e in events) == links
    assert {e.reason for e in drops} == {"loss"}
    assert abs(len(drops) - p * links) <= 4 * math.sqrt(links * p * (1 - p))
    for receiver in (2, 3):  # each directed link on its own, too
        mine = sum(e.receiver == receiver for e in drops)
        assert abs(mine - p * n) <= 4 * math.sqrt(n * p * (1 - p))
    delivered, _ = channel.deliver(1e9)
    assert len(delivered) + len(drops) == links


@pytest.mark.parametrize(("loss", "dropped"), [(0.0, 0), (1.0, 300)])
def test_no_loss_drops_nothing_and_certain_loss_drops_everything(loss, dropped):
    channel = Channel(ChannelParams(sound_speed=C, loss=Bernoulli(loss)), seed=2)
    events: list[LinkEvent] = []
    for seq in range(1, 101):
        events += send(channel, tx(1, seq=seq), 16, {2: at(10.0), 3: at(20.0), 4: at(30.0)})
    assert sum(e.kind == "dropped" for e in events) == dropped
    assert len(channel.deliver(1e9)[0]) == 300 - dropped


FLEET4 = {1: (0.0, 0.0, 0.0), 2: (300.0, 0.0, 0.0), 3: (0.0, 450.0, 0.0), 4: (200.0, 200.0, -50.0)}


def scripted_run(
    seed: int, params: ChannelParams, order: Sequence[int] = (1, 2, 3, 4), round_robin: bool = False
) -> list[object]:
    """Every event and reception of a small, fully connected fleet, then the end of the run.

    Every vehicle transmits every step, or (round_robin) one vehicle per step in turn. `order`: the order in which
    the vehicles are put in the mappings (and sets) given to the channel.
    """
    channel = Channel(params, seed)
    log: list[object] = []
    dt = 0.1
    for k in range(60):
        t = k * dt
        everyone = {j: at(*FLEET4[j], velocity=(1.0, 0.5, 0.0)) for j in order}
        for sender in (1, 2, 3, 4):
            if round_robin and k % 4 != sender - 1:
                continue
            receivers = {j for j in order if j != sender}
            message = tx(sender, seq=k + 1, t=t, position=FLEET4[sender], gamma=t)
            log += channel.transmit(message, 24, receivers, everyone)
        got, events = channel.deliver(t + dt)
        log += [*got, *events]
    log += channel.flush(60 * dt)
    return log


LOSSY = ChannelParams(sound_speed=C, modem=ModemParams(bitrate=400.0), jitter=0.2, loss=Bernoulli(0.3))
# A half-duplex modem that loses overlapping packets: 24 bytes are 0.096 s on air, jitter up to 0.2 s.
CROWDED = ChannelParams(
    sound_speed=C,
    modem=ModemParams(bitrate=2000.0, half_duplex=True, collisions=True),
    jitter=0.2,
    loss=Bernoulli(0.3),
)
RUNS = [pytest.param(LOSSY, False, id="lossy"), pytest.param(CROWDED, True, id="crowded")]


@pytest.mark.parametrize(("params", "round_robin"), RUNS)
def test_same_seed_gives_the_same_events(params, round_robin):
    first = scripted_run(42, params, round_robin=round_robin)
    assert first == scripted_run(42, params, round_robin=round_robin)
    assert len(first) > 100


def test_different_seeds_give_different_drops():
    def drops(seed: int) -> list[tuple[int, int, int]]:
        return [
            (e.sender, e.receiver, e.seq)
            for e in scripted_run(seed, LOSSY)
            if isinstance(e, LinkEvent) and e.reason == "loss"
        ]

    a, b = drops(1), drops(2)
    assert a and b and a != b


@pytest.mark.parametrize(("params", "round_robin"), RUNS)
def test_results_do_not_depend_on_the_order_receivers_are_given_in(params, round_robin):
    reference = scripted_run(7, params, order=(1, 2, 3, 4), round_robin=round_robin)
    assert reference == scripted_run(7, params, order=(4, 3, 2, 1), round_robin=round_robin)
    assert reference == scripted_run(7, params, order=(3, 1, 4, 2), round_robin=round_robin)


def test_a_link_does_not_depend_on_which_other_links_exist():
    def link_1_to_2(receivers: Mapping[int, Kinematics]) -> list[object]:
        channel = Channel(LOSSY, seed=9)
        log: list[object] = []
        for seq in range(1, 200):
            log += [e for e in send(channel, tx(1, seq=seq, t=seq * 0.1), 24, receivers) if e.receiver == 2]
        got, events = channel.deliver(1e6)
        return [*log, *(r for r in got if r.receiver == 2), *(e for e in events if e.receiver == 2)]

    alone = link_1_to_2({2: at(300.0)})
    assert alone == link_1_to_2({2: at(300.0), 3: at(0.0, 450.0), 4: at(9.0, 9.0)})
    assert alone == link_1_to_2({5: at(1.0), 2: at(300.0)})


def test_with_collisions_a_link_depends_on_who_is_in_the_water_not_on_who_is_a_receiver():
    """Interference comes from transmissions, not from links: making 3 a receiver changes nothing on 1 -> 2."""
    everyone = {1: at(0.0), 2: at(300.0), 3: at(0.0, 450.0)}

    def run(receivers: set[int]) -> list[object]:
        channel = Channel(CROWDED, seed=9)
        log: list[object] = []
        for k in range(300):
            t = k * 0.1
            if k % 10 == 0:
                log += [e for e in channel.transmit(tx(1, seq=k + 1, t=t), 24, receivers, everyone) if e.receiver == 2]
            if k % 23 == 0:  # 3 is heard by 2 (so its packets can collide there) but offers nothing to anyone
                channel.transmit(tx(3, seq=k + 1, t=t, position=(0.0, 450.0, 0.0)), 24, set(), everyone)
            got, events = channel.deliver(t + 0.1)
            log += [*(r for r in got if r.receiver == 2), *(e for e in events if e.receiver == 2)]
        return log

    alone = run({2})
    assert alone == run({2, 3})
    reasons = Counter(e.reason for e in alone if isinstance(e, LinkEvent) and e.kind == "dropped")
    assert reasons["collision"] > 0  # 3's packets do spoil some of 1's at 2
    assert sum(isinstance(e, Reception) for e in alone) > 0


@pytest.mark.parametrize(
    ("params", "round_robin", "reasons"),
    [
        pytest.param(LOSSY, False, {"loss", "end_of_run"}, id="lossy"),
        pytest.param(CROWDED, True, {"loss", "half_duplex", "collision", "end_of_run"}, id="crowded"),
    ],
)
def test_every_link_balances_after_the_run_ends(params, round_robin, reasons):
    log = scripted_run(3, params, round_robin=round_robin)
    events = [e for e in log if isinstance(e, LinkEvent)]
    found = Counter(e.reason for e in events if e.kind == "dropped")
    assert set(found) == reasons  # the test exercises every way of dropping
    books = link_balance(events)
    assert len(books) == 12  # every directed link of 4 fully connected vehicles
    for link, kinds in books.items():
        assert kinds["sent"] == kinds["delivered"] + kinds["dropped"] > 0, link
    receptions = [r for r in log if isinstance(r, Reception)]
    assert len(receptions) == sum(kinds["delivered"] for kinds in books.values())


def test_flush_drops_what_is_in_flight_and_empties_the_channel():
    channel = Channel(ChannelParams(sound_speed=C, modem=ModemParams(bitrate=8.0)), seed=0)  # 16 s per 16 bytes
    send(channel, tx(1, seq=3, t=1.0), 16, {2: at(10.0), 3: at(20.0)})
    assert channel.deliver(5.0) == ([], [])
    dropped = channel.flush(5.0)
    assert [(e.kind, e.reason, e.t, e.sender, e.receiver, e.seq) for e in dropped] == [
        ("dropped", "end_of_run", 5.0, 1, 2, 3),
        ("dropped", "end_of_run", 5.0, 1, 3, 3),
    ]
    assert channel.deliver(1e9) == ([], [])
    assert channel.flush(1e9) == []


def test_a_negative_seed_is_refused_before_any_run(paper_text):
    """Seeds are non-negative (numpy's seed sequences need that): the scenario and --seed refuse -1 up front."""
    with pytest.raises(ScenarioError, match=r"scenario\.seed: .*got -1"):
        parse_scenario(paper_text.replace("seed = 0", "seed = -1"), "s.toml")
    done = subprocess.run(
        [sys.executable, "-m", "supervisor.cli", "run", "configs/paper.toml", "--seed", "-1"],
        cwd=Path(__file__).resolve().parent.parent,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2 and "--seed: must be within [0, 18446744073709551615], got -1" in done.stderr


# --- the broker's per-step work ----------------------------------------------------------------------------------

GRAPH = {1: [2, 3], 2: [1], 3: [1]}  # the paper's: 2 - 1 - 3
WHERE: dict[int, tuple[float, float, float]] = {1: (0.0, 0.0, 0.0), 2: (-300.0, 0.0, 0.0), 3: (0.0, 600.0, 0.0)}
FLEET = {i: at(*p) for i, p in WHERE.items()}


LOSSLESS = ChannelParams()


def broker(params: ChannelParams = LOSSLESS, seed: int = 0) -> BrokerCore:
    stats = LinkStats(sorted(GRAPH), window=10.0)
    return BrokerCore(Channel(params, seed), {i: list(js) for i, js in GRAPH.items()}, stats)


def step_transmissions(t: float = 0.0, seq: int = 1) -> list[Transmission]:
    return [tx(i, seq=seq, t=t, position=WHERE[i], gamma=float(i)) for i in (1, 2, 3)]


def links(events: Iterable[LinkEvent], kind: str) -> list[tuple[int, int]]:
    return [(e.sender, e.receiver) for e in events if e.kind == kind]


def test_only_graph_neighbours_receive():
    core = broker()
    sent = core.submit(step_transmissions(), FLEET)
    assert links(sent, "sent") == [(1, 2), (1, 3), (2, 1), (3, 1)]
    batches, delivered = core.deliver(1.0, [1, 2, 3])
    assert sorted(links(delivered, "delivered")) == [(1, 2), (1, 3), (2, 1), (3, 1)]
    assert [r.sender for r in batches[1]] == [2, 3]  # 2 is nearer: 0.2 s before 3's 0.4 s
    assert [r.sender for r in batches[2]] == [1] and [r.sender for r in batches[3]] == [1]
    assert [r.gamma for r in batches[1]] == [2.0, 3.0]


def test_every_vehicle_gets_a_batch_even_an_empty_one():
    core = broker()
    batches, events = core.deliver(0.0, [1, 2, 3])
    assert batches == {1: [], 2: [], 3: []} and events == []
    core.submit([step_transmissions()[1]], FLEET)  # only 2 transmits, and only 1 hears it
    batches, _ = core.deliver(1.0, [1, 2, 3])
    assert [r.sender for r in batches[1]] == [2] and batches[2] == [] and batches[3] == []


def test_a_sender_outside_the_graph_reaches_nobody():
    core = broker()
    assert core.submit([tx(7, position=(5.0, 5.0, 5.0))], FLEET) == []
    assert core.deliver(10.0, [1, 2, 3])[0] == {1: [], 2: [], 3: []}


def test_vehicles_without_kinematics_are_skipped():
    core = broker()
    sent = core.submit(step_transmissions(), {1: FLEET[1], 2: FLEET[2]})  # 3's state did not come
    assert links(sent, "sent") == [(1, 2), (2, 1), (3, 1)]  # 3 still transmits, but nothing is sent to it
    batches, _ = core.deliver(1.0, [1, 2, 3])
    assert batches[3] == [] and [r.sender for r in batches[1]] == [2, 3]


def test_transmissions_are_processed_in_sender_order_whatever_the_input_order():
    params = ChannelParams(jitter=0.05, loss=Bernoulli(0.4))
    forward, backward = broker(params, seed=4), broker(params, seed=4)
    log_f: list[object] = []
    log_b: list[object] = []
    for k in range(30):
        txs = step_transmissions(t=k * 0.1, seq=k + 1)
        log_f += forward.submit(txs, FLEET)
        events = backward.submit(list(reversed(txs)), FLEET)
        assert [e.sender for e in events] == sorted(e.sender for e in events)
        log_b += events
        log_f.append(forward.deliver(k * 0.1 + 0.1, [1, 2, 3]))
        log_b.append(backward.deliver(k * 0.1 + 0.1, [1, 2, 3]))
    assert log_f == log_b
    assert forward.stats.snapshot(3.0) == backward.stats.snapshot(3.0)


def test_the_channel_is_sized_by_the_wire_frame():
    core = broker(ChannelParams(modem=ModemParams(bitrate=80.0)))
    message = step_transmissions()[1]
    assert SIZE == len(encode_coordination(message)) == 15
    core.submit([message], FLEET)
    (got,) = core.deliver(1e6, [1, 2, 3])[0][1]
    expected = 8.0 * 15 / 80.0 + 300.0 / 1500.0  # 1.5 s on air + 0.2 s of flight
    assert got.arrival == pytest.approx(expected, rel=1e-12)


def test_receptions_carry_the_float32_values_of_the_wire_frame():
    core = broker()
    message = tx(2, seq=5, t=0.0, position=WHERE[2], gamma=0.1, gamma_dot=1.0 / 3.0)
    core.submit([message], FLEET)
    (got,) = core.deliver(1.0, [1, 2, 3])[0][1]
    assert got.gamma == float(np.float32(0.1)) and got.gamma != 0.1
    assert got.gamma_dot == float(np.float32(1.0 / 3.0)) and got.gamma_dot != 1.0 / 3.0
    assert (got.sender, got.seq, got.stamp) == (2, 5, 0.0)
    assert message.gamma == 0.1  # what the vehicle sent is left alone


def test_broker_counts_add_up():
    core = broker(ChannelParams(modem=ModemParams(bitrate=2000.0), jitter=0.3, loss=Bernoulli(0.25)), seed=8)
    seen: list[LinkEvent] = []
    for k in range(40):
        seen += core.submit(step_transmissions(t=k * 0.1, seq=k + 1), FLEET)
        seen += core.deliver(k * 0.1 + 0.1, [1, 2, 3])[1]
    seen += core.finish(4.0)
    assert core.counts == dict(Counter(e.kind for e in seen))
    assert core.counts["sent"] == 40 * 4
    assert core.counts["sent"] == core.counts["delivered"] + core.counts["dropped"]
    for link, kinds in link_balance(seen).items():
        assert kinds["sent"] == 40 and kinds["sent"] == kinds["delivered"] + kinds["dropped"], link
        book = core.stats.books[link]
        assert (book.sent, book.delivered, sum(book.dropped.values())) == (40, kinds["delivered"], kinds["dropped"])
    assert core.finish(5.0) == [] and core.counts["sent"] == 160


def test_snapshots_come_once_per_window_and_at_the_end():
    core = broker()
    due = [t for t in (k * 0.5 for k in range(50)) if core.snapshot_due(t) is not None]
    assert due == [10.0, 20.0]  # the first after one full window
    final = core.snapshot_due(24.6, final=True)
    assert final is not None and final["t"] == 24.6 and final["window"] == 10.0
