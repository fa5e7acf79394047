"""`cpf replay` (supervisor/tools/replay.py): a real run's log published again over localhost Zenoh and counted back."""

from __future__ import annotations

import contextlib
import io
import re
import threading
import time
from collections import Counter, defaultdict
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zenoh

from comms.bus.bus import answer_flushes, free_port, open_session
from comms.records.messages import META_KEY, ROOT, Message, decode
from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from supervisor.errors import ScenarioError
from supervisor.record.recorder import read_messages, seconds_to_ns
from supervisor.record.scene.foxglove_schemas import is_scene_topic
from supervisor.tools.replay import ReplayReport, replay
from supervisor.tools.replay_bus import bus_form, latched

pytestmark = pytest.mark.integration

REPO = Path(__file__).resolve().parent.parent
DURATION = 5.0  # s simulated: some 850 messages on 13 topics in the log, fewer on the bus (events batched)
TIMEOUT = 10.0  # s for every expected message to arrive

Logged = list[tuple[str, int, dict[str, Any]]]  # (topic, log time ns, message) in log-time order


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A real run: configs/paper.toml cut to DURATION, in process, recorded to MCAP."""
    text = (REPO / "configs" / "paper.toml").read_text(encoding="utf-8")
    text = re.sub(r"(?m)^duration = .*$", f"duration = {DURATION}", text, count=1)
    scenario = parse_scenario(text, "paper.toml")
    assert scenario.scenario.duration == DURATION
    out = tmp_path_factory.mktemp("replay") / "run.mcap"
    run_inprocess(scenario, "paper.toml", text, out, 0, Progress(DURATION, io.StringIO(), enabled=False))
    return out


@pytest.fixture(scope="module")
def raw(log: Path) -> Logged:
    """The log's cpf records (its Foxglove scene is not replayed: no run publishes it on the bus)."""
    return [record for record in read_messages(log) if not is_scene_topic(record[0])]


@pytest.fixture(scope="module")
def logged(raw: Logged) -> Logged:
    """The whole log as a live run publishes it (what a replay of it publishes)."""
    return bus_window(raw)


def bus_window(raw: Logged, start: float | None = None, end: float | None = None) -> Logged:
    """What a replay of the window publishes: the latched state before it (at its start), then its records in the
    form of the live bus (supervisor.tools.replay_bus)."""
    lo = 0 if start is None else seconds_to_ns(start)
    hi = raw[-1][1] if end is None else seconds_to_ns(end)
    meta = next(m for t, _, m in raw if t == META_KEY)
    before = [(t, lo, m) for t, _, m in latched(r for r in raw if r[1] < lo)]
    return before + list(bus_form([r for r in raw if lo <= r[1] <= hi], meta))


class Collector:
    """Everything that arrives on cpf/**: (key, payload, monotonic arrival time), in arrival order."""

    def __init__(self, session: zenoh.Session) -> None:
        self._lock = threading.Lock()
        self._arrived: list[tuple[str, bytes, float]] = []
        self._expected = 0
        self._reached = threading.Event()
        self._subscriber = session.declare_subscriber(f"{ROOT}/**", self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        item = (str(sample.key_expr), sample.payload.to_bytes(), time.monotonic())
        with self._lock:
            self._arrived.append(item)
            if self._expected and len(self._arrived) >= self._expected:
                self._reached.set()

    def count(self) -> int:
        with self._lock:
            return len(self._arrived)

    def wait_for(self, expected: int, timeout: float = TIMEOUT) -> list[tuple[str, Message, float]]:
        """Every message once `expected` have arrived (decoded); fails after timeout."""
        with self._lock:
            self._expected = expected
            if len(self._arrived) >= expected:
                self._reached.set()
            else:  # an earlier wait_for's count was reached: wait for this one's
                self._reached.clear()
        if not self._reached.wait(timeout):
            pytest.fail(f"{self.count()} of {expected} messages arrived within {timeout} s")
        with self._lock:
            return [(key, decode(payload), at) for key, payload, at in self._arrived]


@contextlib.contextmanager
def router() -> Iterator[tuple[str, Collector]]:
    """The test's side: a router on a free localhost port with its subscriber declared before anyone connects; it
    answers flushes, so a replay's last messages are not lost at its close (comms.bus.bus.flush)."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with open_session("router", listen=[endpoint]) as session:
        answering = answer_flushes(session)
        yield endpoint, Collector(session)
        answering.undeclare()


def by_topic(messages: list[tuple[str, Message]]) -> dict[str, list[Message]]:
    out: dict[str, list[Message]] = defaultdict(list)
    for topic, message in messages:
        out[topic].append(message)
    return dict(out)


def check_replayed(received: list[tuple[str, Message, float]], expected: Logged, report: ReplayReport) -> None:
    """Per topic, exactly the logged messages, identical and in log-time order; the report counts the same."""
    counts = Counter(topic for topic, _, _ in expected)
    assert Counter(key for key, _, _ in received) == counts
    assert report.published == counts
    assert by_topic([(key, message) for key, message, _ in received]) == by_topic([(t, m) for t, _, m in expected])


def test_replay_publishes_every_message_of_the_log_on_its_topic(log, raw, logged):
    assert {topic for topic, _, _ in logged} >= {f"{ROOT}/vehicle/1/state", f"{ROOT}/comms/events", f"{ROOT}/run/meta"}
    assert not any(topic.endswith(("/tx", "/rx", "/comms/event")) for topic, _, _ in logged)  # the log's forms
    with router() as (endpoint, collector):
        report = replay(log, speed=0, connect=endpoint)
        received = collector.wait_for(len(logged))
    check_replayed(received, logged, report)
    assert len(received) == len(logged) == report.messages > 200
    first = received[0]
    assert (first[0], first[1]) == (logged[0][0], logged[0][2])  # the run's meta first: it has the earliest time
    assert report.passes == 1 and report.skipped == 0 and not report.interrupted
    assert (report.first, report.last, report.span) == (0.0, DURATION, DURATION)
    assert report.endpoint == f"Zenoh client connected to {endpoint}"
    assert f"replayed {len(logged)} messages on {len(report.published)} topics" in report.describe()


def test_replay_keeps_the_original_timing_scaled_by_speed(log, raw, logged):
    start, end, speed = 1.0, 3.0, 4.0  # 2 s of log time: at least 0.5 s of wall time
    expected = bus_window(raw, start, end)
    with router() as (endpoint, collector):
        began = time.monotonic()
        report = replay(log, speed=speed, start=start, end=end, connect=endpoint)
        took = time.monotonic() - began
        received = collector.wait_for(len(expected))
    check_replayed(received, expected, report)
    assert took >= (end - start) / speed and report.wall_time >= (end - start) / speed
    # no message goes out before its time: arrival >= call + (t - t_first) / speed
    first_ns = expected[0][1]
    schedule = sorted(ns for _, ns, _ in expected)  # the i-th arrival cannot precede the i-th scheduled time
    arrivals = sorted(at for _, _, at in received)
    slack = 1e-3  # float rounding of the schedule, not tolerance for lateness
    assert all(at >= began + (ns - first_ns) * 1e-9 / speed - slack for at, ns in zip(arrivals, schedule, strict=True))


def test_a_window_replays_exactly_its_messages_bounds_included(log, raw, logged):
    start, end = 1.2, 2.5
    expected = bus_window(raw, start, end)
    stamps = {ns for _, ns, _ in expected}
    assert {seconds_to_ns(start), seconds_to_ns(end)} <= stamps  # messages lie on both bounds
    assert 0 < len(expected) < len(logged)
    with router() as (endpoint, collector):
        report = replay(log, speed=0, start=start, end=end, connect=endpoint)
        received = collector.wait_for(len(expected))
    check_replayed(received, expected, report)
    assert (report.first, report.last) == (start, end)


def test_loop_repeats_the_window_until_interrupted_then_ends_cleanly(log, raw, logged):
    start, end = 4.0, 5.0
    expected = bus_window(raw, start, end)
    stop_after = 2 * len(expected) + 5  # two full passes and a bit of the third
    published = 0

    def interrupt(t: float) -> None:
        nonlocal published
        published += 1
        if published == stop_after:
            raise KeyboardInterrupt

    with router() as (endpoint, collector):
        report = replay(log, speed=0, start=start, end=end, loop=True, connect=endpoint, progress=interrupt)
        received = collector.wait_for(stop_after)
    assert report.interrupted and report.passes == 2 and report.messages == stop_after == len(received)
    assert (report.first, report.last) == (start, end)
    assert [(key, message) for key, message, _ in received[: len(expected)]] == [(t, m) for t, _, m in expected]


def test_without_connect_the_replayer_runs_a_router_subscribers_connect_to(log, raw, logged):
    sessions: list[zenoh.Session] = []
    collectors: list[Collector] = []
    deadline = time.monotonic() + TIMEOUT
    lines: list[str] = []

    def connect_a_subscriber(where: str) -> None:
        lines.append(where)
        endpoint = where.removeprefix("Zenoh router listening on ")
        sessions.append(open_session("client", connect=[endpoint]))
        collectors.append(Collector(sessions[0]))

    def until_a_full_pass_arrived(t: float) -> None:
        # the subscriber may miss the very first messages while its declaration travels: loop until it has a pass
        if collectors[0].count() >= len(logged) or time.monotonic() > deadline:
            raise KeyboardInterrupt

    try:
        report = replay(log, speed=0, loop=True, on_ready=connect_a_subscriber, progress=until_a_full_pass_arrived)
        received = collectors[0].wait_for(len(logged))
    finally:
        for session in sessions:
            session.close()
    assert re.fullmatch(r"Zenoh router listening on tcp/127\.0\.0\.1:\d+", lines[0])
    assert report.endpoint == lines[0] and report.interrupted  # after a pass or within one: the subscriber decides
    assert report.messages >= len(logged)  # the report counts at least what the subscriber was seen to receive
    assert {key for key, _, _ in received} == {topic for topic, _, _ in logged}


@pytest.mark.parametrize(
    ("name", "content", "reason"),
    [
        ("missing.mcap", None, "no such log file"),
        ("empty.mcap", b"", "not an MCAP file"),
        ("text.mcap", b"this is not an MCAP file, just some text" * 4, "not an MCAP file"),
    ],
)
def test_a_log_that_is_missing_or_no_mcap_is_a_scenario_error_naming_it(tmp_path, name, content, reason):
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(ScenarioError, match=re.escape(f"{name}: {reason}")):
        replay(path, speed=0, connect="tcp/127.0.0.1:9")  # never reached: the file is checked first


def test_a_cut_log_is_an_error_that_points_to_recover(tmp_path, log):
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(log.read_bytes()[:-10])
    with pytest.raises(ScenarioError, match=r"cut\.mcap: cut short or damaged .*cpf recover"):
        replay(cut, speed=0, connect="tcp/127.0.0.1:9")


@pytest.mark.parametrize(
    ("kwargs", "reason"),
    [
        ({"start": 100.0, "end": 200.0}, "no message to replay in t = 100 s to 200 s"),
        ({"start": 5.01}, "no message to replay in t = 5.01 s to the end"),
        ({"start": 3.0, "end": 2.0}, "--start (3 s) is after --end (2 s)"),
        ({"start": -1.0}, "--start: must be a simulation time >= 0 in s, got -1"),
        ({"end": float("inf")}, "--end: must be a simulation time >= 0 in s, got inf"),
        ({"speed": -1.0}, "--speed: must be >= 0"),
        ({"speed": float("nan")}, "--speed: must be >= 0"),
        ({"listen": "tcp/127.0.0.1:9"}, "--listen and --connect exclude each other"),
    ],
)
def test_bad_arguments_and_empty_windows_are_scenario_errors(log, kwargs, reason):
    with pytest.raises(ScenarioError, match=re.escape(f"run.mcap: {reason}")):
        replay(log, **({"connect": "tcp/127.0.0.1:9"} | kwargs))


def test_records_that_do_not_read_are_replayed_as_they_are_and_never_acted_on(raw: Logged) -> None:
    """bus_form and latched read ticks, faults and receptions through their records: a tick that does not read
    gets no cpf/comms/step of its own (it was handed out with its k a string), a fault that does not read is not
    latched and cannot end one that is."""
    meta = next(m for t, _, m in raw if t == META_KEY)
    odd_tick = {"t": 0.0, "k": "zero", "final": False}
    out = list(bus_form([("cpf/clock/tick", 0, odd_tick)], meta))
    assert out == [("cpf/clock/tick", 0, odd_tick)]
    start = {"t": 1.0, "kind": "blackout", "phase": "start", "detail": {"start": 1.0, "end": 2.0}}
    garbage = {**start, "phase": "half-way"}  # same kind and detail, a phase no fault has
    records = [("cpf/run/fault", 10, start), ("cpf/run/fault", 20, garbage)]
    assert [m for _, _, m in latched(records)] == [start]


def test_a_looping_replay_stopped_by_ctrl_c_exits_130_as_every_command(log, tmp_path):
    """`cpf replay --loop` exited 0 when interrupted, where every other command (and replay without --loop) exits
    130 (a new user)."""
    import signal

    from tests.procs import start_cpf

    proc = start_cpf(["replay", str(log), "--loop", "--speed", "20", "--delay", "0"], tmp_path)
    try:
        assert proc.stdout is not None
        for line in proc.stdout:
            if "listening on" in line:  # its router is up: the replay is under way
                break
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
        proc.communicate()
    assert proc.returncode == 130, err
