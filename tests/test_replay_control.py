"""A replay steered over the bus (supervisor/tools/replay_control.py): queries on cpf/replay/control pause, resume and
seek a replay while a subscriber counts what it publishes.

    cpf replay log.mcap --connect-> test router [subscriber cpf/**, querier cpf/replay/control]

The pause is timed by events: the replay holds at its N-th message (its progress callback waits) until the test,
having seen N messages arrive, has paused it; after that nothing more may go out until it resumes.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
import zenoh

from comms.bus.bus import free_port, open_session
from supervisor.tools.replay import ReplayReport, replay
from supervisor.tools.replay_control import CONTROL_KEY
from supervisor.tools.replay_player import SEEK_KEY
from tests import test_replay
from tests.test_replay import TIMEOUT, Collector, bus_window, check_replayed

log, logged, raw = test_replay.log, test_replay.logged, test_replay.raw  # fixtures: the same recorded run

pytestmark = pytest.mark.integration
HOLD_AT = 100  # messages published before the test pauses the replay


@dataclass
class Steered:
    """A replay running on a thread, connected to the test's router, held at its HOLD_AT-th message."""

    session: zenoh.Session
    collector: Collector
    published: int = 0
    released: threading.Event = field(default_factory=threading.Event)
    report: ReplayReport | None = None

    def progress(self, t: float) -> None:
        self.published += 1
        if self.published == HOLD_AT:
            assert self.released.wait(TIMEOUT)

    def ask(self, command: str) -> tuple[bool, dict[str, Any]]:
        """(ok, reply) of one query on the control key: the replay's state or its error."""
        replies = list(self.session.get(CONTROL_KEY, payload=command, timeout=TIMEOUT))
        assert len(replies) == 1
        reply = replies[0]
        if reply.ok is not None:
            return True, json.loads(reply.ok.payload.to_bytes())
        assert reply.err is not None
        return False, json.loads(reply.err.payload.to_bytes())


@contextmanager
def steered(log_path: Path, speed: float) -> Iterator[Steered]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with open_session("router", listen=[endpoint]) as session:
        run = Steered(session, Collector(session))

        def play() -> None:
            run.report = replay(log_path, speed=speed, connect=endpoint, progress=run.progress)

        thread = threading.Thread(target=play, name="replay")
        thread.start()
        try:
            yield run
        finally:
            run.released.set()
            thread.join()


def pause_at_hold(run: Steered) -> dict[str, Any]:
    """Pause the replay once the subscriber has seen HOLD_AT messages; the state the pause answered."""
    run.collector.wait_for(HOLD_AT)
    ok, state = run.ask("pause")
    assert ok and state["paused"] is True
    run.released.set()
    return state


def test_a_replay_paused_and_resumed_over_the_bus_publishes_everything_once_in_order(log, logged) -> None:
    with steered(log, speed=0) as run:
        paused = pause_at_hold(run)
        ok, again = run.ask("state")  # time holds while paused
        assert ok and again == paused and again["t"] > 0
        assert run.collector.count() == run.published == HOLD_AT  # nothing went out after the pause
        ok, resumed = run.ask("resume")
        assert ok and resumed["paused"] is False and resumed["t"] == paused["t"]
        received = run.collector.wait_for(len(logged))
    assert run.report is not None
    check_replayed(received, logged, run.report)  # per topic: every message once, in log order
    assert [key for key, _, _ in received] == [topic for topic, _, _ in logged]  # and in the order published
    assert not run.report.interrupted and run.report.seeks == 0 and run.report.rejected == 0


def test_the_queryable_rejects_malformed_commands_with_an_error_and_counts_them(log, logged) -> None:
    with steered(log, speed=0) as run:
        pause_at_hold(run)
        answers = [run.ask(text) for text in ("seek t=oops", "jump", '{"command": 3}', "speed x=4")]
        run.ask("resume")
        run.collector.wait_for(len(logged))
    assert [ok for ok, _ in answers] == [False, False, False, True]
    assert answers[0][1] == {"error": "t must be a log time >= 0 s, got 'oops'"}
    assert answers[1][1]["error"].startswith("unknown command 'jump'")
    assert answers[3][1]["speed"] == 4.0 and answers[3][1]["paused"] is True
    assert run.report is not None and run.report.rejected == 3 and run.report.messages == len(logged)


def test_a_seek_back_is_marked_and_replays_in_order_from_its_target(log, raw, logged) -> None:
    target = 1.0
    after = bus_window(raw, target)  # what a window from the target publishes: latched state, then its records
    with steered(log, speed=0) as run:
        paused = pause_at_hold(run)
        assert paused["t"] > target  # HOLD_AT messages are past 1 s of the log: the seek goes back
        ok, state = run.ask(f"seek t={target}")
        assert ok and state["t"] == target and state["seeks"] == 1
        run.ask("resume")
        received = run.collector.wait_for(HOLD_AT + 1 + len(after))
    keys = [key for key, _, _ in received]
    assert keys[:HOLD_AT] == [topic for topic, _, _ in logged[:HOLD_AT]]
    mark = received[HOLD_AT]
    assert mark[0] == SEEK_KEY and mark[1] == {"from": paused["t"], "to": target, "seek": 1}
    assert [(key, message) for key, message, _ in received[HOLD_AT + 1 :]] == [(t, m) for t, _, m in after]
    assert run.report is not None and run.report.seeks == 1 and SEEK_KEY not in run.report.published
