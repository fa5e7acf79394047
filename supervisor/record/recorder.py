"""MCAP recording: one channel per key expression, JSON messages with a JSON-Schema, log time = simulation time.

The writer is closed in every case (normal end, error, Ctrl-C) so the file always ends with its summary and index.
A SIGKILL cannot be caught, so the recorder is also crash-safe: the open chunk is finished and handed to the OS
(no fsync: the OS keeps it if only the process dies) every FLUSH_INTERVAL of wall time and whenever it grows past
CHUNK_BYTES. A killed run loses at most its last FLUSH_INTERVAL of messages; `cpf recover` (record/recover.py)
rebuilds the missing summary and index from the complete chunks.

Nothing written can make the writer fail, then or at its finish: a message whose time is not finite or lies outside
[0, the run's end + TIME_MARGIN] (outside an MCAP time in any case), or that is no JSON, is refused before it reaches
the writer, counted (`refused`) and named in one warning when the recorder closes.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import logging
import math
import numbers
import os
import time
from collections import Counter
from collections.abc import Iterable
from pathlib import Path
from types import TracebackType
from typing import IO, Any, Protocol

import orjson
from mcap.writer import CompressionType

from comms.records.messages import Message
from comms.records.records import LinkEvent
from comms.records.schemas import schema_for
from comms.records.state import StateReport
from supervisor.collector import paused
from supervisor.errors import LogWriteError, ScenarioError
from supervisor.record.fast_mcap import FastWriter
from supervisor.record.scene.foxglove_schemas import MESSAGE_ENCODING, SCHEMA_ENCODING, schema_data, schema_name
from supervisor.record.scene.scene import FleetScene

PROFILE = ""  # no ROS profile: plain JSON channels
FLUSH_INTERVAL = 0.5  # s of wall time: the most a SIGKILL can take (the next write after it flushes)
CHUNK_BYTES = 512 * 1024  # uncompressed: the writer finishes a chunk this big by itself
TIME_MARGIN = 60.0  # s after the run's end a message may still be stamped (the last step, the books closed at the end)
LAST_NS = 2**64 - 1  # MCAP times are unsigned 64-bit ns
FAST_MAX = 1.8e10  # s: any float time below it is a valid MCAP time (LAST_NS is 1.8446e10 s)
SEQUENCES = 2**32  # MCAP sequence numbers are unsigned 32-bit

log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)


JSON_OPTIONS = orjson.OPT_NON_STR_KEYS | orjson.OPT_SERIALIZE_NUMPY  # NaN and inf are written as null


def seconds_to_ns(t: float) -> int:
    return round(t * 1e9)


def open_exclusively(path: Path) -> IO[bytes]:
    """path opened for writing from its start, locked (flock, exclusive) for as long as it is open: a second run on
    the same file is refused and leaves it untouched (it is truncated only once the lock is held). The lock goes with
    the process, SIGKILL included. ScenarioError if the file is in use or cannot be written."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(path, os.O_WRONLY | os.O_CREAT, 0o666)
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot write the log: {exc.strerror or exc}") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        raise ScenarioError(f"{path}: in use: another run is writing this log (choose another --out)") from None
    os.ftruncate(fd, 0)
    return os.fdopen(fd, "wb")


def in_use(path: Path) -> bool:
    """Whether another process holds path's lock (a run writing it) right now."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    finally:
        os.close(fd)  # closing releases a lock taken here
    return False


class LiveSink(Protocol):
    """Who sees the records as they are written (record.live.LiveView: `cpf run --live`)."""

    def take(self, topic: str, t: float, message: Any) -> None: ...

    def finish(self) -> None: ...


class Recorder:
    """Writes messages to an MCAP file; use as a context manager.

    With `scene` (the default) every record written also feeds the run's Foxglove scene (record.scene), whose
    messages go into the log, on their own channels, when it closes: built from the whole run, they depend on which
    records were written, never on the order they came in, so both engines write the same scene. With `live`, every
    record written is handed to it too, and it is told when the run is over (as the log closes)."""

    def __init__(self, path: Path, scene: bool = True, live: LiveSink | None = None) -> None:
        self.path = path
        self.scene: FleetScene | None = FleetScene() if scene else None
        self.live = live
        self._stream: IO[bytes] = open_exclusively(path)
        self._writer = FastWriter(self._stream, CHUNK_BYTES, CompressionType.ZSTD)
        self._writer.start(profile=PROFILE, library="cpf-cosim")
        self._channels: dict[str, int] = {}
        self._sequence = 0
        self._deadline = 0.0
        self.count = 0  # the run's messages; its Foxglove scene apart (scene_count), written as the log closes
        self.scene_count = 0
        self.horizon = LAST_NS / 1e9  # s: the latest time recorded (limit() sets the run's)
        self.refused: Counter[tuple[str, str]] = Counter()  # (key, why) of the messages not recorded
        self.failed = False  # the file could not be written (the disk full): close() writes nothing more
        self.flush()  # magic and header on disk: even a run killed at once leaves a recoverable (empty) MCAP

    def _channel(self, key: str) -> int:
        if key not in self._channels:
            foxglove = schema_name(key)
            if foxglove is not None:  # Foxglove's own schema, as Foxglove ships it
                schema_id = self._writer.register_schema(
                    name=foxglove, encoding=SCHEMA_ENCODING, data=schema_data(foxglove)
                )
                self._channels[key] = self._writer.register_channel(key, MESSAGE_ENCODING, schema_id)
                return self._channels[key]
            schema = schema_for(key)
            schema_id = 0  # no schema: a key we do not know still gets recorded
            if schema is not None:
                schema_id = self._writer.register_schema(
                    name=str(schema["title"]), encoding="jsonschema", data=json.dumps(schema).encode()
                )
            self._channels[key] = self._writer.register_channel(topic=key, message_encoding="json", schema_id=schema_id)
        return self._channels[key]

    def limit(self, end: float) -> None:
        """Refuse, from now on, any message stamped later than TIME_MARGIN after end (s), the run's end."""
        self.horizon = min(end + TIME_MARGIN, LAST_NS / 1e9)

    def write(self, key: str, t: float, message: Message) -> bool:
        """Record a message published on key at simulation time t (s). False, and counted in `refused`, for a time
        that is not finite or is outside [0, horizon], or a message that is not JSON: not recorded."""
        # Every message of a run passes here (~72000 in the paper scenario): its cheap checks first, inline.
        why = None if type(t) is float and 0.0 <= t <= self.horizon and t < FAST_MAX else self._bad_time(t)
        data = b""
        if why is None:
            try:
                data = orjson.dumps(message, option=JSON_OPTIONS)
            except TypeError as exc:  # orjson.JSONEncodeError: a type, a key, an integer or a depth JSON cannot hold
                why = f"not JSON ({exc})"
        if why is not None:
            self.refused[(key, why)] += 1
            return False
        self._add(key, t, data)
        if self.scene is not None:
            self.scene.take(key, message)
        if self.live is not None:
            self.live.take(key, t, message)
        return True

    def write_state(self, key: str, t: float, data: bytes, report: StateReport) -> None:
        """write_json of a vehicle's state, fed to the scene as its record (as write feeds it the message)."""
        if self.write_json(key, t, data) and self.scene is not None:
            self.scene.take_state(report)

    def write_events(self, key: str, t: float, data: bytes, events: Iterable[LinkEvent]) -> None:
        """write_json of a batch of link events (comms.records.events.LinkEvents), each fed to the scene as its
        record."""
        if self.write_json(key, t, data) and self.scene is not None:
            for event in events:
                self.scene.take_event(event)

    def write_json(self, key: str, t: float, data: bytes) -> bool:
        """As write, for a message already in its log form (what write would make of it: orjson, JSON_OPTIONS), and
        without feeding the scene (write_state and write_events feed it theirs; the other records it ignores)."""
        why = None if type(t) is float and 0.0 <= t <= self.horizon and t < FAST_MAX else self._bad_time(t)
        if why is not None:
            self.refused[(key, why)] += 1
            return False
        self._add(key, t, data)
        if self.live is not None:  # the live view takes messages: read back only for it (--live)
            self.live.take(key, t, orjson.loads(data))
        return True

    def _add(self, key: str, t: float, data: bytes) -> None:
        channel = self._channels.get(key)
        self._sequence += 1
        try:
            self._writer.add(
                channel if channel is not None else self._channel(key), seconds_to_ns(float(t)), data,
                self._sequence % SEQUENCES,
            )  # fmt: skip
        except OSError as exc:  # a chunk full: written now
            raise self._cannot_write(exc) from None
        self.count += 1
        if time.monotonic() >= self._deadline:
            self.flush()

    def _bad_time(self, t: object) -> str | None:
        """Why t (s) cannot be a message's time, None if it can."""
        if type(t) is float and 0.0 <= t <= self.horizon and t < FAST_MAX:  # every message of a run: checked cheaply
            return None
        if isinstance(t, bool) or not isinstance(t, numbers.Real):
            return f"time of type {type(t).__name__} is not a number"
        try:
            seconds = float(t)
        except OverflowError:  # an integer beyond any float
            return "time outside any MCAP time"
        last = min(seconds_to_ns(self.horizon), LAST_NS)
        if not math.isfinite(seconds) or abs(seconds) > self.horizon + 1 or not 0 <= seconds_to_ns(seconds) <= last:
            return f"time outside 0..{self.horizon:g} s"
        return None

    def flush(self) -> None:
        """Finish the open chunk and hand the file's bytes to the OS (no fsync): what a SIGKILL cannot take away.

        Writer.flush (public API of mcap, here 1.6.0) writes a chunk only if it holds a message: flushing an idle
        recorder costs nothing.
        """
        try:
            self._writer.flush()
        except OSError as exc:
            raise self._cannot_write(exc) from None
        self._deadline = time.monotonic() + FLUSH_INTERVAL

    def note(self, name: str, data: dict[str, str]) -> None:
        """An MCAP metadata record (what the log is drawn from: supervisor.record.provenance)."""
        try:
            self._writer.add_metadata(name, data)
        except OSError as exc:
            raise self._cannot_write(exc) from None

    def _cannot_write(self, exc: OSError) -> LogWriteError:
        """One line for a log that cannot take more (ENOSPC: the disk full); the log is left as it stands, for
        `cpf recover`, and close() then writes nothing more (it would fail again, with a traceback per attempt)."""
        self.failed = True
        why = "no space left on device" if exc.errno == errno.ENOSPC else f"cannot write ({exc.strerror or exc})"
        return LogWriteError(f"{why} writing {self.path}; `cpf recover {self.path}` keeps what was written")

    def close(self, over: bool = True) -> None:
        """The log finished and closed; over: the run ended (its live view's viewers are told 1000, else 1001 as
        the view stops: an interrupted run was reported over, a new user found)."""
        if self.failed:
            self._abandon()
            return
        if not self._stream.closed:
            live, self.live = self.live, None  # the log's scene is the log's: the live view has its own
            try:
                self._write_scene()
            finally:
                try:
                    self._writer.finish()
                finally:
                    self._stream.close()
            if live is not None and over:  # the run is over: the live view's last instants
                live.finish()
            if self.refused:
                log.warning("%s: %d message(s) not recorded: %s", self.path, self.refused.total(), self._refusals())

    def _abandon(self) -> None:
        """Close a log that could not be written without writing more: the flush of its buffer fails again and is
        let go (the file then holds whole chunks up to the failure, what cpf recover reads); the file is closed
        whatever the flush did (io's close closes the descriptor even when its flush raises)."""
        with contextlib.suppress(OSError, ValueError):
            self._stream.close()

    def _write_scene(self) -> None:
        """The run's Foxglove scene, built from every record written, after them (MCAP readers order by log time)."""
        scene, self.scene = self.scene, None
        if scene is not None:
            before = self.count
            with paused():  # the scene makes no cycles, and the run's heap is large (supervisor.collector)
                for topic, t, message in scene.messages():
                    self.write(topic, t, message)
            self.scene_count, self.count = self.count - before, before

    def _refusals(self) -> str:
        return "; ".join(f"{count} on {key}: {why}" for (key, why), count in sorted(self.refused.items()))

    def __enter__(self) -> Recorder:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close(over=exc_type is None)


class Tally:
    """A recorder that writes nothing: it counts what a run would record. A sweep keeps only each run's metrics,
    and writing the MCAP was a quarter of an in-process run's time (68000 messages encoded and compressed for a
    file deleted at once)."""

    def __init__(self) -> None:
        self.count = 0
        self.scene_count = 0  # a tally has no scene

    def limit(self, end: float) -> None:
        """As Recorder.limit: nothing is kept, so nothing to refuse."""

    def write(self, key: str, t: float, message: Message) -> bool:
        self.count += 1
        return True

    def skip(self, messages: int) -> None:
        """Count messages a run would write without building them: nothing reads them here."""
        self.count += messages

    def __enter__(self) -> Tally:
        return self

    def __exit__(self, *exc: object) -> None:
        return None


Sink = Recorder | Tally  # what an engine records to


def read_messages(path: Path) -> list[tuple[str, int, dict[str, Any]]]:
    """(topic, log time ns, message) of every message in log-time order (supervisor.record.logfile reads every log)."""
    from supervisor.record.logfile import read_messages as read

    return read(path)
