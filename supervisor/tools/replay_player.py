"""The player of a steerable replay (`cpf replay`): which record goes out next, and when, under pause, seek and speed.

Pure: no Zenoh, no threads, no clock of its own. Every call takes `now`, the wall time (s, monotonic) the caller read,
so a test drives it with numbers. The replay loop (supervisor/tools/replay.py) asks `step(now)` and gets one of:

- `Publish(topic, stamp, message)`: put it on the bus now;
- `Wait(seconds)`: nothing is due for that long (None: paused, until a command);
- `Done()`: the window is over (and not looping) or the user quit.

The clock maps wall time to log time: t_log = anchor_log + (now - anchor_wall) * speed, re-anchored at every
command, so a pause holds the log time, a resume continues from it and a speed change bends the line where it is.
Speed 0 means as fast as possible: every record is due at once and the clock stands where publishing is.
Records come from `source(t)`: the window's records from log time t on (None: the window's start), as a
subscriber must see them from there (supervisor.tools.replay: latched meta, graph and faults first). A seek drops the
records not yet published and opens the source at the target; before the first of them the player publishes a
mark on SEEK_KEY, so a subscriber knows that what follows starts again at `to` (it may be earlier than what it saw).
Without a seek every record of the source goes out once, in its order.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, Literal

from comms.records.messages import ROOT

NS_PER_S = 1e9
SEEK_KEY = f"{ROOT}/replay/seek"  # {"from": s, "to": s, "seek": n}: what follows starts at log time `to`
MAX_SPEED = 1e6  # as `cpf replay --speed`
ROUNDING = 1e-6  # s: a record this close to its time is due (wall times in float s do not add up exactly)
MIN_SPEED = 1e-3  # '-' stops halving here: a slower replay would look stopped without saying so
Record = tuple[str, int, Any]  # (topic, log time ns, message)
Source = Callable[[float | None], Iterator[Record]]
Verb = Literal["state", "pause", "resume", "toggle", "seek", "skip", "speed", "faster", "slower", "quit"]


@dataclass(frozen=True, slots=True)
class Command:
    """What a user asks: seek takes a log time t (s), skip a step dt (s, either sign), speed a factor x (0: as fast
    as possible); faster and slower double and halve the speed; state changes nothing (it asks for the state)."""

    verb: Verb
    value: float | None = None


@dataclass(frozen=True, slots=True)
class PlayerState:
    """What a replay is doing, as the control query answers it."""

    time: float  # log time (s) the replay stands at
    speed: float
    paused: bool
    passes: int  # complete passes over the window
    seeks: int
    done: bool

    def to_message(self) -> dict[str, Any]:
        return {"t": self.time, "speed": self.speed, "paused": self.paused, "passes": self.passes,
                "seeks": self.seeks, "done": self.done}  # fmt: skip


@dataclass(frozen=True, slots=True)
class Publish:
    topic: str
    stamp: int  # log time ns
    message: Any
    mark: bool = False  # a seek mark (SEEK_KEY), not a record of the log


@dataclass(frozen=True, slots=True)
class Wait:
    seconds: float | None  # None: paused, nothing is due until a command


@dataclass(frozen=True, slots=True)
class Done:
    quit: bool = False  # the user asked to stop (else the window is over)


Action = Publish | Wait | Done


class Player:
    """One replay's position, clock and record stream. bounds: (first, last) log time in s a seek is held within
    (last None: no known end)."""

    def __init__(
        self, source: Source, speed: float, bounds: tuple[float, float | None], loop: bool = False, now: float = 0.0
    ) -> None:
        self._source = source
        self._bounds = bounds
        self._loop = loop
        self.speed = speed
        self.paused = False
        self.passes = 0
        self.seeks = 0
        self._quit = False
        self._finished = False
        self._anchor: tuple[float, float] | None = None  # (wall s, log ns) the clock runs from; None: next record
        self._held = 0.0  # log ns while paused
        self._position = seconds_to_ns(bounds[0])  # log ns of the last record published (or of a seek's target)
        self._seek_from: float | None = None  # a seek not yet carried out: the log time (s) it left
        self._records: Iterator[Record] = source(None)
        self._next: Record | None = None  # the record read but not yet due
        self._in_pass = 0  # records published since the source was last opened

    # --- the loop's side ------------------------------------------------------------------------------------------

    def step(self, now: float) -> Action:
        """What to do now: publish a record (or a seek's mark), wait, or stop."""
        if self._quit or self._finished:
            return Done(self._quit)
        if self._seek_from is not None:
            return self._mark(now)
        record = self._peek()
        if record is None:  # a pass ended: finished, or the next pass opened (asked again at once)
            return Done() if self._finished else Wait(0.0)
        if self.paused:
            return Wait(None)
        if self._anchor is None:  # a pass's first record sets the clock: it goes out at once
            self._anchor = (now, float(record[1]))
        wait = self._due_in(record[1], now)
        if wait > ROUNDING:
            return Wait(wait)
        self._next = None
        self._position = record[1]
        self._in_pass += 1
        return Publish(*record)

    def _peek(self) -> Record | None:
        """The next record; None when a pass ended (then the next pass is opened, or the player is finished)."""
        if self._next is None:
            self._next = next(self._records, None)
        if self._next is not None:
            return self._next
        self.passes += 1
        if self._loop and self._in_pass > 0:  # a pass that published nothing would loop forever doing nothing
            self._reopen(None)
            self._anchor = None
        else:
            self._finished = True
        return None

    def _due_in(self, stamp: int, now: float) -> float:
        """Wall seconds until log time stamp (ns) is due; <= 0: due."""
        if self.speed == 0 or self._anchor is None:
            return 0.0
        wall, log = self._anchor
        return (stamp - log) / NS_PER_S / self.speed - (now - wall)

    def _mark(self, now: float) -> Publish:
        target = self._position
        message = {"from": self._seek_from, "to": target / NS_PER_S, "seek": self.seeks}
        self._seek_from = None
        self._reopen(target / NS_PER_S)
        self._anchor = (now, float(target))
        return Publish(SEEK_KEY, target, message, mark=True)

    def _reopen(self, t: float | None) -> None:
        close = getattr(self._records, "close", None)
        if close is not None:  # a generator over the log: let go of the file now
            close()
        self._records = self._source(t)
        self._next = None
        self._in_pass = 0

    # --- the user's side ------------------------------------------------------------------------------------------

    def time_ns(self, now: float) -> float:
        """The log time (ns) the replay stands at."""
        if self.paused:
            return self._held
        if self.speed == 0 or self._anchor is None:
            return float(self._position)
        wall, log = self._anchor
        return max(float(self._position), log + (now - wall) * self.speed * NS_PER_S)

    def state(self, now: float) -> PlayerState:
        done = self._quit or self._finished
        return PlayerState(self.time_ns(now) / NS_PER_S, self.speed, self.paused, self.passes, self.seeks, done)

    def apply(self, command: Command, now: float) -> None:
        """Carry out a command (ValueError for a value out of range: parse_command checks them first)."""
        verb, value = command.verb, command.value
        if verb == "pause" or (verb == "toggle" and not self.paused):
            self._pause(now)
        elif verb in ("resume", "toggle"):
            self._resume(now)
        elif verb == "speed":
            self._set_speed(_number(value, verb), now)
        elif verb == "faster":
            self._set_speed(min(self.speed * 2, MAX_SPEED), now)
        elif verb == "slower":  # from as fast as possible: real time
            self._set_speed(max(self.speed / 2, MIN_SPEED) if self.speed > 0 else 1.0, now)
        elif verb in ("seek", "skip"):
            step = _number(value, verb)
            self._seek(step if verb == "seek" else self.time_ns(now) / NS_PER_S + step, now)
        elif verb == "quit":
            self._quit = True

    def _pause(self, now: float) -> None:
        if not self.paused:
            self._held = self.time_ns(now)
            self.paused = True

    def _resume(self, now: float) -> None:
        if self.paused:
            self.paused = False
            self._anchor = (now, self._held)

    def _set_speed(self, speed: float, now: float) -> None:
        if not (0 <= speed <= MAX_SPEED):
            raise ValueError(f"speed must be within 0-{MAX_SPEED:g}, got {speed:g}")
        if not self.paused:
            self._anchor = (now, self.time_ns(now))
        self.speed = speed

    def _seek(self, t: float, now: float) -> None:
        """Go to log time t (s), held within the bounds; what follows is read again from there."""
        first, last = self._bounds
        target = max(first, t if last is None else min(t, last))
        self._seek_from = self.time_ns(now) / NS_PER_S if self._seek_from is None else self._seek_from
        self._position = seconds_to_ns(target)
        self._held = float(self._position)
        self._anchor = (now, float(self._position))
        self._finished = False  # a seek after the end (a looping window, or a paused last record) plays again
        self.seeks += 1


def _number(value: float | None, verb: str) -> float:
    if value is None or not math.isfinite(value):
        raise ValueError(f"{verb} needs a finite number, got {value}")
    return value


def seconds_to_ns(t: float) -> int:
    """Log time in ns (the recorder's rounding: supervisor.record.recorder.seconds_to_ns)."""
    return round(t * NS_PER_S)
