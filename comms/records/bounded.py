"""The one reader of bus bytes: every message any process takes off the bus (the supervisor's intake, the broker, the
vehicles, the hello replies, the stop message) is read here, bounded in size and depth before anything walks it, and
everything it refuses is a ValueError naming its cause (`dropped`, `cause_of`), which the receiver counts and drops.

msgpack's C unpacker reads without recursing (its own stack of 1024 levels, StackError beyond); the level-by-level walk
below then holds the message to MAX_DEPTH, so no later reader (msgspec's conversions, an error message) meets a value
deeper than a cpf message can be. Error messages show a value through `brief`, never its full repr: a value off the
bus may be as large and as deep as the bound allows.
"""

from __future__ import annotations

import reprlib
from collections.abc import Iterable
from itertools import compress
from typing import Any

import msgpack

MAX_BYTES = 64 * 2**20  # a message: the broker's step message of a 10,000-vehicle fleet's window stays far below
MAX_DEPTH = 16  # nested maps and lists: a cpf message has at most 7 (a window's step, its batch, a delivery, ...)
# The causes of a drop, as every reader (supervisor, broker, vehicles) counts them.
TOO_LARGE = "too large"
TOO_DEEP = "too deep"
UNDECODABLE = "undecodable"
MALFORMED = "malformed"
_NESTED = frozenset((dict, list, tuple)).__contains__
_KEY = frozenset((str, int)).__contains__
_BRIEF = reprlib.Repr()
_BRIEF.maxlevel, _BRIEF.maxstring, _BRIEF.maxother, _BRIEF.maxlist, _BRIEF.maxdict = 2, 40, 40, 4, 4


def dropped(cause: str, reason: str) -> ValueError:
    """The ValueError of a message (or a part of one) a receiver drops, and why: its `cause` one of the names every
    reader counts by (an attribute: supervisor/errors.py holds the project's only exception classes, above comms)."""
    exc = ValueError(reason)
    exc.cause = cause  # type: ignore[attr-defined]
    return exc


def cause_of(exc: BaseException) -> str:
    """The cause a drop is counted under: its own (dropped), MALFORMED for any other refusal."""
    cause = getattr(exc, "cause", None)
    return cause if isinstance(cause, str) else TOO_DEEP if isinstance(exc, RecursionError) else MALFORMED


def brief(value: object) -> str:
    """A value's repr cut to a few dozen characters and two levels: safe for any value off the bus."""
    return _BRIEF.repr(value)


def read_bytes(payload: bytes, what: str = "message") -> Any:
    """The value msgpack packs in payload: ValueError (dropped: TOO_LARGE, UNDECODABLE, TOO_DEEP) for one that is
    larger than MAX_BYTES, not msgpack, or nested deeper than MAX_DEPTH."""
    if len(payload) > MAX_BYTES:
        raise dropped(TOO_LARGE, f"{what} of {len(payload)} bytes, more than {MAX_BYTES}")
    try:
        value = msgpack.unpackb(payload, raw=False, strict_map_key=False)
    except msgpack.StackError:
        raise dropped(TOO_DEEP, f"{what} nested deeper than {MAX_DEPTH}") from None
    except Exception as exc:  # msgpack raises several unrelated types for garbage
        raise dropped(UNDECODABLE, f"undecodable {what}: {brief(str(exc))}") from None
    _shallow(value, what)
    return value


def _shallow(value: object, what: str) -> None:
    """ValueError (dropped) unless value nests at most MAX_DEPTH maps and lists and its map keys are strings or
    integers. Level by level, without recursing, each level's containers picked out in C (compress)."""
    level = [value] if _NESTED(type(value)) else []
    for _ in range(MAX_DEPTH + 1):
        if not level:
            return
        inner: list[object] = []
        for container in level:
            items: Iterable[object] = container  # type: ignore[assignment]
            if isinstance(container, dict):
                if not all(map(_KEY, map(type, container))):
                    raise dropped(MALFORMED, f"{what} has a map key that is neither a string nor an integer")
                items = container.values()
            inner.extend(compress(items, map(_NESTED, map(type, items))))
        level = inner
    raise dropped(TOO_DEEP, f"{what} nested deeper than {MAX_DEPTH}")
