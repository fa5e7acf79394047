"""Steering a replay while it runs (`cpf replay`): commands from a Zenoh query or the keyboard, applied to its player.

A query on CONTROL_KEY (`cpf/replay/control`) carries one small command, as text or JSON:

    pause | resume | state | seek t=120.5 | seek dt=-10 | speed x=4
    {"command": "seek", "t": 120.5}

and is answered with the replay's state after it, JSON `{"t": ..., "speed": ..., "paused": ..., ...}`; an empty
payload asks the state alone. A command that does not parse gets an error reply (JSON `{"error": ...}`) and is
counted, never more. The queryable is declared on the replay's own session, the one it publishes on: no other door
is opened, so exactly who the bus admits may steer it (a router with access control lets through only the queries
its rules allow on this key).

`Control` holds the player (supervisor.tools.replay_player) under one lock: the replay loop asks it for the next
action and waits on it, and a command from any thread wakes the loop at once.
"""

from __future__ import annotations

import json
import logging
import math
import threading
import time
from collections.abc import Callable
from typing import Any, cast

import zenoh

from comms.records.bounded import brief
from comms.records.messages import ROOT
from supervisor.tools.replay_player import MAX_SPEED, Command, Done, Player, PlayerState, Publish, Verb, Wait

log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)
CONTROL_KEY = f"{ROOT}/replay/control"
MAX_PAYLOAD = 1024  # bytes: a command is a few words
IDLE = 1.0  # s a paused loop waits at most before looking again (a command wakes it before)
ARGUMENTS: dict[str, tuple[str, ...]] = {"state": (), "pause": (), "resume": (), "seek": ("t", "dt"), "speed": ("x",)}
Listener = Callable[[Command, PlayerState], None]


def parse_command(text: str) -> Command:
    """A remote command (the module's forms); ValueError saying what is wrong."""
    text = text.strip()
    if not text:
        return Command("state")
    fields = _json_fields(text) if text.startswith("{") else _text_fields(text)
    verb = _verb(fields.pop("command", None))
    allowed = ARGUMENTS[verb]
    if set(fields) - set(allowed) or (allowed and len(fields) != 1):
        wanted = " or ".join(f"{name}=NUMBER" for name in allowed) or "no argument"
        raise ValueError(f"{verb} takes {wanted}, got {', '.join(fields) or 'none'}")
    if not allowed:
        return Command(verb)
    ((name, raw),) = fields.items()
    return Command("skip" if name == "dt" else verb, _value(name, raw))


def _verb(verb: Any) -> Verb:
    if not isinstance(verb, str) or verb not in ARGUMENTS:
        raise ValueError(f"unknown command {brief(verb)}: expected one of {', '.join(ARGUMENTS)}")
    return cast(Verb, verb)


def _json_fields(text: str) -> dict[str, Any]:
    """A JSON command's fields: one flat object, its nesting refused before the JSON reader recurses into it."""
    if text.count("{") + text.count("[") > 1:
        raise ValueError("a JSON command is one flat object of names and numbers")
    try:
        data = json.loads(text)
    except ValueError:
        raise ValueError("not JSON") from None
    if not isinstance(data, dict):
        raise ValueError("JSON command must be an object")
    return dict(data)


def _text_fields(text: str) -> dict[str, Any]:
    verb, *rest = text.split()
    fields: dict[str, Any] = {"command": _verb(verb)}
    for item in rest:
        name, equals, value = item.partition("=")
        if not equals or name in fields:
            raise ValueError(f"expected NAME=NUMBER once each, got {item!r}")
        fields[name] = value
    return fields


def _value(name: str, raw: Any) -> float:
    """The argument as a number within its range (t >= 0, dt any, x 0-MAX_SPEED), all finite."""
    try:
        value = float(raw) if isinstance(raw, str | int | float) and not isinstance(raw, bool) else math.nan
    except ValueError:
        value = math.nan
    low, high = {"t": (0.0, math.inf), "dt": (-math.inf, math.inf), "x": (0.0, MAX_SPEED)}[name]
    if not (math.isfinite(value) and low <= value <= high):
        limits = {"t": "a log time >= 0 s", "dt": "a finite step in s", "x": f"a speed within 0-{MAX_SPEED:g}"}
        raise ValueError(f"{name} must be {limits[name]}, got {brief(raw)}")
    return value


class Control:
    """A player shared by the replay loop (next_action) and whoever steers it (command, answer), thread-safe."""

    def __init__(self, player: Player, clock: Callable[[], float] = time.monotonic) -> None:
        self._player = player
        self._clock = clock
        self._changed = threading.Condition()
        self.rejected = 0  # remote commands that did not parse
        self.listeners: list[Listener] = []  # told of every command carried out, with the state after it

    @property
    def passes(self) -> int:
        return self._player.passes  # an int read whole: no lock needed for the loop's own counting

    def next_action(self) -> Publish | Done:
        """The next record (or seek mark) to publish once it is due, or Done; waits meanwhile, woken by commands."""
        with self._changed:
            while True:
                action = self._player.step(self._clock())
                if not isinstance(action, Wait):
                    return action
                self._changed.wait(IDLE if action.seconds is None else min(action.seconds, IDLE))

    def command(self, command: Command) -> PlayerState:
        with self._changed:
            self._player.apply(command, self._clock())
            state = self._player.state(self._clock())
            self._changed.notify_all()
        for listener in self.listeners:
            listener(command, state)
        return state

    def state(self) -> PlayerState:
        with self._changed:
            return self._player.state(self._clock())

    def answer(self, payload: bytes) -> tuple[bool, dict[str, Any]]:
        """(accepted, reply message) for a query's payload; a rejected one is counted."""
        try:
            if len(payload) > MAX_PAYLOAD:
                raise ValueError(f"a command is at most {MAX_PAYLOAD} bytes, got {len(payload)}")
            command = parse_command(payload.decode("utf-8"))
        except (ValueError, UnicodeDecodeError) as exc:
            with self._changed:
                self.rejected += 1
            return False, {"error": str(exc)}
        return True, self.command(command).to_message()


def declare_control(session: zenoh.Session, control: Control) -> zenoh.Queryable[None]:
    """The queryable on CONTROL_KEY, on the replay's session; keep it as long as the replay runs."""

    def on_query(query: zenoh.Query) -> None:
        payload = b"" if query.payload is None else query.payload.to_bytes()
        try:
            accepted, message = control.answer(payload)
        except Exception as exc:  # a Zenoh callback must not raise: say it and answer with the error
            log.exception("replay control: %s", exc)
            accepted, message = False, {"error": f"internal error: {exc}"}
        body = json.dumps(message)
        if accepted:
            query.reply(CONTROL_KEY, body, encoding=zenoh.Encoding.APPLICATION_JSON)
        else:
            query.reply_err(body, encoding=zenoh.Encoding.APPLICATION_JSON)

    return session.declare_queryable(CONTROL_KEY, on_query)
