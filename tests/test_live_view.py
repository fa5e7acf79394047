"""The live view (`cpf run --live`, `cpf replay --live`; supervisor/record/live.py, record/scene/live.py): a client
speaking Foxglove's WebSocket protocol (tests/foxglove_client.py) connects, subscribes and gets the scene while the
run goes on; the run ends cleanly whether the client stays or leaves; a replay serves the log's scene."""

from __future__ import annotations

import contextlib
import os
import re
import signal
import socket
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from websockets.typing import Subprotocol

from comms.records.events import EVENT_TOPICS
from comms.records.messages import GRAPH_KEY, META_KEY
from supervisor.record import logfile
from supervisor.record.live import ALWAYS, WATCH_PERIOD, LiveView
from supervisor.record.scene.foxglove_schemas import (
    PATHS_TOPIC,
    SCENE_TOPIC,
    TRANSFORMS_TOPIC,
    is_scene_topic,
    schema,
    schema_name,
)
from supervisor.record.scene.live import LiveScene
from tests.conftest import CONFIGS, shortened
from tests.foxglove_client import CLOSE_WAIT, FoxgloveClient, Received
from tests.procs import CPF, cpf, processes_with, wait_until

pytestmark = pytest.mark.e2e
LIVE_LINE = re.compile(r"live view on ws://127\.0\.0\.1:(\d+) \(Foxglove: Open connection -> Foxglove WebSocket\)")
LINK_FAULT = "kind=link_down,sender=1,receiver=2,start=4,end=8"


def scenario(tmp_path: Path, duration: float) -> Path:
    path = tmp_path / "short.toml"
    text = shortened((CONFIGS / "paper.toml").read_text(), duration)
    path.write_text(re.sub(r"(?ms)^\[\[faults\]\].*?(?=^\[|\Z)", "", text))  # the paper's fault is after the end
    return path


@contextlib.contextmanager
def running(args: list[str], tmp_path: Path, stdin: bool = False) -> Iterator[subprocess.Popen[str]]:
    """cpf in the background; killed on the way out if a failed test left it running."""
    proc = subprocess.Popen([CPF, *args], cwd=tmp_path, stdin=subprocess.PIPE if stdin else subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
        if proc.stdin is not None and not proc.stdin.closed:
            proc.stdin.close()
        proc.stdin = None  # closed: communicate only drains stdout and stderr
        proc.communicate()


def live_port(proc: subprocess.Popen[str]) -> int:
    """The port cpf printed on stderr (the lines before it, warnings, are skipped)."""
    assert proc.stderr is not None
    while line := proc.stderr.readline():
        if found := LIVE_LINE.search(line):
            return int(found.group(1))
    raise AssertionError(f"cpf ended without a live line (exit {proc.wait()})")


def told_subscribed(proc: subprocess.Popen[str], topics: list[str]) -> None:
    """Read cpf replay's stderr until it has said a client subscribed to each of topics (live_port read the lines
    before)."""
    assert proc.stderr is not None
    waiting = set(topics)
    while waiting and (line := proc.stderr.readline()):
        waiting -= {topic for topic in topics if line.strip() == f"cpf replay: a client subscribed to {topic}"}
    assert not waiting, f"cpf replay did not say a client subscribed to {sorted(waiting)} (exit {proc.poll()})"


def log_scene(path: Path) -> list[tuple[str, int, object]]:
    return [(m.topic, m.log_time, m.message) for m in logfile.messages(path, is_scene_topic)]


def valid(received: list[Received]) -> None:
    for r in received:
        name = schema_name(r.topic)
        assert name is not None
        jsonschema.validate(r.message, schema(name))


@pytest.fixture(scope="module")
def inprocess_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 30 s paper run with a link fault, in process (its records in a deterministic order)."""
    tmp_path = tmp_path_factory.mktemp("live")
    out = tmp_path / "run.mcap"
    done = cpf("run", str(scenario(tmp_path, 30)), "--engine", "inprocess", "--fault", LINK_FAULT,
               "--out", str(out), "--quiet", cwd=tmp_path)  # fmt: skip
    assert done.returncode == 0, done.stderr
    return out


def live_scene_of(records: list[tuple[str, Any]]) -> list[tuple[str, int, Any]]:
    """The live builder's messages, each instant as it completes (none may be left for the end)."""
    live, made = LiveScene(), list[tuple[str, int, Any]]()
    for topic, message in records:
        made += [(scene_topic, round(t * 1e9), m) for scene_topic, t, m in live.take(topic, message)]
    assert live.finish() == []
    return made


def assert_the_logs_scene(made: list[tuple[str, int, Any]], out: Path) -> None:
    expected = [record for record in log_scene(out) if record[0] != PATHS_TOPIC]
    assert len(expected) == 60 * 8  # 60 instants: transforms, scene, 3 trails, 3 vehicles' coordination
    assert [record for record in made if record[0] != PATHS_TOPIC] == expected
    paths = [(t, m) for topic, t, m in made if topic == PATHS_TOPIC]  # drawn at once, further when a vehicle leaves it
    assert paths[0][0] == 0 and len(paths) <= 5
    assert all(len(m["entities"]) == 3 for _, m in paths)


def test_the_live_scene_is_the_logs_scene_instant_by_instant(inprocess_log: Path) -> None:
    """Fed the records of a log in the order they were written, the live builder gives every transform, scene and
    trail message of the log's scene, each as soon as its instant is complete (none left for the end)."""
    records = [(m.topic, m.message) for m in logfile.messages(inprocess_log, lambda topic: not is_scene_topic(topic))]
    assert_the_logs_scene(live_scene_of(records), inprocess_log)


def test_link_events_overtaken_by_the_next_states_still_reach_their_instant(inprocess_log: Path) -> None:
    """On the realtime clock the broker's link events of t_k can come in after a vehicle's state of step k + 1 (its
    own connection; seen under load: a link going down at t_k shown up live). Records so reordered, every event
    after the states of the next step, give the same scene."""
    records = [(m.topic, m.message) for m in logfile.messages(inprocess_log, lambda topic: not is_scene_topic(topic))]
    held: list[tuple[str, Any]] = []
    reordered: list[tuple[str, Any]] = []
    assert sum(topic in EVENT_TOPICS for topic, _ in records) > 100  # a step's events, a record each step
    for topic, message in records:
        if topic in EVENT_TOPICS:
            held.append((topic, message))
            continue
        reordered.append((topic, message))
        if held and topic.endswith("/state") and isinstance(message, dict) and message["t"] > held[0][1]["t"]:
            reordered += held
            held = []
    assert_the_logs_scene(live_scene_of(reordered + held), inprocess_log)


def test_a_client_watches_a_run_live_and_the_run_ends_cleanly_with_it_connected(tmp_path: Path) -> None:
    out = tmp_path / "run.mcap"
    args = ["run", str(scenario(tmp_path, 20)), "--clock", "realtime", "--speed", "10", "--fault", LINK_FAULT,
            "--live", "0", "--out", str(out), "--quiet"]  # fmt: skip
    with running(args, tmp_path) as proc, FoxgloveClient.open(live_port(proc), {SCENE_TOPIC, TRANSFORMS_TOPIC}) as c:
        assert c.channels[SCENE_TOPIC]["schemaName"] == "foxglove.SceneUpdate"
        assert c.channels[TRANSFORMS_TOPIC]["schemaName"] == "foxglove.FrameTransforms"
        assert {c.channels[t]["encoding"] for t in (SCENE_TOPIC, TRANSFORMS_TOPIC)} == {"json"}
        c.subscribe([SCENE_TOPIC, TRANSFORMS_TOPIC])
        first = c.receive()
        assert first is not None and proc.poll() is None  # the run still going
        received = [first]
        while (r := c.receive(CLOSE_WAIT)) is not None:  # None: the server closed the connection as the run ended
            received.append(r)
        assert proc.wait(timeout=60) == 0
    assert c.close_code == 1000  # normal closure: the run is over
    valid(received)
    times = [r.log_time for r in received if r.topic == TRANSFORMS_TOPIC]
    assert times == sorted(times) and len(set(times)) >= 20 and times[-1] == 19_500_000_000  # to the last instant
    assert c.times and c.times == sorted(c.times)  # the simulation time announced
    # What the client got is the log's scene, message for message (the live builder is the log's).
    logged = {(topic, t): m for topic, t, m in log_scene(out)}
    assert all(logged[(r.topic, r.log_time)] == r.message for r in received)
    faulted = [r for r in received if r.topic == SCENE_TOPIC and "link_down" in str(r.message)]
    assert faulted and all(4e9 <= r.log_time <= 8e9 for r in faulted)


def test_a_client_leaving_mid_run_leaves_the_run_unharmed(tmp_path: Path) -> None:
    out = tmp_path / "run.mcap"
    args = ["run", str(scenario(tmp_path, 20)), "--clock", "realtime", "--speed", "10", "--live", "0",
            "--out", str(out), "--quiet"]  # fmt: skip
    with running(args, tmp_path) as proc:
        with FoxgloveClient.open(live_port(proc), {TRANSFORMS_TOPIC}) as client:
            client.subscribe([TRANSFORMS_TOPIC])
            got = [client.receive() for _ in range(3)]
            assert all(r is not None for r in got) and proc.poll() is None
        assert proc.wait(timeout=60) == 0  # the client gone mid-run
    assert len([r for r in log_scene(out) if r[0] == TRANSFORMS_TOPIC]) == 40  # the log whole


def test_ctrl_c_stops_the_server_with_a_client_connected(tmp_path: Path) -> None:
    args = ["run", str(scenario(tmp_path, 200)), "--clock", "realtime", "--live", "0",
            "--out", str(tmp_path / "run.mcap"), "--quiet"]  # fmt: skip
    with running(args, tmp_path) as proc:
        port = live_port(proc)
        with FoxgloveClient.open(port, {TRANSFORMS_TOPIC}) as client:
            client.subscribe([TRANSFORMS_TOPIC])
            assert client.receive() is not None
            proc.send_signal(signal.SIGINT)
            while client.receive(CLOSE_WAIT) is not None:  # until the server closes the connection
                pass
        assert proc.wait(timeout=60) != 0
    with socket.socket() as probe:
        assert probe.connect_ex(("127.0.0.1", port)) != 0  # nobody listens there any more


def test_a_port_in_use_is_a_one_line_error_and_nothing_is_written(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        out = tmp_path / "run.mcap"
        done = cpf("run", str(scenario(tmp_path, 5)), "--engine", "inprocess", "--live", str(port),
                   "--out", str(out), cwd=tmp_path)  # fmt: skip
    assert done.returncode == 2
    errors = [line for line in done.stderr.splitlines() if line.startswith("cpf: error:")]
    assert len(errors) == 1 and f"--live: cannot serve on 127.0.0.1:{port}" in errors[0]
    assert not out.exists()


@pytest.mark.parametrize("scene", [True, False], ids=["log-scene", "built"])
def test_a_replay_serves_the_logs_scene(tmp_path: Path, scene: bool) -> None:
    """The log's own scene, or (a log without one) the scene built from its records as they are replayed: the same
    messages either way, paced with the replay."""
    out = tmp_path / "run.mcap"
    flags = [] if scene else ["--no-foxglove"]
    done = cpf("run", str(scenario(tmp_path, 20)), "--engine", "inprocess", "--fault", LINK_FAULT, *flags,
               "--out", str(out), "--quiet", cwd=tmp_path)  # fmt: skip
    assert done.returncode == 0, done.stderr
    reference = tmp_path / "reference.mcap"
    assert cpf("run", str(scenario(tmp_path, 20)), "--engine", "inprocess", "--fault", LINK_FAULT,
               "--out", str(reference), "--quiet", cwd=tmp_path).returncode == 0  # fmt: skip
    args = ["replay", str(out), "--speed", "20", "--live", "0", "--quiet"]
    wanted = [TRANSFORMS_TOPIC, SCENE_TOPIC]
    with running(args, tmp_path, stdin=True) as proc, FoxgloveClient.open(live_port(proc), set(wanted)) as client:
        client.subscribe(wanted)
        told_subscribed(proc, wanted)  # the server has the subscriptions: what is replayed now reaches the client
        assert proc.poll() is None and proc.stdin is not None  # waiting for Enter: nothing replayed yet
        proc.stdin.write("\n")
        proc.stdin.close()
        received = []
        while (r := client.receive()) is not None:
            received.append(r)
        assert proc.wait(timeout=60) == 0
    expected = [(t, ns, m) for t, ns, m in log_scene(reference) if t in wanted]
    assert [(r.topic, r.log_time, r.message) for r in received] == expected


def test_nobody_watching_no_scene_is_built_and_nothing_served(tmp_path: Path) -> None:
    """The cost of --live with nobody connected: the records pass by, the scene keeps only the run's meta, graphs
    and faults (what a client coming later needs), no instant is built, nothing is encoded."""
    out = tmp_path / "run.mcap"
    done = cpf("run", str(scenario(tmp_path, 10)), "--engine", "inprocess", "--fault", LINK_FAULT,
               "--out", str(out), "--quiet", cwd=tmp_path)  # fmt: skip
    assert done.returncode == 0, done.stderr
    with LiveView(0) as view:
        for m in logfile.messages(out, lambda topic: not is_scene_topic(topic)):
            view.take(m.topic, m.log_time / 1e9, m.message)
        view.finish()
        assert view.scene is not None
        history = view.scene.history
        assert view.scene.emitted == -1 and not history.states and not history.outcomes
        assert history.meta is not None and len(history.faults) == 2 and view.served == 0


@pytest.mark.parametrize("offered", ["foxglove.websocket.v1", "foxglove.sdk.v1"])
def test_either_name_of_the_protocol_is_accepted(offered: str) -> None:
    """Foxglove's own client library (@foxglove/ws-protocol) offers only the protocol's first name; foxglove-sdk's
    clients its new one: each is answered with the name it offered, and served."""
    with LiveView(0) as view, FoxgloveClient.open(view.port, {TRANSFORMS_TOPIC}, [Subprotocol(offered)]) as client:
        assert client.ws.subprotocol == offered and client.server_info["name"] == "cpf"


def test_a_client_that_joins_late_gets_the_meta_the_graph_and_the_paths_at_once(inprocess_log: Path) -> None:
    """What a new subscriber needs, sent when it subscribes, whenever that is (latched): the run's meta and graph
    (from its start), the desired paths as last drawn, while the run goes on (no record comes in meanwhile)."""
    records = [(m.topic, m.log_time / 1e9, m.message)
               for m in logfile.messages(inprocess_log, lambda topic: not is_scene_topic(topic))]  # fmt: skip
    assert records[0][0] == META_KEY
    # What the view's scene takes: watched from its first look after the first client came (WATCH_PERIOD).
    made = live_scene_of([(topic, m) for topic, t, m in records if topic in ALWAYS or t >= WATCH_PERIOD])
    paths = [(ns, m) for topic, ns, m in made if topic == PATHS_TOPIC]
    with LiveView(0) as view:
        view.take(*records[0])
        with FoxgloveClient.open(view.port, {TRANSFORMS_TOPIC, PATHS_TOPIC, META_KEY}) as first:
            first.subscribe([TRANSFORMS_TOPIC, PATHS_TOPIC])
            first.subscribe([META_KEY])  # handled after the first subscription, so that one is in force now:
            meta = first.receive()  # nobody watched before: the meta, latched
            assert meta is not None and meta.topic == META_KEY
            for record in records[1:]:
                view.take(*record)
            with FoxgloveClient.open(view.port, {META_KEY, GRAPH_KEY, PATHS_TOPIC}) as late:
                late.subscribe([META_KEY, GRAPH_KEY, PATHS_TOPIC])
                got = {r.topic: r for r in (late.receive(), late.receive(), late.receive()) if r is not None}
    graph = [(round(t * 1e9), m) for topic, t, m in records if topic == GRAPH_KEY]
    assert set(got) == {META_KEY, GRAPH_KEY, PATHS_TOPIC}
    assert (got[META_KEY].log_time, got[META_KEY].message) == (0, records[0][2])
    assert (got[GRAPH_KEY].log_time, got[GRAPH_KEY].message) == graph[-1]
    assert (got[PATHS_TOPIC].log_time, got[PATHS_TOPIC].message) == paths[-1]


def test_a_clients_close_is_answered_with_its_code() -> None:
    """RFC 6455, 5.5.1: an endpoint answers a close frame with one, typically echoing its code (without the answer a
    client sees 1006, abnormal closure)."""
    with LiveView(0) as view, FoxgloveClient.open(view.port, {TRANSFORMS_TOPIC}) as client:
        client.ws.close(1000, "bye")
        assert client.close_code == 1000


@pytest.mark.parametrize(("finished", "code"), [(True, 1000), (False, 1001)], ids=["run-over", "stopped"])
def test_the_view_closes_each_connection_with_a_code_as_it_stops(finished: bool, code: int) -> None:
    """After the run's end, normal closure (1000); stopped before it (Ctrl-C, an error), going away (1001)."""
    view = LiveView(0)
    try:
        with FoxgloveClient.open(view.port, {TRANSFORMS_TOPIC}) as client:
            if finished:
                view.finish()
            view.stop()
            assert client.receive() is None  # the connection closed, by the server
            assert client.close_code == code
    finally:
        view.stop()


def test_the_relay_serves_from_a_process_of_its_own_that_ends_with_the_view() -> None:
    """Its own interpreter (the engine's thread does not hold its lock: supervisor.record.relay_process), its own
    session, gone once the view has stopped; and the view serves through it meanwhile."""
    view = LiveView(0)
    try:
        assert wait_until(lambda: len(_relays()) == 1, timeout=10), _relays()  # its command line once it is exec'd
        (relay,) = _relays()
        assert os.getsid(relay) == relay
        with FoxgloveClient.open(view.port, {TRANSFORMS_TOPIC}) as client:
            view.finish()
            view.stop()
            assert client.receive() is None and client.close_code == 1000
    finally:
        view.stop()
    assert _relays() == []


def _relays() -> list[int]:
    """This process's live relays."""
    return [p for p, _ in processes_with("supervisor.record.live_relay") if _parent(p) == os.getpid()]


def _parent(pid: int) -> int:
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return 0
    return int(next(line.split()[1] for line in status.splitlines() if line.startswith("PPid:")))


def test_the_transforms_place_a_fleet_frame_at_the_centroid_for_the_camera(inprocess_log: Path) -> None:
    """world -> fleet, unrotated, at the mean of the vehicles' positions (the layout's 3-D panel follows it), in
    every transforms message of the log's scene, which the live view's is."""
    transforms: list[Any] = [m for topic, _, m in log_scene(inprocess_log) if topic == TRANSFORMS_TOPIC]
    assert len(transforms) == 60
    for message in transforms:
        frames = {tf["child_frame_id"]: tf for tf in message["transforms"]}
        assert set(frames) == {"vehicle_1", "vehicle_2", "vehicle_3", "fleet"}
        vehicles = [frames[f"vehicle_{v}"]["translation"] for v in (1, 2, 3)]
        centre = [sum(p[axis] for p in vehicles) / 3 for axis in "xyz"]
        fleet = frames["fleet"]
        assert fleet["parent_frame_id"] == "world" and fleet["rotation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
        assert [fleet["translation"][axis] for axis in "xyz"] == pytest.approx(centre, abs=1e-4)


@pytest.mark.parametrize(("interrupted", "code"), [(False, 1000), (True, 1001)], ids=["run-over", "interrupted"])
def test_a_run_interrupted_closes_its_viewers_as_stopped_not_over(tmp_path: Path, interrupted: bool, code: int) -> None:
    """Ctrl-C of `cpf run --live` told viewers 1000 'the run is over' (the log's close finished the view whatever
    ended the run; a new user): the recorder's log closes on the way out either way, the view is over only if the
    run is."""
    from supervisor.record.recorder import Recorder

    view = LiveView(0)
    try:
        with FoxgloveClient.open(view.port, {TRANSFORMS_TOPIC}) as client:
            with contextlib.suppress(KeyboardInterrupt), Recorder(tmp_path / "r.mcap", False, view):
                if interrupted:
                    raise KeyboardInterrupt
            view.stop()
            assert client.receive() is None
            assert client.close_code == code
    finally:
        view.stop()
    assert logfile.read_messages(tmp_path / "r.mcap") == []  # closed whole either way


def test_replay_tells_the_first_subscriptions_then_one_line(monkeypatch, capsys) -> None:
    """One viewer of a 100-vehicle log printed 508 'a client subscribed to' lines (a new user)."""
    import supervisor.record.live
    from supervisor.cli.live_view import TOLD, live_view

    class Fake:
        url = "ws://here"

        def __init__(self, port: int, on_subscribe: Any) -> None:
            self.on_subscribe = on_subscribe

        def __enter__(self) -> Fake:
            return self

        def __exit__(self, *exc: object) -> None:
            return None

    monkeypatch.setattr(supervisor.record.live, "LiveView", Fake)
    with live_view(0, "cpf replay", tell_subscriptions=True) as view:
        for n in range(3 * TOLD):
            view.on_subscribe(f"topic/{n}")  # type: ignore[union-attr]
    lines = capsys.readouterr().err.splitlines()[1:]
    assert lines == [f"cpf replay: a client subscribed to topic/{n}" for n in range(TOLD)] + [
        "cpf replay: (more subscriptions, not shown)"
    ]


def test_a_viewer_that_reads_nothing_does_not_hold_the_views_stop() -> None:
    """A viewer that stopped reading held `cpf run --live` ~50 s after the run (a new user): the server's stop waited
    on the relay, whose reading of the server waited on that viewer. The relay lets such a viewer go after STALLED s."""
    import time

    from supervisor.record.live_relay import STALLED

    view = LiveView(0)
    try:
        view.publish("test/bulk", 0.0, {"n": 0})
        with FoxgloveClient.open(view.port, {"test/bulk"}) as client:
            client.subscribe(["test/bulk"])  # from here on it reads nothing
            assert wait_until(lambda: view._channels["test/bulk"].has_sinks(), timeout=10)
            blob = "x" * 20000
            for n in range(2000):  # 40 MB: more than every buffer between the server and the viewer holds
                view.publish("test/bulk", n * 0.001, {"n": n, "blob": blob})
            view.finish()
            began = time.monotonic()
            view.stop()
            assert time.monotonic() - began < STALLED + 5.0
    finally:
        view.stop()
