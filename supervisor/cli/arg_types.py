"""What the `cpf` options take: each a function argparse calls on the option's text, raising ArgumentTypeError with
a message naming what was expected and what came."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

from comms.records.ids import MAX_VEHICLE_ID


def number(text: str) -> float:
    """A finite number: inf and nan (which float() takes) are refused."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text}")
    return value


def within(low: float, high: float) -> Callable[[str], float]:
    """A number in [low, high]."""

    def check(text: str) -> float:
        value = number(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be within [{low:g}, {high:g}], got {text}")
        return value

    return check


def positive(text: str) -> float:
    value = number(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def whole(low: int, high: int) -> Callable[[str], int]:
    """A whole number in [low, high]."""

    def check(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text[:60]!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be within [{low}, {high}], got {text[:60]}")
        return value

    return check


seed = whole(0, 2**64 - 1)  # what the scenario's seed takes (numpy's generators take any, the log's JSON 64 bits)
step_number = whole(0, 2**63 - 1)
pace = within(0.0, 1e6)  # replay: 0 is as fast as possible
speed = within(1e-3, 1e6)  # realtime pace: simulated s per wall s (inf would never wait, a tiny one never tick)


def ids(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(part) for part in text.split(",") if part)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated vehicle ids, got {text!r}") from None


def gamma0(text: str) -> tuple[int | None, float]:
    """ID=GAMMA, or GAMMA alone (the process's one vehicle)."""
    vid, _, value = text.rpartition("=")
    if not vid:
        return None, number(value)
    return whole(1, MAX_VEHICLE_ID)(vid), number(value)


def per_process(text: str) -> int:
    """--vehicles-per-process: a whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number of vehicles, got {text[:60]!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1 (1: one process per vehicle), got {text[:60]}")
    return value
