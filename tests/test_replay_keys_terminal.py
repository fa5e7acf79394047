"""`cpf replay`'s keyboard (supervisor/cli/replay_keys.py): which key means what (pure), and over a pseudo-terminal:
a key reaches the replay's control, and the terminal's settings come back however the block ends."""

from __future__ import annotations

import io
import os
import pty
import termios
import threading
from collections.abc import Iterator

import pytest

from supervisor.cli.replay_keys import describe, key_command, keyboard, split_keys
from supervisor.tools.replay_control import Control
from supervisor.tools.replay_player import Command, Player, PlayerState

WAIT = 10.0  # s: a bound on an event that does come


@pytest.mark.parametrize(
    ("key", "command"),
    [
        (" ", Command("toggle")),
        ("+", Command("faster")),
        ("=", Command("faster")),
        ("-", Command("slower")),
        ("\x1b[C", Command("skip", 10.0)),
        ("\x1b[D", Command("skip", -10.0)),
        ("\x1bOC", Command("skip", 10.0)),
        ("\x1bOD", Command("skip", -10.0)),
        ("q", Command("quit")),
        ("x", None),
        ("\x1b[A", None),  # up: nothing
    ],
)
def test_keys_map_to_commands(key: str, command: Command | None) -> None:
    assert key_command(key) == command


def test_a_read_is_split_into_keys_escape_sequences_whole() -> None:
    assert split_keys(" +\x1b[D\x1b[Cq") == [" ", "+", "\x1b[D", "\x1b[C", "q"]
    assert split_keys("\x1b") == ["\x1b"]  # a lone escape stays one key (and means nothing)
    assert [key_command(k) for k in split_keys("--\x1bOC")] == [Command("slower")] * 2 + [Command("skip", 10.0)]


def test_describe_says_where_the_replay_stands() -> None:
    state = PlayerState(12.34, 0.0, True, 0, 0, False)
    assert describe(Command("pause"), state) == "pause: paused at t = 12.3 s, as fast as possible"


def idle_control() -> Control:
    return Control(Player(lambda t: iter([("cpf/x", 0, {})]), 1.0, (0.0, 1.0)), clock=lambda: 0.0)


def test_no_terminal_no_keyboard() -> None:
    control = idle_control()
    with keyboard(control, io.StringIO("q"), io.StringIO()):
        pass
    assert control.listeners == [] and not control.state().done  # nothing read, nothing told


@pytest.fixture
def terminal() -> Iterator[tuple[int, io.TextIOWrapper]]:
    """A pseudo-terminal: (master fd the test types into, the slave as the replay's stdin)."""
    master, slave = pty.openpty()
    stdin = os.fdopen(slave, "r", closefd=True)
    try:
        yield master, stdin
    finally:
        stdin.close()
        os.close(master)


def test_keys_typed_in_a_terminal_steer_the_replay_and_the_terminal_is_restored(terminal) -> None:
    master, stdin = terminal
    before = termios.tcgetattr(stdin.fileno())
    control = idle_control()
    quit_seen = threading.Event()
    out = io.StringIO()
    with keyboard(control, stdin, out):
        control.listeners.append(lambda command, state: quit_seen.set() if command.verb == "quit" else None)
        during = termios.tcgetattr(stdin.fileno())
        os.write(master, b" \x1b[C+q")
        assert quit_seen.wait(WAIT)
    state = control.state()
    assert state.paused and state.speed == 2.0 and state.done and control.state().seeks == 1
    assert during[3] & termios.ICANON == 0 and during[3] & termios.ECHO == 0  # keys one by one, unechoed
    assert during[3] & termios.ISIG  # Ctrl-C still interrupts
    assert termios.tcgetattr(stdin.fileno()) == before
    assert "keys: space pause/resume" in out.getvalue() and "toggle: paused at t = 0.0 s" in out.getvalue()


def test_the_terminal_is_restored_when_the_replay_ends_by_an_error_or_ctrl_c(terminal) -> None:
    _, stdin = terminal
    before = termios.tcgetattr(stdin.fileno())
    for error in (KeyboardInterrupt, RuntimeError):
        with pytest.raises(error), keyboard(idle_control(), stdin, io.StringIO()):
            assert termios.tcgetattr(stdin.fileno()) != before
            raise error
        assert termios.tcgetattr(stdin.fileno()) == before
