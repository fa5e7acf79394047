"""What a recorded run is, in a few lines (`describe`), and reading a log whether or not its writer finished it.

A finished log ends with a summary (statistics, channels, chunk index): `describe` takes the message counts and the
time span from it and decodes only the run's meta message. A log whose writer was killed has no summary: it is read
linearly, record by record, up to the first record the file cuts short (`read_raw`, also used by the report); such a
log is described as far as it goes, and `cpf recover` rebuilds its summary and index.
"""

from __future__ import annotations

import io
import json
import struct
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, NamedTuple

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import McapReader, make_reader
from mcap.records import Channel, Chunk, Statistics
from mcap.stream_reader import get_chunk_data_stream
from mcap.summary import Summary

from comms.messages import META_KEY
from supervisor.errors import ScenarioError

__all__ = ["LogError", "RawLog", "RawMessage", "describe", "read_raw"]

MAGIC = b"\x89MCAP0\r\n"
PREFIX = struct.Struct("<BQ")  # every record: opcode, length of what follows
MESSAGE_HEAD = struct.Struct("<HIQQ")  # a message record: channel id, sequence, log time, publish time; then data
TOPIC_WIDTH = 28


class LogError(ScenarioError):
    """A log that cannot be read at all: missing, not an MCAP, or cut before anything readable (exit code 2)."""


class RawMessage(NamedTuple):
    topic: str
    log_time: int  # ns of simulation time
    data: bytes  # JSON


@dataclass
class RawLog:
    """Messages read from a log: those asked for (in log-time order) and how many there are of every topic."""

    messages: list[RawMessage] = field(default_factory=list)
    counts: Counter[str] = field(default_factory=Counter)
    first_time: int | None = None  # ns, over every message read
    last_time: int | None = None
    complete: bool = True  # False: no summary, read up to where the file is cut or damaged

    def take(self, topic: str, log_time: int, data: bytes, wanted: Callable[[str], bool]) -> None:
        self.counts[topic] += 1
        self.first_time = log_time if self.first_time is None else min(self.first_time, log_time)
        self.last_time = log_time if self.last_time is None else max(self.last_time, log_time)
        if wanted(topic):
            self.messages.append(RawMessage(topic, log_time, data))


# --- reading ------------------------------------------------------------------------------------------------


def read_raw(path: Path, wanted: Callable[[str], bool]) -> RawLog:
    """The messages of the wanted topics in log-time order, and the count of every topic; LogError if the file is
    not an MCAP. One linear pass (every chunk is wanted anyway): a log cut short is read up to its cut."""
    with _open(path) as stream:
        return _scan(stream, wanted)


def _open(path: Path) -> IO[bytes]:
    """The log, opened, its magic checked; LogError otherwise."""
    try:
        stream = path.open("rb")
    except OSError as exc:
        raise LogError(f"{path}: cannot read the log: {exc.strerror or exc}") from exc
    if stream.read(len(MAGIC)) != MAGIC:
        stream.close()
        raise LogError(f"{path}: not an MCAP file (no MCAP magic at its start)")
    return stream


def _reader(stream: IO[bytes]) -> McapReader:
    stream.seek(0)  # the reader checks the magic where the stream stands
    return make_reader(stream)


def _summary(stream: IO[bytes]) -> Summary | None:
    """The log's summary section; None when it has none (its writer was killed: no footer)."""
    try:
        return _reader(stream).get_summary()
    except (McapError, struct.error, ValueError, OSError):  # OSError: too short to hold a footer
        return None


def _scan(stream: IO[bytes], wanted: Callable[[str], bool]) -> RawLog:
    """Every complete top-level record from the start; stops at the first one cut short or damaged."""
    log = RawLog(complete=False)
    topics: dict[int, str] = {}
    for opcode, body in _top_records(stream):
        if opcode in (Opcode.DATA_END, Opcode.FOOTER):
            log.complete = True  # a whole data section, with or without a summary after it
            break
        try:
            records = _parsed(opcode, body, topics)
        except Exception:  # damaged data raises many unrelated types (struct, zstd, CRC): the readable part ends
            break
        for topic, log_time, data in records:
            log.take(topic, log_time, data, wanted)
    log.messages.sort(key=lambda m: m.log_time)  # stable: equal times keep the order they were written in
    return log


def _top_records(stream: IO[bytes]) -> Iterable[tuple[int, bytes]]:
    """(opcode, body) of each record after the magic that the file holds whole."""
    size = stream.seek(0, io.SEEK_END)
    offset = stream.seek(len(MAGIC))
    while offset + PREFIX.size <= size:
        opcode, length = PREFIX.unpack(stream.read(PREFIX.size))
        if length > size - offset - PREFIX.size:
            return
        yield opcode, stream.read(length)
        offset += PREFIX.size + length


def _parsed(opcode: int, body: bytes, topics: dict[int, str]) -> list[RawMessage]:
    """The messages of one top-level record (a chunk: all of them, or an exception if it is damaged); channel
    records found on the way are entered in topics."""
    inner = _chunk_data(body) if opcode == Opcode.CHUNK else PREFIX.pack(opcode, len(body)) + body
    out = []
    offset = 0
    while offset < len(inner):
        opcode, length = PREFIX.unpack_from(inner, offset)
        start, offset = offset + PREFIX.size, offset + PREFIX.size + length
        if offset > len(inner):
            raise ValueError("record runs past its chunk")
        if opcode == Opcode.CHANNEL:
            channel = Channel.read(ReadDataStream(io.BytesIO(inner[start:offset])))
            topics[channel.id] = channel.topic
        elif opcode == Opcode.MESSAGE:
            channel_id, _, log_time, _ = MESSAGE_HEAD.unpack_from(inner, start)
            out.append(RawMessage(topics[channel_id], log_time, inner[start + MESSAGE_HEAD.size : offset]))
    return out


def _chunk_data(body: bytes) -> bytes:
    """The records of a chunk, decompressed (by mcap, whatever the codec) and checked against its size and CRC."""
    chunk = Chunk.read(ReadDataStream(io.BytesIO(body)))
    stream, length = get_chunk_data_stream(chunk, validate_crc=True)
    if length != chunk.uncompressed_size:
        raise ValueError(f"chunk holds {length} bytes, announces {chunk.uncompressed_size}")
    return stream.read(length)


# --- describing ---------------------------------------------------------------------------------------------


def describe(path: Path) -> str:
    """A short multi-line summary of a log: what ran, how long, which faults, and the message count per topic."""
    log, source = _overview(path)
    meta = _meta(log)
    lines = [
        f"{path}: {_size(path.stat().st_size)}, {sum(log.counts.values())} messages on {len(log.counts)} topics "
        f"({source})",
        *_run_lines(meta, log),
        "topics" if log.counts else "topics     none",
        *(f"  {topic:<{TOPIC_WIDTH}}{count:>8}" for topic, count in sorted(log.counts.items())),
    ]
    return "\n".join(lines)


def _overview(path: Path) -> tuple[RawLog, str]:
    """Counts and time span from the summary when there is one (decoding only the meta), else from reading."""
    with _open(path) as stream:
        summary = _summary(stream)
        if summary is not None and summary.statistics is not None:
            return _from_summary(stream, summary, summary.statistics), "counts from the file's summary"
        log = _scan(stream, lambda topic: topic == META_KEY)
    if not log.complete:
        return log, "CUT SHORT, no summary: counted what is readable; `cpf recover` rebuilds it"
    return log, "no statistics in the file: counted by reading it"


def _from_summary(stream: IO[bytes], summary: Summary, stats: Statistics) -> RawLog:
    """The summary's message counts and time span, and the meta message (read through the chunk index)."""
    log = RawLog()
    if stats.message_count:
        log.first_time, log.last_time = stats.message_start_time, stats.message_end_time
    for channel_id, count in stats.channel_message_counts.items():
        log.counts[summary.channels[channel_id].topic] += count
    for _, _, message in _reader(stream).iter_messages(topics=[META_KEY]):
        log.messages.append(RawMessage(META_KEY, message.log_time, message.data))
        break
    return log


def _meta(log: RawLog) -> dict[str, Any]:
    for message in log.messages:
        if message.topic == META_KEY:
            try:
                meta = json.loads(message.data)
            except ValueError:
                return {}
            return meta if isinstance(meta, dict) else {}
    return {}


def _run_lines(meta: dict[str, Any], log: RawLog) -> list[str]:
    if not meta:
        return ["run        no cpf/run/meta message: not a cpf run, or cut before it"]
    vehicles = ", ".join(str(v) for v in meta.get("vehicles", [])) or "-"
    edges = ", ".join(f"{i}-{j}" for i, j in meta.get("edges", [])) or "-"
    faults = [_fault(f) for f in meta.get("faults", [])] or ["none"]
    description = (meta.get("scenario") or {}).get("scenario", {}).get("description")
    return [
        f"scenario   {meta.get('scenario_name', '?')} ({meta.get('scenario_file', '?')})",
        *([f"           {description}"] if description else []),
        f"engine     {meta.get('engine', '?')}, clock {meta.get('clock', '?')}, seed {meta.get('seed', '?')}, "
        f"step {meta.get('step', '?')} s",
        f"duration   {_seconds(meta.get('duration'))} s simulated (scenario); messages from t = "
        f"{_seconds(_ns(log.first_time))} to {_seconds(_ns(log.last_time))} s",
        f"vehicles   {vehicles}",
        f"graph      {edges}",
        f"faults     {faults[0]}",
        *(f"           {line}" for line in faults[1:]),
    ]


TARGET_FIELDS = ("vehicle", "sender", "receiver", "both", "edges")


def _fault(fault: dict[str, Any]) -> str:
    """'kind on [start, end) s: target (parameters)'."""
    end = fault.get("end")
    window = f"[{_seconds(fault.get('start'))}, {'end' if end is None else _seconds(end)}) s"
    return f"{fault.get('kind', '?')} on {window}: {_target(fault)}{_parameters(fault)}"


def _target(fault: dict[str, Any]) -> str:
    if fault.get("vehicle") is not None:
        return f"vehicle {fault['vehicle']}"
    if fault.get("sender") is not None:
        arrow = "<->" if fault.get("both") else "->"
        return f"link {fault['sender']}{arrow}{fault.get('receiver')}"
    if fault.get("edges") is not None:
        return "graph " + (", ".join(f"{i}-{j}" for i, j in fault["edges"]) or "without edges")
    return "broker" if fault.get("kind") == "broker_kill" else "every link"


def _parameters(fault: dict[str, Any]) -> str:
    rest = {k: v for k, v in fault.items() if k not in ("kind", "start", "end", *TARGET_FIELDS)}
    return f" ({', '.join(f'{k} {v}' for k, v in rest.items())})" if rest else ""


def _ns(value: int | None) -> float | None:
    return None if value is None else value / 1e9


def _seconds(value: Any) -> str:
    return "?" if value is None else f"{float(value):g}"


def _size(size: int) -> str:
    value, unit = float(size), "B"
    for unit in ("B", "kB", "MB", "GB"):
        if value < 1000 or unit == "GB":
            break
        value /= 1000
    return f"{size} B" if unit == "B" else f"{value:.1f} {unit} ({size} bytes)"
