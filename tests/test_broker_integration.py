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

import numpy as np
import pytest
import zenoh

from comms.broker import Broker
from comms.bus import Publishers, free_port, open_session
from comms.messages import (
    COMMS_ALIVE,
    COMMS_DONE_KEY,
    COMMS_EVENT_KEY,
    COMMS_STATS_KEY,
    ROOT,
    STOP_KEY,
    SUPERVISOR_ALIVE,
    TICK_KEY,
    Message,
    decode,
    encode,
    rx_key,
    state_key,
    state_message,
    tick_message,
    tx_key,
    tx_message,
)
from supervisor.fleet import broker_core
from supervisor.scenario import load_scenario
from tests.test_messages import assert_valid, first_step

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
            pubs.put(TICK_KEY, tick_message(0, 0.0, False, {}))
            for vid in IDS:
                batch = listener.next(rx_key(vid))
                assert batch == {"t": 0.0, "k": 0, "vehicle": vid, "receptions": []}
                assert_valid(batch, rx_key(vid))

            # every vehicle transmits at t = 0 and reports its state of step 0; tick 1 hands out what arrived
            for vid in IDS:
                pubs.put(tx_key(vid), sent[vid])
                pubs.put(state_key(vid), states[vid])
            pubs.put(TICK_KEY, tick_message(1, 0.1, False, {}))
            batches = {vid: listener.next(rx_key(vid)) for vid in IDS}
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
            events = [listener.next(COMMS_EVENT_KEY) for _ in range(8)]
            for event in events:
                assert_valid(event, COMMS_EVENT_KEY)
            links = {(1, 2), (1, 3), (2, 1), (3, 1)}
            assert {(e["sender"], e["receiver"]) for e in events if e["kind"] == "sent"} == links
            delivered = {(e["sender"], e["receiver"]): e for e in events if e["kind"] == "delivered"}
            assert set(delivered) == links
            for link, event in delivered.items():
                assert event["t"] == arrivals[link] and event["delay"] == pytest.approx(arrivals[link])

            # three malformed messages: garbage, a transmission on another vehicle's key, a state without position
            put_raw(session, tx_key(2), b"\xc1 this is not msgpack")
            pubs.put(tx_key(2), sent[3])
            pubs.put(state_key(1), {k: v for k, v in states[1].items() if k != "position"} | {"k": 1})

            # the broker keeps working: step 1 without transmissions
            for vid in IDS:
                pubs.put(state_key(vid), states[vid] | {"k": 1, "tx_seq": 0})
            pubs.put(TICK_KEY, tick_message(2, 0.2, False, {}))
            for vid in IDS:
                assert listener.next(rx_key(vid)) == {"t": 0.2, "k": 2, "vehicle": vid, "receptions": []}

            # the final tick: the broker's books close and it reports the malformed messages
            for vid in IDS:
                pubs.put(state_key(vid), states[vid] | {"k": 2, "tx_seq": 0})
            pubs.put(TICK_KEY, tick_message(3, 0.3, True, {}))
            done = listener.next(COMMS_DONE_KEY)
            assert_valid(done, COMMS_DONE_KEY)
            assert done == {"t": 0.3, "k": 3, "events": 8, "malformed": 3}
            assert listener.pending(COMMS_EVENT_KEY) == 0  # nothing was left in flight
            # link statistics: only the final snapshot (a run shorter than one window), books balanced
            stats = listener.next(COMMS_STATS_KEY)
            assert_valid(stats, COMMS_STATS_KEY)
            assert (stats["t"], stats["window"]) == (0.3, 10.0) and listener.pending(COMMS_STATS_KEY) == 0
            books = {(b["sender"], b["receiver"]): b for b in stats["links"]}
            assert set(books) == links
            for link, book in books.items():
                assert (book["sent"], book["delivered"], book["dropped"]) == (1, 1, {}), link
                assert book["mean_delay"] == book["max_delay"] == pytest.approx(arrivals[link])
            assert stats["lambda2"] == pytest.approx(1.0)  # the path graph 2 - 1 - 3, every link delivered
            assert all(listener.pending(rx_key(vid)) == 0 for vid in IDS)  # no batches for the final tick

            pubs.put(STOP_KEY, {"t": 0.3, "reason": "end of test"})
            assert exit_code(proc, log) == 0
    assert log.read_text().count("dropped a malformed message") == 3


def test_broker_exits_by_itself_when_the_supervisor_disappears(tmp_path):
    log = tmp_path / "comms.log"
    with supervisor_router() as (session, endpoint):
        listener = Listener(session)
        with comms_process(endpoint, log) as proc:
            wait_until_alive(listener, proc, log)
            session.close()
            assert exit_code(proc, log) == 0
    assert "the supervisor is gone" in log.read_text()


class RecordingPublishers(Publishers):
    """What the broker would publish, kept in a list (no Zenoh session)."""

    def __init__(self) -> None:
        self.messages: list[tuple[str, Message]] = []

    def put(self, key: str, message: Message) -> None:
        self.messages.append((key, message))


def test_broker_survives_a_transmission_its_wire_frame_cannot_carry():
    scenario = load_scenario(REPO / "configs" / "paper.toml")
    pubs = RecordingPublishers()
    broker = Broker(broker_core(scenario, 1), IDS, pubs)
    fleet = {telemetry.vehicle_id: (telemetry, model, sent) for telemetry, model, sent in first_step()}
    broker.take(TICK_KEY, encode(tick_message(0, 0.0, False, {})))
    assert broker.advance() is False
    for vid, (telemetry, model, sent) in fleet.items():
        told = tx_message(sent) | ({"gamma": 1e39} if vid == 2 else {})
        broker.take(tx_key(vid), encode(told))
        broker.take(state_key(vid), encode(state_message(telemetry, model, 0, sent.seq)))
    broker.take(TICK_KEY, encode(tick_message(1, 0.1, False, {})))
    broker.advance()
    assert broker.books.malformed == 1
    assert broker.next_k == 2  # step 1 was handled: it did not wait for the packet that could not be carried
    batches = [m for key, m in pubs.messages if key.endswith("/rx") and m["k"] == 1]
    assert len(batches) == 3
    heard_by_1 = {r["sender"] for m in batches if m["vehicle"] == 1 for r in m["receptions"]}
    assert heard_by_1 == {3}  # 3's packet went through; 2's was dropped as malformed
