"""The replay's player (supervisor/tools/replay_player.py) and its commands (replay_control.parse_command), pure:
a list of records for a log, wall time given as numbers, no Zenoh and no sleeping."""

from __future__ import annotations

import re
from collections.abc import Iterator

import pytest

from supervisor.tools.replay_control import Control, parse_command
from supervisor.tools.replay_player import (
    SEEK_KEY,
    Command,
    Done,
    Player,
    Publish,
    Record,
    Wait,
    seconds_to_ns,
)

RECORDS: list[Record] = [("cpf/x", seconds_to_ns(0.5 * k), {"k": k}) for k in range(21)]  # every 0.5 s, 0-10 s


def source(t: float | None) -> Iterator[Record]:
    """The records from log time t on (as the replay opens its log at a seek's target)."""
    lo = 0 if t is None else seconds_to_ns(t)
    return iter([record for record in RECORDS if record[1] >= lo])


def player(speed: float = 1.0, loop: bool = False) -> Player:
    return Player(source, speed, (0.0, 10.0), loop)


def due(p: Player, now: float) -> list[Publish]:
    """Everything the player publishes at wall time now (until it waits or is done)."""
    out: list[Publish] = []
    while isinstance(action := p.step(now), Publish):
        out.append(action)
    return out


def waits(p: Player, now: float) -> float | None:
    """How long the player says to wait at now (it must say to wait)."""
    action = p.step(now)
    assert isinstance(action, Wait)
    return action.seconds


def ks(published: list[Publish]) -> list[int]:
    return [p.message["k"] for p in published if not p.mark]


def test_records_go_out_when_log_time_reaches_them_at_speed() -> None:
    p = player(speed=2.0)
    assert ks(due(p, 100.0)) == [0]  # the first record sets the clock
    assert waits(p, 100.0) == pytest.approx(0.25)  # 0.5 s of log at 2x
    assert ks(due(p, 100.2)) == []
    assert ks(due(p, 100.25)) == [1]
    assert ks(due(p, 101.0)) == [2, 3, 4]
    assert p.state(101.0).time == pytest.approx(2.0)


def test_pause_holds_log_time_and_resume_continues_from_it() -> None:
    p = player()
    due(p, 0.0)
    assert ks(due(p, 1.2)) == [1, 2]
    p.apply(Command("pause"), 1.2)
    assert p.step(50.0) == Wait(None)  # paused: nothing is due, however long it lasts
    assert due(p, 60.0) == [] and p.state(60.0).time == pytest.approx(1.2) and p.state(60.0).paused
    p.apply(Command("resume"), 100.0)
    assert p.state(100.0).time == pytest.approx(1.2)
    assert waits(p, 100.0) == pytest.approx(0.3)  # record 3 (1.5 s) is 0.3 s after where it paused
    assert ks(due(p, 100.3)) == [3]
    p.apply(Command("toggle"), 100.3)
    assert p.paused
    p.apply(Command("toggle"), 100.3)
    assert not p.paused


def test_speed_changes_the_rate_from_where_the_replay_stands() -> None:
    p = player()
    due(p, 0.0)
    due(p, 1.0)  # at log time 1.0 s
    p.apply(Command("speed", 4.0), 1.0)
    assert p.state(1.5).time == pytest.approx(3.0)  # 0.5 s of wall time at 4x
    assert ks(due(p, 1.5)) == [3, 4, 5, 6]
    p.apply(Command("slower"), 1.5)
    p.apply(Command("slower"), 1.5)
    assert p.speed == 1.0 and p.state(2.5).time == pytest.approx(4.0)
    p.apply(Command("faster"), 2.5)
    assert p.speed == 2.0


def test_speed_zero_publishes_everything_at_once_and_slower_goes_back_to_real_time() -> None:
    p = player(speed=0.0)
    assert ks(due(p, 5.0)) == list(range(21))
    assert p.step(5.0) == Done()
    q = player(speed=0.0)
    due_first = q.step(0.0)
    assert isinstance(due_first, Publish)
    q.apply(Command("slower"), 0.0)
    assert q.speed == 1.0 and waits(q, 0.0) == pytest.approx(0.5)


def test_seek_marks_the_jump_and_replays_from_its_target_backwards_and_forwards() -> None:
    p = player()
    due(p, 0.0)
    assert ks(due(p, 4.0)) == list(range(1, 9))
    p.apply(Command("seek", 1.0), 4.0)
    mark, *after = due(p, 4.0)
    assert (mark.topic, mark.stamp, mark.mark) == (SEEK_KEY, seconds_to_ns(1.0), True)
    assert mark.message == {"from": pytest.approx(4.0), "to": 1.0, "seek": 1}
    assert ks(after) == [2]  # the record at the target is due at once
    assert ks(due(p, 4.5)) == [3]
    p.apply(Command("skip", 10.0), 4.5)  # 1.5 + 10 s: held to the window's end
    mark, *after = due(p, 4.5)
    assert mark.message["to"] == 10.0 and ks(after) == [20]
    p.apply(Command("skip", -100.0), 4.5)  # held to its start
    assert due(p, 4.5)[0].message["to"] == 0.0 and p.seeks == 3


def test_without_a_seek_every_record_goes_out_once_in_order_whatever_the_commands() -> None:
    """Pauses, resumes and speed changes at arbitrary wall times never repeat or drop a record."""
    p = player()
    commands = [Command("pause"), Command("speed", 3.0), Command("resume"), Command("faster"), Command("toggle"),
                Command("toggle"), Command("slower"), Command("speed", 0.0), Command("speed", 0.5)]  # fmt: skip
    seen: list[int] = []
    now = 0.0
    for command in commands * 3:
        seen += ks(due(p, now))
        p.apply(command, now)
        now += 0.7
    while not isinstance(action := p.step(now), Done):
        if isinstance(action, Publish):
            seen.append(action.message["k"])
        elif action.seconds is None:
            p.apply(Command("resume"), now)
        else:
            now += action.seconds
    assert seen == list(range(21))


def test_a_seek_replays_in_order_from_its_target_and_skips_only_what_it_jumped() -> None:
    p = player(speed=0.0)
    out: list[Publish] = []
    for _ in range(5):
        action = p.step(0.0)
        assert isinstance(action, Publish)
        out.append(action)
    p.apply(Command("seek", 1.0), 0.0)  # back from 2.0 s
    rest = due(p, 0.0)
    assert ks(out) == [0, 1, 2, 3, 4]
    assert rest[0].mark and rest[0].message["from"] == 2.0
    assert ks(rest[1:]) == list(range(2, 21))  # from 1.0 s on, in order, each once


def test_loop_starts_the_window_again_and_counts_passes_and_quit_ends_it() -> None:
    p = player(speed=0.0, loop=True)
    published: list[int] = []
    while len(published) < 50:
        action = p.step(0.0)
        if isinstance(action, Publish):
            published.append(action.message["k"])
    assert published == [*range(21), *range(21), *range(8)] and p.passes == 2
    p.apply(Command("quit"), 0.0)
    assert p.step(0.0) == Done(quit=True) and p.state(0.0).done


def test_an_empty_source_ends_a_looping_player_instead_of_spinning() -> None:
    p = Player(lambda t: iter([]), 0.0, (0.0, None), loop=True)
    assert p.step(0.0) == Done() and p.passes == 1


@pytest.mark.parametrize(
    ("text", "command"),
    [
        ("", Command("state")),
        ("pause", Command("pause")),
        ("  resume\n", Command("resume")),
        ("seek t=120.5", Command("seek", 120.5)),
        ("seek dt=-10", Command("skip", -10.0)),
        ("speed x=4", Command("speed", 4.0)),
        ("speed x=0", Command("speed", 0.0)),
        ('{"command": "seek", "t": 3}', Command("seek", 3.0)),
        ('{"command": "pause"}', Command("pause")),
    ],
)
def test_remote_commands_parse_as_text_or_json(text: str, command: Command) -> None:
    assert parse_command(text) == command


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("jump", "unknown command 'jump'"),
        ("quit", "unknown command 'quit'"),  # the keyboard's alone
        ("seek", "seek takes t=NUMBER or dt=NUMBER, got none"),
        ("seek t=1 dt=2", "seek takes t=NUMBER or dt=NUMBER, got t, dt"),
        ("seek t=-1", "t must be a log time >= 0 s, got '-1'"),
        ("seek t=nan", "t must be a log time >= 0 s"),
        ("speed x=fast", "x must be a speed within 0-1e+06, got 'fast'"),
        ("speed x=1e7", "x must be a speed within 0-1e+06"),
        ("speed 4", "expected NAME=NUMBER once each, got '4'"),
        ("pause now=1", "pause takes no argument, got now"),
        ('{"command": "seek", "t": true}', "t must be a log time >= 0 s"),
        ('{"command": "seek"', "not JSON"),
        ("[1, 2]", "unknown command '[1,'"),
        ('["pause"]', "unknown command"),
    ],
)
def test_malformed_commands_are_refused_saying_why(text: str, problem: str) -> None:
    with pytest.raises(ValueError, match=re.escape(problem)):
        parse_command(text)


def test_control_answers_with_the_state_and_counts_what_it_rejects() -> None:
    now = [10.0]
    control = Control(player(), clock=lambda: now[0])
    assert control.next_action().message == {"k": 0}  # type: ignore[union-attr]
    heard: list[tuple[str, bool]] = []
    control.listeners.append(lambda command, state: heard.append((command.verb, state.paused)))
    ok, state = control.answer(b"pause")
    assert ok and state["paused"] is True and state["t"] == pytest.approx(0.0) and state["speed"] == 1.0
    ok, state = control.answer(b"speed x=8")
    assert ok and state == {"t": 0.0, "speed": 8.0, "paused": True, "passes": 0, "seeks": 0, "done": False}
    for bad in (b"seek t=oops", b"\xff\xfe", b"x" * 2000):
        ok, reply = control.answer(bad)
        assert not ok and "error" in reply
    assert control.rejected == 3 and heard == [("pause", True), ("speed", True)]
