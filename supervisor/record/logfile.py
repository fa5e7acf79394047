"""Reading a cpf log (MCAP): the one module every command that reads a log goes through, so all fail alike.

Two ways to read. `messages` / `read_messages` are strict: a log that is missing, not an MCAP, cut short (its writer
was killed: no footer, no summary) or damaged (a chunk that does not decompress or fails its CRC, a message that is
not JSON) raises LogError, one line naming the file and, where it can help, pointing to `cpf recover`. `read_raw`
is lenient, for describing a log whatever its state (`cpf info`): it reads record by record up to the first record
the file cuts short or that is damaged, and says whether it got to the end. `verify` checks every chunk of a log.
"""

from __future__ import annotations

import io
import json
import struct
import zlib
from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, NamedTuple

import msgspec
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.reader import McapReader, make_reader
from mcap.records import Channel, Chunk
from mcap.stream_reader import get_chunk_data_stream
from mcap.summary import Summary

from supervisor.errors import LogError

KNOWN_OPCODES = frozenset(int(op) for op in Opcode)  # 0x00 is none: a zeroed record is damage
USER_OPCODES = 0x80  # 0x80-0xff: records of an extension of MCAP, left alone

__all__ = [
    "LogError",
    "LogMessage",
    "RawLog",
    "RawMessage",
    "messages",
    "read_checked",
    "read_messages",
    "read_raw",
    "verify",
]

MAGIC = b"\x89MCAP0\r\n"
PREFIX = struct.Struct("<BQ")  # every record: opcode, length of what follows
FOOTER = struct.Struct("<BQQQI")  # opcode, length, summary start, summary offset start, summary CRC
MESSAGE_HEAD = struct.Struct("<HIQQ")  # a message record: channel id, sequence, log time, publish time; then data
_JSON = msgspec.json.Decoder()


class LogMessage(NamedTuple):
    topic: str
    log_time: int  # ns of simulation time
    message: Any  # the decoded JSON; None on a channel whose encoding is not JSON


class RawMessage(NamedTuple):
    topic: str
    log_time: int  # ns of simulation time
    data: bytes  # JSON


def damaged(path: Path, what: str) -> LogError:
    """The error for a log cut short or damaged: what `cpf recover` is for."""
    return LogError(f"{path}: cut short or damaged ({what}); try `cpf recover {path}`")


# --- strict reading -------------------------------------------------------------------------------------------


def messages(
    path: Path,
    wanted: Callable[[str], bool] | None = None,
    start: int | None = None,
    end: int | None = None,
    verified: bool = False,
) -> Iterator[LogMessage]:
    """The messages of the wanted topics with start <= log time <= end (ns), in log-time order (equal times in the
    order written), streamed chunk by chunk. LogError, before the first message, for a log that is missing, not an
    MCAP, cut short or damaged anywhere (verify: the reader alone skips a chunk zeroed whole, and a resim of such a
    log ran on without its records, issue 29); LogError where it is met for a damaged message. verified: the caller
    has verified the log (a second pass over every chunk is not needed)."""
    if not verified:
        verify(path)
    with open_log(path) as stream:
        stream.seek(0)  # the reader checks the magic where the stream stands
        reader = make_reader(stream, validate_crcs=True)
        summary = _strict_summary(path, reader, stream)
        topics = None
        if wanted is not None and summary is not None:  # the chunk index then skips chunks without a wanted topic
            topics = [channel.topic for channel in summary.channels.values() if wanted(channel.topic)]
        records = reader.iter_messages(topics=topics, log_time_order=True, starting_at=start, ending_at=end)
        while True:
            try:
                _, channel, record = next(records)
            except StopIteration:
                return
            except Exception as exc:  # damaged data raises many unrelated types (struct, zstd, CRC, mcap)
                raise damaged(path, _reason(exc)) from None
            if wanted is None or wanted(channel.topic):
                yield LogMessage(channel.topic, record.log_time, _decoded(path, channel, record.data))


def read_messages(path: Path, wanted: Callable[[str], bool] | None = None) -> list[tuple[str, int, Any]]:
    """(topic, log time ns, message) of every (wanted) message in log-time order; LogError as `messages`. Read in
    `read_checked`'s one pass (the same messages in the same order, tests/test_report_drawing.py): `messages` streams,
    for a replay's seek, at twice the cost of a whole read (74k messages of the paper run: 2.9 against 1.6 s)."""
    return [(m.topic, m.log_time, m.message) for m in read_checked(path, wanted or _every)]


def _every(_: str) -> bool:
    return True


def read_checked(path: Path, wanted: Callable[[str], bool]) -> list[LogMessage]:
    """The wanted messages in log-time order (equal times in the order written, as `messages` gives them) of a log
    checked whole as `verify` checks it, also in chunks holding no wanted topic. One linear pass that decompresses
    each chunk once: `verify` then `messages` decompressed every chunk twice and merged them in a heap of Python
    objects (11 s of a 14 s load of an 8-vehicle, 450 s run). LogError as both."""
    out: list[LogMessage] = []
    channels: dict[int, Channel] = {}
    taken: dict[int, bool] = {}  # channel id -> wanted: asked once per channel, not once per message
    with open_log(path) as stream:
        for offset, records in _checked(path, stream):
            try:
                found = _records_in(records, channels)
            except Exception as exc:  # see messages
                raise damaged(path, f"records at byte {offset}: {_reason(exc)}") from None
            for c, t, data in found:
                if taken.get(c) is None:
                    taken[c] = wanted(channels[c].topic)
                if taken[c]:
                    out.append(LogMessage(channels[c].topic, t, _decoded(path, channels[c], data)))
    out.sort(key=lambda m: m.log_time)  # stable: equal times keep the order they were written in
    return out


def verify(path: Path) -> None:
    """LogError unless the log ends with its footer, every record of its data section starts with a known opcode,
    every chunk in it decompresses to its size and CRC and every chunk its index names is where it says."""
    with open_log(path) as stream:
        for _ in _checked(path, stream):
            pass


def _checked(path: Path, stream: IO[bytes]) -> Iterator[tuple[int, bytes]]:
    """(offset, its records) of each top-level record of the data section, checked as `verify` says: a chunk's
    records decompressed, any other record as it stands; LogError at the first damage."""
    summary = _strict_summary(path, reader_of(stream), stream)
    indexed = {c.chunk_start_offset for c in summary.chunk_indexes} if summary is not None else set()
    offset = len(MAGIC)
    for offset, opcode, body in _top_records(stream):
        if opcode in (Opcode.DATA_END, Opcode.FOOTER):
            _all_found(path, indexed)
            return
        if opcode not in KNOWN_OPCODES and opcode < USER_OPCODES:  # zeroed or overwritten where a record starts
            raise damaged(path, f"no MCAP record at byte {offset} (opcode {opcode:#04x})")
        indexed.discard(offset)
        if opcode != Opcode.CHUNK:
            yield offset, PREFIX.pack(opcode, len(body)) + body
            continue
        try:
            records = _chunk_data(body)
        except Exception as exc:  # see messages
            raise damaged(path, f"chunk at byte {offset}: {_reason(exc)}") from None
        yield offset, records
    raise damaged(path, f"a record at byte {offset} runs past the end of the file")


def _all_found(path: Path, indexed: set[int]) -> None:
    """LogError if the index names a chunk the file does not hold where it says."""
    if indexed:
        raise damaged(path, f"the index names a chunk at byte {min(indexed)} that is not there")


def open_log(path: Path) -> IO[bytes]:
    """The log, opened, its magic checked; LogError otherwise."""
    if path.exists() and not path.is_file():  # a FIFO blocked the open until a writer came (a new user's hang)
        raise LogError(f"{path}: not a log file ({'a directory' if path.is_dir() else 'not a regular file'})")
    try:
        stream = path.open("rb")
    except FileNotFoundError:
        raise LogError(f"{path}: no such log file") from None
    except OSError as exc:
        raise LogError(f"{path}: cannot read the log: {exc.strerror or exc}") from None
    if stream.read(len(MAGIC)) != MAGIC:
        stream.close()
        raise LogError(f"{path}: not an MCAP file (no MCAP magic at its start)")
    return stream


def _strict_summary(path: Path, reader: McapReader, stream: IO[bytes]) -> Summary | None:
    """The summary (None if the writer wrote none); LogError for a log without its footer."""
    try:
        summary = reader.get_summary()
    except Exception:  # see messages; a file too short for a footer raises OSError on the seek. mcap's own text
        # (bytes read as a record length, ...) would only puzzle a user: say what it means
        raise damaged(path, "no footer at its end, its writer did not finish it") from None
    if not summary_whole(stream):
        raise damaged(path, "its summary section (index, counts) fails its CRC")
    return summary


def summary_whole(stream: IO[bytes]) -> bool:
    """Whether the summary section matches the CRC its footer gives (mcap does not check it): a damaged summary
    would send a reader to the wrong chunks or give wrong counts. True without a summary or a CRC."""
    size = stream.seek(0, io.SEEK_END)
    if size < len(MAGIC) + FOOTER.size + len(MAGIC):
        return False
    stream.seek(size - len(MAGIC) - FOOTER.size)
    _, _, start, _, crc = FOOTER.unpack(stream.read(FOOTER.size))
    if crc == 0 or start == 0:
        return True
    if not len(MAGIC) <= start <= size - len(MAGIC) - FOOTER.size:
        return False
    stream.seek(start)
    return zlib.crc32(stream.read(size - len(MAGIC) - 4 - start)) == crc


def _decoded(path: Path, channel: Channel, data: bytes) -> Any:
    if channel.message_encoding != "json":
        return None
    try:  # msgspec reads JSON 2-3x faster; json also reads the NaN and Infinity an older writer may have left
        return _JSON.decode(data)
    except msgspec.DecodeError:
        pass
    try:
        return json.loads(data)
    except ValueError as exc:  # in a chunk that checks (its CRC, its size): written so, cpf recover keeps it as is
        raise LogError(
            f"{path}: a message on {channel.topic} is not JSON ({exc}): written so by another program than cpf, or "
            "changed since; cpf reads no log that holds one"
        ) from None


def _reason(exc: BaseException) -> str:
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__


# --- lenient reading ------------------------------------------------------------------------------------------


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


def read_raw(path: Path, wanted: Callable[[str], bool]) -> RawLog:
    """The messages of the wanted topics in log-time order, and the count of every topic, of a log in any state;
    LogError if the file is not an MCAP. One linear pass: a log cut short is read up to its cut."""
    with open_log(path) as stream:
        return scan(stream, wanted)


def lenient_summary(stream: IO[bytes]) -> Summary | None:
    """The log's summary section; None when it has none or it does not read (its writer was killed: no footer)."""
    try:
        summary = reader_of(stream).get_summary()
    except Exception:  # see messages
        return None
    return summary if summary_whole(stream) else None


def reader_of(stream: IO[bytes]) -> McapReader:
    stream.seek(0)  # the reader checks the magic where the stream stands
    return make_reader(stream)


def scan(stream: IO[bytes], wanted: Callable[[str], bool]) -> RawLog:
    """Every complete top-level record from the start; stops at the first one cut short or damaged."""
    log = RawLog(complete=False)
    channels: dict[int, Channel] = {}
    for _, opcode, body in _top_records(stream):
        if opcode in (Opcode.DATA_END, Opcode.FOOTER):
            log.complete = True  # a whole data section, with or without a summary after it
            break
        try:
            records = _parsed(opcode, body, channels)
        except Exception:  # see messages: the readable part ends here
            break
        for channel, log_time, data in records:
            log.take(channels[channel].topic, log_time, data, wanted)
    log.messages.sort(key=lambda m: m.log_time)  # stable: equal times keep the order they were written in
    return log


def _top_records(stream: IO[bytes]) -> Iterable[tuple[int, int, bytes]]:
    """(offset, opcode, body) of each record after the magic that the file holds whole."""
    size = stream.seek(0, io.SEEK_END)
    offset = stream.seek(len(MAGIC))
    while offset + PREFIX.size <= size:
        opcode, length = PREFIX.unpack(stream.read(PREFIX.size))
        if length > size - offset - PREFIX.size:
            return
        yield offset, opcode, stream.read(length)
        offset += PREFIX.size + length


def _parsed(opcode: int, body: bytes, channels: dict[int, Channel]) -> list[tuple[int, int, bytes]]:
    """(channel id, log time, data) of the messages of one top-level record (a chunk: all of them, or an exception
    if it is damaged); channel records found on the way are entered in channels."""
    return _records_in(_chunk_data(body) if opcode == Opcode.CHUNK else PREFIX.pack(opcode, len(body)) + body, channels)


def _records_in(inner: bytes, channels: dict[int, Channel]) -> list[tuple[int, int, bytes]]:
    """(channel id, log time, data) of the messages in a run of records (a chunk's, decompressed); channel records
    are entered in channels; an exception for a record cut short or a message on a channel not yet described."""
    out = []
    offset = 0
    while offset < len(inner):
        opcode, length = PREFIX.unpack_from(inner, offset)
        start, offset = offset + PREFIX.size, offset + PREFIX.size + length
        if offset > len(inner):
            raise ValueError("record runs past its chunk")
        if opcode == Opcode.CHANNEL:
            channel = Channel.read(ReadDataStream(io.BytesIO(inner[start:offset])))
            channels[channel.id] = channel
        elif opcode == Opcode.MESSAGE:
            channel_id, _, log_time, _ = MESSAGE_HEAD.unpack_from(inner, start)
            if channel_id not in channels:
                raise ValueError(f"a message on channel {channel_id}, which no channel record describes")
            out.append((channel_id, log_time, inner[start + MESSAGE_HEAD.size : offset]))
    return out


def _chunk_data(body: bytes) -> bytes:
    """The records of a chunk, decompressed (by mcap, whatever the codec) and checked against its size and CRC."""
    chunk = Chunk.read(ReadDataStream(io.BytesIO(body)))
    stream, length = get_chunk_data_stream(chunk, validate_crc=True)
    if length != chunk.uncompressed_size:
        raise ValueError(f"chunk holds {length} bytes, announces {chunk.uncompressed_size}")
    return stream.read(length)
