"""`cpf replay`'s keyboard, when it runs in a terminal: space pause/resume, + and - speed, left and right arrows seek
10 s back and forth, q quit.

`key_command` (which key means what) and `split_keys` (a read of the terminal cut into keys, arrows being escape
sequences) are pure. `keyboard(control)` puts the terminal in cbreak mode (keys arrive one by one, unechoed; Ctrl-C
still interrupts) for as long as the replay plays, reads it on a thread and hands each command to the replay's
control; the terminal's settings are restored however the replay ends. When stdin is no terminal nothing is read.
"""

from __future__ import annotations

import contextlib
import os
import select
import sys
import threading
from collections.abc import Iterator
from typing import TextIO

from supervisor.tools.replay_control import Control
from supervisor.tools.replay_player import Command, PlayerState

SEEK_STEP = 10.0  # s of log time per arrow key
KEYS = {
    " ": Command("toggle"),
    "+": Command("faster"),
    "=": Command("faster"),  # + without shift on most layouts
    "-": Command("slower"),
    "\x1b[C": Command("skip", SEEK_STEP),  # right arrow (normal and application cursor mode)
    "\x1bOC": Command("skip", SEEK_STEP),
    "\x1b[D": Command("skip", -SEEK_STEP),  # left arrow
    "\x1bOD": Command("skip", -SEEK_STEP),
    "q": Command("quit"),
    "Q": Command("quit"),
}
HELP = "keys: space pause/resume, + faster, - slower, left/right seek 10 s, q quit"
POLL = 0.2  # s between looks at whether the replay ended, while no key comes


def key_command(key: str) -> Command | None:
    """The command a key stands for, None for any other key."""
    return KEYS.get(key)


def split_keys(text: str) -> list[str]:
    """The keys in what one read of the terminal gave: escape sequences (ESC [ X, ESC O X) whole, else characters."""
    keys: list[str] = []
    i = 0
    while i < len(text):
        if text[i] == "\x1b" and text[i + 1 : i + 2] in ("[", "O") and i + 2 < len(text):
            keys.append(text[i : i + 3])
            i += 3
        else:
            keys.append(text[i])
            i += 1
    return keys


def describe(command: Command, state: PlayerState) -> str:
    """One line for the user after a command: where the replay stands."""
    pace = "as fast as possible" if state.speed == 0 else f"speed {state.speed:g}x"
    status = "paused" if state.paused else "playing"
    return f"{command.verb}: {status} at t = {state.time:.1f} s, {pace}"


@contextlib.contextmanager
def keyboard(control: Control, stdin: TextIO | None = None, out: TextIO | None = None) -> Iterator[None]:
    """Steer control from the terminal on stdin (default sys.stdin) while the block runs; nothing if it is no TTY.
    Each command carried out (from here or a query) is said on out (default sys.stderr)."""
    stream = sys.stdin if stdin is None else stdin
    said = sys.stderr if out is None else out
    if not stream.isatty():
        yield
        return
    import termios  # here: POSIX only, and only a terminal needs it
    import tty

    fd = stream.fileno()
    saved = termios.tcgetattr(fd)
    ended = threading.Event()
    reader = threading.Thread(target=_read_keys, args=(fd, control, ended), name="replay-keys", daemon=True)
    control.listeners.append(lambda command, state: print(f"\r{describe(command, state)}", file=said, flush=True))
    try:
        tty.setcbreak(fd)
        print(HELP, file=said, flush=True)
        reader.start()
        yield
    finally:
        ended.set()
        if reader.is_alive():
            reader.join()
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


def _read_keys(fd: int, control: Control, ended: threading.Event) -> None:
    """Until ended or the end of input: each key's command to the control."""
    while not ended.is_set():
        ready, _, _ = select.select([fd], [], [], POLL)
        if not ready:
            continue
        data = os.read(fd, 64)
        if not data:
            return
        for key in split_keys(data.decode("utf-8", errors="replace")):
            command = key_command(key)
            if command is not None:
                control.command(command)
