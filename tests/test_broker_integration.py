"""The comms broker as a real process over localhost Zenoh, with the test playing the supervisor and the vehicles."""

from __future__ import annotations

import contextlib
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import msgspec
import numpy as np
import pytest
import zenoh

from comms.broker.broker import Broker
from comms.bus.bus import Publishers, free_port, open_session
from comms.records.messages import (
    COMMS_ALIVE,
    COMMS_DONE_KEY,
    COMMS_EVENT_KEY,
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    COMMS_STEP_KEY,
    ROOT,
    STOP_KEY,
    SUPERVISOR_ALIVE,
    TICK_KEY,
    Message,
    decode,
    encode,
    parse_batches,
    rx_key,
    rx_message,
    state_key,
    step_message,
    tick_message,
    tx_key,
    tx_message,
)
from comms.records.network import Network
from comms.records.records import Transmission
from supervisor.config.fleet import broker_core
from supervisor.config.scenario import load_scenario
from tests.conftest import RecordingPublishers
from tests.test_messages import assert_valid, first_step
from vehicles.agent import Telemetry
from vehicles.dynamics import Model
from vehicles.report import state_message

pytestmark = pytest.mark.integration

REPO = Path(__file__).resolve().parent.parent
IDS = (1, 2, 3)
START_TIMEOUT = 30.0  # s for the broker process to start and declare its token
TIMEOUT = 10.0  # s for any one expected message
EXIT_TIMEOUT = 5.0  # s for the broker process to exit once told (or once alone)


class Listener:
    """What the test hears on the bus: one queue per key expression, and liveliness changes of the broker."""

    def __init__(self, session: zenoh.Session) -> None:
        self._lock = threading.Lock()
        self._queues: dict[str, queue.Queue[Message]] = {}
        self.comms_alive: queue.Queue[bool] = queue.Queue()
        self._keep = [
            session.declare_subscriber(f"{ROOT}/vehicle/*/rx", self._on_sample),
            session.declare_subscriber(f"{ROOT}/comms/**", self._on_sample),
            session.liveliness().declare_subscriber(COMMS_ALIVE, self._on_token, history=True),
        ]

    def _queue(self, key: str) -> queue.Queue[Message]:
        with self._lock:
            return self._queues.setdefault(key, queue.Queue())

    def _on_sample(self, sample: zenoh.Sample) -> None:
        payload = sample.payload.to_bytes()
        try:
            message = decode(payload)
        except ValueError:
            message = {"undecodable": payload.hex()}
        self._queue(str(sample.key_expr)).put(message)

    def _on_token(self, sample: zenoh.Sample) -> None:
        self.comms_alive.put(sample.kind == zenoh.SampleKind.PUT)

    def next(self, key: str, timeout: float = TIMEOUT) -> Message:
        try:
            return self._queue(key).get(timeout=timeout)
        except queue.Empty:
            raise AssertionError(f"nothing arrived on {key} within {timeout} s") from None

    def pending(self, key: str) -> int:
        return self._queue(key).qsize()


@contextlib.contextmanager
def supervisor_router() -> Iterator[tuple[zenoh.Session, str]]:
    """The supervisor's side: a router on a free localhost port, holding the supervisor's liveliness token."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    session = open_session("router", listen=[endpoint])
    try:
        token = session.liveliness().declare_token(SUPERVISOR_ALIVE)  # undeclared if dropped: keep it
        yield session, endpoint
        del token
    finally:
        if not session.is_closed():
            session.close()


@contextlib.contextmanager
def comms_process(endpoint: str, log: Path) -> Iterator[subprocess.Popen[bytes]]:
    """`cpf comms` on the paper's scenario, killed with its process group if it outlives the test."""
    argv = [sys.executable, "-m", "supervisor.cli", "comms", "configs/paper.toml", "--connect", endpoint, "--seed", "1"]
    with log.open("wb") as err:
        proc = subprocess.Popen(argv, cwd=REPO, stdout=subprocess.DEVNULL, stderr=err, start_new_session=True)
        try:
            yield proc
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=EXIT_TIMEOUT)


def wait_until_alive(listener: Listener, proc: subprocess.Popen[bytes], log: Path) -> None:
    deadline = time.monotonic() + START_TIMEOUT
    while time.monotonic() < deadline:
        try:
            if listener.comms_alive.get(timeout=0.25):
                return
        except queue.Empty:
            if proc.poll() is not None:
                pytest.fail(f"the broker exited with {proc.returncode} before coming alive:\n{log.read_text()}")
    pytest.fail(f"the broker declared no liveliness token within {START_TIMEOUT} s:\n{log.read_text()}")


def exit_code(proc: subprocess.Popen[bytes], log: Path) -> int:
    try:
        return proc.wait(timeout=EXIT_TIMEOUT)
    except subprocess.TimeoutExpired:
        pytest.fail(f"the broker is still running {EXIT_TIMEOUT} s later:\n{log.read_text()}")


def fleet_batches(step: Message) -> dict[int, Message]:
    """Each vehicle's reception batch in a batches message, as the vehicle reads it."""
    assert set(step["rx"]) == set(IDS)
    out = {}
    for vid in IDS:
        batch = parse_batches(step, vid)[1]
        assert batch is not None
        out[vid] = batch
    return out


def put_raw(session: zenoh.Session, key: str, payload: bytes) -> None:
    session.put(key, payload, congestion_control=zenoh.CongestionControl.BLOCK, express=True)


def test_broker_relays_to_graph_neighbours_and_survives_malformed_messages(tmp_path):
    fleet = {telemetry.vehicle_id: (telemetry, model, sent) for telemetry, model, sent in first_step()}
    states = {vid: state_message(telemetry, model, 0, sent.seq) for vid, (telemetry, model, sent) in fleet.items()}
    sent = {vid: tx_message(s) for vid, (_, _, s) in fleet.items()}
    log = tmp_path / "comms.log"
    with supervisor_router() as (session, endpoint):
        listener, pubs = Listener(session), Publishers(session)
        with comms_process(endpoint, log) as proc:
            wait_until_alive(listener, proc, log)

            # step 0: nothing is in flight yet, still every vehicle gets its (empty) batch
            pubs.put(TICK_KEY, tick_message(0, 0.0, False))
            step = listener.next(COMMS_STEP_KEY)  # one message for the whole fleet: the tick and every batch
            assert step["tick"] == tick_message(0, 0.0, False)
            for vid, batch in fleet_batches(step).items():
                assert batch == {"t": 0.0, "k": 0, "vehicle": vid, "receptions": []}
                assert_valid(batch, rx_key(vid))

            # every vehicle transmits at t = 0 and reports its state of step 0; tick 1 hands out what arrived
            for vid in IDS:
                pubs.put(state_key(vid), step_message(states[vid], sent[vid], None))
            pubs.put(TICK_KEY, tick_message(1, 0.1, False))
            batches = fleet_batches(listener.next(COMMS_STEP_KEY))
            heard = {vid: [r["sender"] for r in batch["receptions"]] for vid, batch in batches.items()}
            assert heard == {1: [2, 3], 2: [1], 3: [1]}  # graph 2 - 1 - 3; 2 is nearer 1 than 3 is
            arrivals: dict[tuple[int, int], float] = {}
            for vid, batch in batches.items():
                assert_valid(batch, rx_key(vid))
                assert (batch["k"], batch["t"], batch["vehicle"]) == (1, 0.1, vid)
                for r in batch["receptions"]:
                    # the modem carries gamma and gamma_dot as float32: receivers get the rounded values
                    told = sent[r["sender"]]
                    assert (r["seq"], r["stamp"]) == (1, 0.0)
                    assert r["gamma"] == float(np.float32(told["gamma"])) != told["gamma"]
                    assert r["gamma_dot"] == float(np.float32(told["gamma_dot"]))
                    assert abs(r["gamma"] - told["gamma"]) <= 2**-24 * abs(told["gamma"])
                    assert 0.0 < r["arrival"] < 0.1  # some 11 ms of flight over 16-17 m
                    arrivals[(r["sender"], vid)] = r["arrival"]
            batch = listener.next(COMMS_EVENTS_KEY)  # one message per step on the bus
            assert (batch["t"], batch["k"]) == (0.1, 1)
            events = batch["events"]
            assert len(events) == 8
            for event in events:
                assert_valid(event, COMMS_EVENT_KEY)
            links = {(1, 2), (1, 3), (2, 1), (3, 1)}
            assert {(e["sender"], e["receiver"]) for e in events if e["kind"] == "sent"} == links
            delivered = {(e["sender"], e["receiver"]): e for e in events if e["kind"] == "delivered"}
            assert set(delivered) == links
            for link, event in delivered.items():
                assert event["t"] == arrivals[link] and event.get("delay") == pytest.approx(arrivals[link])

            # three malformed messages: garbage, a transmission on another vehicle's key (its state taken), a state
            # without position; then vehicle 2's step 1 again (a replay: dropped, counted)
            put_raw(session, state_key(2), b"\xc1 this is not msgpack")
            pubs.put(state_key(2), step_message(states[2] | {"k": 1, "tx_seq": 0}, sent[3], None))  # another's packet
            pubs.put(state_key(1), {k: v for k, v in states[1].items() if k != "position"} | {"k": 1})

            # the broker keeps working: step 1 without transmissions
            for vid in IDS:
                pubs.put(state_key(vid), states[vid] | {"k": 1, "tx_seq": 0})
            pubs.put(TICK_KEY, tick_message(2, 0.2, False))
            for vid, batch in fleet_batches(listener.next(COMMS_STEP_KEY)).items():
                assert batch == {"t": 0.2, "k": 2, "vehicle": vid, "receptions": []}

            # the final tick: the broker's books close and it reports the malformed messages
            for vid in IDS:
                pubs.put(state_key(vid), states[vid] | {"k": 2, "tx_seq": 0})
            pubs.put(TICK_KEY, tick_message(3, 0.3, True))
            done = listener.next(COMMS_DONE_KEY)
            assert_valid(done, COMMS_DONE_KEY)
            causes = {"malformed": 2, "replayed step": 1, "undecodable": 1}
            by_key = {state_key(1): 1, state_key(2): 2, tx_key(2): 1}  # whose key carried them
            assert done == {"t": 0.3, "k": 3, "events": 8, "malformed": 4, "causes": causes, "by_key": by_key}
            assert listener.pending(COMMS_EVENTS_KEY) == 0  # nothing was left in flight
            # link statistics: only the final snapshot (a run shorter than one window), books balanced
            stats = listener.next(COMMS_STATS_KEY)
            assert_valid(stats, COMMS_STATS_KEY)
            assert (stats["t"], stats["window"]) == (0.3, 10.0) and listener.pending(COMMS_STATS_KEY) == 0
            books = {(b["sender"], b["receiver"]): b for b in stats["links"]}
            assert set(books) == links
            for link, book in books.items():
                assert (book["sent"], book["delivered"], book["dropped"]) == (1, 1, {}), link
                assert book.get("mean_delay") == book.get("max_delay") == pytest.approx(arrivals[link])
            assert stats["lambda2"] == pytest.approx(1.0)  # the path graph 2 - 1 - 3, every link delivered
            assert listener.pending(COMMS_STEP_KEY) == 0  # no batches for the final tick

            pubs.put(STOP_KEY, {"t": 0.3, "reason": "end of test"})
            assert exit_code(proc, log) == 0
    text = log.read_text()
    assert text.count("dropped a message") == 3 and text.count("dropped a transmission") == 1


def test_broker_exits_by_itself_when_the_supervisor_disappears(tmp_path):
    log = tmp_path / "comms.log"
    with supervisor_router() as (session, endpoint):
        listener = Listener(session)
        with comms_process(endpoint, log) as proc:
            wait_until_alive(listener, proc, log)
            session.close()
            assert exit_code(proc, log) == 0
    assert "the supervisor is gone" in log.read_text()


def test_broker_survives_a_transmission_its_wire_frame_cannot_carry():
    scenario = load_scenario(REPO / "configs" / "paper.toml")
    pubs = RecordingPublishers()
    broker = Broker(broker_core(scenario, 1), IDS, pubs, DT)
    fleet = {telemetry.vehicle_id: (telemetry, model, sent) for telemetry, model, sent in first_step()}
    broker.take(TICK_KEY, encode(tick_message(0, 0.0, False)))
    assert broker.advance() is False
    for vid, (telemetry, model, sent) in fleet.items():
        told = tx_message(sent) | ({"gamma": 1e39} if vid == 2 else {})
        broker.take(state_key(vid), encode(step_message(state_message(telemetry, model, 0, sent.seq), told, None)))
    broker.take(TICK_KEY, encode(tick_message(1, 0.1, False)))
    broker.advance()
    assert broker.books.malformed == 1
    assert broker.next_k == 2  # step 1 was handled: it did not wait for the packet that could not be carried
    assert batches(pubs, 1)[1] == [3]  # 3's packet went through; 2's was dropped as malformed


# --- the broker's bookkeeping, driven directly (no Zenoh) ----------------------------------------------------------

DT = 0.1
PAPER_EDGES = ((1, 2), (1, 3))  # 2 - 1 - 3
Fleet = dict[int, tuple[Telemetry, Model, Transmission]]


@pytest.fixture(scope="module")
def fleet() -> Fleet:
    return {telemetry.vehicle_id: (telemetry, model, sent) for telemetry, model, sent in first_step()}


def pure_broker(start_step: int = 0, overrides: tuple[str, ...] = ()) -> tuple[Broker, RecordingPublishers]:
    scenario = load_scenario(REPO / "configs" / "paper.toml", overrides)
    pubs = RecordingPublishers()
    return Broker(broker_core(scenario, 1), IDS, pubs, DT, start_step), pubs


def report(
    broker: Broker,
    fleet: Fleet,
    k: int,
    vehicles: tuple[int, ...] = IDS,
    seq: int | None = None,
    since: int | None = None,
) -> None:
    """The vehicles' states of step k, each with its transmission at t_k (numbered seq) unless seq is None; since: the
    first step of the window k ends (its earlier steps' states carried as a vehicle carries them), else k alone."""
    for vid in vehicles:
        telemetry, model, sent = fleet[vid]
        tx = tx_message(msgspec.structs.replace(sent, seq=seq, t=k * DT, stamp=k * DT)) if seq is not None else None
        earlier = [
            step_message(state_message(telemetry, model, j, 0), None, None)
            for j in range(k if since is None else since, k)
        ]
        message = step_message(state_message(telemetry, model, k, seq or 0), tx, None, earlier=earlier)
        broker.take(state_key(vid), encode(message))


def tick(broker: Broker, k: int, network: Network | None = None, alive: list[int] | None = None) -> bool:
    broker.take(TICK_KEY, encode(tick_message(k, k * DT, False, None, network, alive)))
    return broker.advance()


def batches(pubs: RecordingPublishers, k: int) -> dict[int, list[int]]:
    """Step k's reception batches (the vehicles served at k): who heard whom."""
    steps = [message for key, message in pubs.messages if key == COMMS_STEP_KEY and message["k"] == k]
    assert len(steps) == 1
    out = {}
    for vid in steps[0]["rx"]:
        batch = parse_batches(steps[0], vid)[1]
        assert batch is not None and vid not in out
        assert_valid(batch, rx_key(vid))
        out[vid] = [r["sender"] for r in batch["receptions"]]
    return out


def link_events(pubs: RecordingPublishers) -> set[tuple[str, int, int, int, str | None]]:
    """Every link event so far as (kind, sender, receiver, seq, reason); the list is cleared."""
    events = [event for key, message in pubs.messages if key == COMMS_EVENTS_KEY for event in message["events"]]
    for event in events:
        assert_valid(event, COMMS_EVENT_KEY)
    pubs.messages.clear()
    found = {(e["kind"], e["sender"], e["receiver"], e["seq"], e.get("reason")) for e in events}
    assert len(found) == len(events)
    return found


def delivered(links: set[tuple[int, int]], seq: int) -> set[tuple[str, int, int, int, str | None]]:
    return {(kind, s, r, seq, None) for s, r in links for kind in ("sent", "delivered")}


def test_broker_neither_waits_for_nor_serves_a_vehicle_that_is_not_alive(fleet):
    broker, pubs = pure_broker()
    assert tick(broker, 0) is False
    assert batches(pubs, 0) == {1: [], 2: [], 3: []}
    report(broker, fleet, 0, (1, 2), seq=1)  # vehicle 3 died during step 0: no state, no transmission
    tick(broker, 1, alive=[1, 2])
    assert broker.next_k == 2  # step 1 was handled without vehicle 3's state
    assert batches(pubs, 1) == {1: [2], 2: [1]}  # nothing for vehicle 3, not even an empty batch
    assert link_events(pubs) == delivered({(1, 2), (2, 1)}, 1)  # nor any link to it

    tick(broker, 2, alive=[1, 2, 3])  # vehicle 3 is back; its state of step 1 is not expected
    assert broker.next_k == 2  # still waiting for vehicles 1 and 2
    report(broker, fleet, 1, (1, 2))
    broker.advance()
    assert broker.next_k == 3
    assert batches(pubs, 2) == {1: [], 2: [], 3: []}

    tick(broker, 3, alive=[1, 3])  # vehicle 2 is gone again: only 1 and 3 are waited for
    assert broker.next_k == 3
    report(broker, fleet, 2, (1, 3), seq=2)
    broker.advance()
    assert broker.next_k == 4
    assert batches(pubs, 3) == {1: [3], 3: [1]}
    assert link_events(pubs) == delivered({(1, 3), (3, 1)}, 2)
    assert broker.books.malformed == 0


def test_a_restarted_broker_handles_its_first_tick_at_once_and_submits_nothing(fleet):
    broker, pubs = pure_broker(start_step=5)
    report(broker, fleet, 4, seq=4)  # left over from before the restart: not this broker's to send
    assert tick(broker, 5) is False
    assert broker.next_k == 6  # handled without waiting for anything
    assert batches(pubs, 5) == {1: [], 2: [], 3: []}
    assert link_events(pubs) == set()
    tick(broker, 6)
    assert broker.next_k == 6  # from now on it waits for the states of the previous step
    report(broker, fleet, 5, seq=5)
    broker.advance()
    assert broker.next_k == 7
    assert batches(pubs, 6) == {1: [2, 3], 2: [1], 3: [1]}
    assert link_events(pubs) == delivered({(1, 2), (2, 1), (1, 3), (3, 1)}, 5)


def test_a_link_down_drops_what_is_sent_over_it_under_the_network_of_the_sending_step(fleet):
    broker, pubs = pure_broker()
    tick(broker, 0, Network.of(PAPER_EDGES, down=frozenset({(1, 2)})))
    report(broker, fleet, 0, seq=1)
    tick(broker, 1, Network.of(PAPER_EDGES, down=frozenset({(2, 1)})))  # applies to what is sent during step 1
    assert broker.next_k == 2
    assert batches(pubs, 1) == {1: [2, 3], 2: [], 3: [1]}
    dropped = {("sent", 1, 2, 1, None), ("dropped", 1, 2, 1, "link_down")}
    assert link_events(pubs) == dropped | delivered({(1, 3), (2, 1), (3, 1)}, 1)

    report(broker, fleet, 1, seq=2)
    tick(broker, 2)
    assert broker.next_k == 3
    assert batches(pubs, 2) == {1: [3], 2: [1], 3: [1]}
    dropped = {("sent", 2, 1, 2, None), ("dropped", 2, 1, 2, "link_down")}
    assert link_events(pubs) == dropped | delivered({(1, 2), (1, 3), (3, 1)}, 2)


def test_a_silent_modem_is_dropped_on_each_of_its_links(fleet):
    broker, pubs = pure_broker()
    tick(broker, 0, Network.of(PAPER_EDGES, silent=frozenset({1})))
    report(broker, fleet, 0, seq=1)
    tick(broker, 1)
    assert batches(pubs, 1) == {1: [2, 3], 2: [], 3: []}  # the others still reach vehicle 1
    silenced = {
        (kind, 1, j, 1, reason) for j in (2, 3) for kind, reason in (("sent", None), ("dropped", "modem_silent"))
    }
    assert link_events(pubs) == silenced | delivered({(2, 1), (3, 1)}, 1)
    broker.take(TICK_KEY, encode(tick_message(2, 2 * DT, True)))
    report(broker, fleet, 1)
    assert broker.advance() is True
    done = [message for key, message in pubs.messages if key == COMMS_DONE_KEY]
    assert done == [{"t": 2 * DT, "k": 2, "events": 8, "malformed": 0}]
    stats = next(message for key, message in pubs.messages if key == COMMS_STATS_KEY)
    books = {(b["sender"], b["receiver"]): b for b in stats["links"]}
    for j in (2, 3):
        book = books[(1, j)]
        assert (book["sent"], book["delivered"], book["dropped"]) == (1, 0, {"modem_silent": 1})


# --- realtime: each reception handed out as soon as it is decided, stamped with its arrival on the wall clock -----


PAPER_LINKS = {(1, 2), (2, 1), (1, 3), (3, 1)}


def realtime_tick(broker: Broker, k: int, wall: float, alive: list[int] | None = None, hold: bool = False) -> bool:
    """Tick k of a realtime run whose t = 0 was at wall-clock time `wall` (speed 1)."""
    tick = tick_message(k, k * DT, False, None, None, alive, wall=wall + k * DT, speed=1.0, hold=hold)
    broker.take(TICK_KEY, encode(tick))
    return broker.advance()


def live_deliveries(pubs: RecordingPublishers) -> list[Message]:
    return [m for key, m in pubs.messages if key.endswith("/rx")]


def test_realtime_receptions_go_out_once_decided_ahead_of_their_arrival_and_say_when_it_is(fleet):
    broker, pubs = pure_broker()
    start = time.time() + 100.0  # t = 0 is still to come: by the wall clock nothing has arrived yet
    realtime_tick(broker, 0, start)
    report(broker, fleet, 0, seq=1)
    broker.advance()
    assert broker.submitted == 0  # in the water at once, without waiting for tick 1
    deliveries = [(key, m) for key, m in pubs.messages if key.endswith("/rx")]
    heard = {m["vehicle"]: sorted(r["sender"] for r in m["receptions"]) for _, m in deliveries}
    assert heard == {1: [2, 3], 2: [1], 3: [1]}
    for key, message in deliveries:
        assert_valid(message, key)
        assert message["k"] == 1  # taken in at the first sync instant after arrival
        for r in message["receptions"]:
            assert 0.0 < r["arrival"] < DT
            assert r["due"] == pytest.approx(start + r["arrival"], abs=1e-6)
    pubs.messages.clear()
    realtime_tick(broker, 1, start)  # nothing left to hand out at the tick; the step's events go out with it
    assert not live_deliveries(pubs)
    steps = [m for key, m in pubs.messages if key == COMMS_STEP_KEY and m["k"] == 1]
    assert len(steps) == 1 and all(parse_batches(steps[0], v)[1] == rx_message(v, 1, DT, []) for v in IDS)
    assert link_events(pubs) == delivered(PAPER_LINKS, 1)


def test_realtime_holds_a_reception_until_no_later_transmission_can_spoil_it(fleet):
    broker, pubs = pure_broker(overrides=("comms.preamble=0.15",))  # every packet arrives after t_1
    start = time.time() - 100.0  # long ago: by the wall clock every arrival is past
    realtime_tick(broker, 0, start)
    report(broker, fleet, 0, seq=1)
    broker.advance()
    assert broker.submitted == 0 and live_deliveries(pubs) == []  # step 1's packets could still collide with them
    realtime_tick(broker, 1, start)
    assert live_deliveries(pubs) == []
    report(broker, fleet, 1)  # no transmission at step 1: step 0's packets are decided
    broker.advance()
    out = live_deliveries(pubs)
    assert {m["vehicle"]: sorted(r["sender"] for r in m["receptions"]) for m in out} == {1: [2, 3], 2: [1], 3: [1]}
    assert all(m["k"] == 2 and all(DT < r["arrival"] < 2 * DT for r in m["receptions"]) for m in out)


def test_a_vehicle_killed_after_reporting_its_step_never_transmits_it(fleet):
    broker, pubs = pure_broker()
    tick(broker, 0)
    report(broker, fleet, 0, seq=1)  # all three report; then vehicle 3 is killed before tick 1
    tick(broker, 1, alive=[1, 2])
    assert broker.next_k == 2
    assert batches(pubs, 1) == {1: [2], 2: [1]}
    assert link_events(pubs) == delivered({(1, 2), (2, 1)}, 1)  # as the in-process engine: its modem never sent


def test_realtime_waits_for_the_next_tick_before_sending_a_step_whose_end_kills_a_vehicle(fleet):
    broker, pubs = pure_broker()
    start = time.time() - 100.0
    realtime_tick(broker, 0, start, hold=True)  # vehicle 3 is killed at tick 1
    report(broker, fleet, 0, seq=1)
    broker.advance()
    assert broker.submitted == -1  # held: only tick 1 says who survived step 0
    realtime_tick(broker, 1, start, alive=[1, 2])
    assert broker.submitted == 0
    realtime_tick(broker, 2, start, alive=[1, 2])
    assert link_events(pubs) == delivered({(1, 2), (2, 1)}, 1)  # as lockstep and the in-process engine


def test_link_events_go_after_the_batches_but_before_them_when_a_process_is_killed_next(fleet):
    """The fleet waits for the batches message only: the link events follow it, off the critical path, except on a
    tick after which a process is killed or restarted (hold), when the supervisor acts as soon as the step's states
    are in and a killed broker must not take its events with it."""
    broker, pubs = pure_broker()

    def order(k: int, hold: bool) -> list[str]:
        pubs.messages.clear()
        broker.take(TICK_KEY, encode(tick_message(k, k * DT, False, hold=hold)))
        broker.advance()
        return [key for key, _ in pubs.messages if key in (COMMS_STEP_KEY, COMMS_EVENTS_KEY)]

    assert order(0, hold=False) == [COMMS_STEP_KEY]  # nothing sent yet: no events
    report(broker, fleet, 0, seq=1)
    assert order(1, hold=True) == [COMMS_EVENTS_KEY, COMMS_STEP_KEY]
    report(broker, fleet, 1, seq=2)
    assert order(2, hold=False) == [COMMS_STEP_KEY, COMMS_EVENTS_KEY]
