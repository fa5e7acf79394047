"""A replay publishes what a live run publishes: the same keys, messages of the same form (a subscriber written
against one works on the other), and when it starts late, the run's meta, graph and faults in force first.

    live:   cpf run (zenoh engine) --connect-> test router [subscriber cpf/**] ; log.mcap
    replay: cpf replay log.mcap   --connect-> test router [subscriber cpf/**]
"""

from __future__ import annotations

import io
import threading

import pytest
import zenoh

from comms.bus.bus import free_port, open_session
from comms.records.messages import (
    COMMS_EVENTS_KEY,
    COMMS_STEP_KEY,
    FAULT_KEY,
    GRAPH_KEY,
    META_KEY,
    STOP_KEY,
    TICK_KEY,
    Message,
    decode,
    state_key,
)
from supervisor.config.scenario import parse_scenario
from supervisor.engine.cosim import BusOptions, run_zenoh
from supervisor.engine.progress import Progress
from supervisor.record.recorder import read_messages
from supervisor.tools.replay import replay
from tests.conftest import CONFIGS, shortened
from tests.test_replay import router

pytestmark = pytest.mark.integration

DURATION = 4.0
FAULTS = ["faults.0.start=1", "faults.0.end=3.5"]  # paper.toml's speed cap, in force from 1 s to 3.5 s
LINK = ["kind=link_down,sender=1,receiver=2,start=0.5"]  # to the end of the run


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> tuple[object, list[tuple[str, Message, float]]]:
    """A live zenoh run joined to the test's router, everything it put on cpf/** collected; and its log."""
    where = tmp_path_factory.mktemp("live")
    text = shortened((CONFIGS / "paper.toml").read_text(), DURATION)
    path = where / "paper.toml"
    path.write_text(text)
    scenario = parse_scenario(text, str(path), FAULTS, LINK)
    out = where / "run.mcap"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with open_session("router", listen=[endpoint]) as session:
        stopped = threading.Event()  # the run's last message: the supervisor sends it once it has everything
        received: list[tuple[str, Message, float]] = []

        def on_sample(sample: zenoh.Sample) -> None:
            received.append((str(sample.key_expr), decode(sample.payload.to_bytes()), 0.0))
            if str(sample.key_expr) == STOP_KEY:
                stopped.set()

        session.declare_subscriber("cpf/**", on_sample)
        bus = BusOptions(connect=endpoint, overrides=tuple(FAULTS), faults=tuple(LINK))
        quiet = Progress(DURATION, io.StringIO(), enabled=False)
        run_zenoh(scenario, path, text, out, 0, "lockstep", 1.0, bus, quiet)
        assert stopped.wait(10.0), "the run's stop message never arrived"
    return out, received


def keys(received: list[tuple[str, Message, float]]) -> set[str]:
    return {key for key, _, _ in received}


def link_events(seen: list[tuple[str, Message, float]]) -> list[tuple[float, int, int, str]]:
    batches = [message for key, message, _ in seen if key == COMMS_EVENTS_KEY]
    return sorted((e["t"], e["sender"], e["receiver"], e["kind"]) for batch in batches for e in batch["events"])


def test_a_replay_publishes_the_keys_of_the_live_run_in_the_same_form(live) -> None:
    log, seen_live = live
    with router() as (endpoint, collector):
        report = replay(log, speed=0, connect=endpoint)
        seen_replay = collector.wait_for(report.messages)
    assert keys(seen_replay) == keys(seen_live)
    assert {COMMS_STEP_KEY, COMMS_EVENTS_KEY, state_key(1)} <= keys(seen_live)
    for key in keys(seen_live):
        # a lockstep tick's span is the supervisor's grant to the broker (comms.broker.span): on the bus, not in the log
        bus_only = {"span", "longest"} if key == TICK_KEY else set()
        live_fields = {field for k, m, _ in seen_live if k == key for field in m} - bus_only
        replay_fields = {field for k, m, _ in seen_replay if k == key for field in m}
        assert replay_fields == live_fields, key
    states = lambda seen: [m for k, m, _ in seen if k == state_key(2)]  # noqa: E731
    assert states(seen_replay) == sorted(states(seen_live), key=lambda m: m["k"])  # state, tx and rx alike
    assert link_events(seen_replay) == link_events(seen_live)


def test_a_replay_that_starts_late_publishes_meta_graph_and_faults_in_force_first(live) -> None:
    log, _ = live
    logged = read_messages(log)
    start = 2.0
    with router() as (endpoint, collector):
        report = replay(log, speed=0, start=start, connect=endpoint)
        seen = collector.wait_for(report.messages)
    first = [(key, message) for key, message, _ in seen[:4]]
    meta = next(m for t, _, m in logged if t == META_KEY)
    graph = [m for t, stamp, m in logged if t == GRAPH_KEY and stamp < start * 1e9][-1]
    assert first[0] == (META_KEY, meta) and first[1] == (GRAPH_KEY, graph)
    in_force = {(key, m["kind"], m["phase"]) for key, m in first[2:]}  # both started before 2 s, neither ended
    assert in_force == {(FAULT_KEY, "speed_cap", "start"), (FAULT_KEY, "link_down", "start")}
    assert min(m["t"] for key, m, _ in seen[4:]) >= start  # then the window itself
