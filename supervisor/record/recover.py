"""Recovery of an MCAP whose writer died (SIGKILL, power cut): no summary, no footer, maybe a partial last chunk.

The source is read record by record from its start. Every complete record is kept (schemas, channels, messages,
chunks whose data decompresses to the announced size and CRC, metadata, attachments); the scan stops cleanly at
the first record that is truncated or corrupt, or at the end of the data section. What was kept is written, in the
same order, to a new MCAP with a summary and an index: same topics, schemas, encodings, times, sequences and bytes.
The Recorder (supervisor/record/recorder.py) finishes a chunk at least every half second, so a killed run loses at most
about its last second. The same repair with the mcap CLI: `mcap recover in.mcap -o out.mcap`.
"""

from __future__ import annotations

import io
import os
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    Channel,
    Chunk,
    DataEnd,
    Footer,
    Header,
    McapRecord,
    Message,
    Metadata,
    Schema,
)
from mcap.writer import CompressionType, Writer

from supervisor.errors import CorruptRecord, RecoveryError

MAGIC = b"\x89MCAP0\r\n"
PREFIX = struct.Struct("<BQ")  # every record: opcode, length of what follows
MESSAGE_FIELDS = 22  # channel id, sequence, log time, publish time: a message is at least this long
FIRST_PRIVATE_OPCODE = 0x80  # opcodes from here on are user-defined: skipped, not corrupt
READERS: dict[int, Any] = {
    Opcode.HEADER: Header.read,
    Opcode.SCHEMA: Schema.read,
    Opcode.CHANNEL: Channel.read,
    Opcode.CHUNK: Chunk.read,
    Opcode.METADATA: Metadata.read,
    Opcode.ATTACHMENT: Attachment.read,
    Opcode.DATA_END: DataEnd.read,
    Opcode.FOOTER: Footer.read,
}  # every other defined opcode is an index or a summary record: rebuilt by the writer, so skipped
IN_CHUNK = (Schema, Channel, Message)
DEFAULT_HEADER = Header(profile="", library="cpf recover")  # for a source cut before its header ends
DEFINED = frozenset(int(opcode) for opcode in Opcode)


@dataclass(frozen=True)
class RecoveryReport:
    """What recover() kept. last_log_time: ns, None without messages; complete: the source's data section was
    whole (it ended with its DataEnd record), so nothing was lost."""

    messages: int
    chunks: int
    unreadable_bytes: int
    last_log_time: int | None
    complete: bool

    def describe(self) -> str:
        last = "-" if self.last_log_time is None else f"{self.last_log_time / 1e9:.3f} s"
        state = "complete source" if self.complete else f"{self.unreadable_bytes} unreadable bytes dropped"
        return f"{self.messages} messages recovered from {self.chunks} chunk(s), last log time {last}; {state}"


class _Body(io.BytesIO):
    """A record's bytes: a field running past the record's end is corruption, not a short read."""

    def read(self, size: int | None = -1, /) -> bytes:
        data = super().read(size)
        if size is not None and size >= 0 and len(data) < size:
            raise CorruptRecord(f"field of {size} bytes runs past the record's end")
        return data


def _parse(opcode: int, body: bytes) -> McapRecord | None:
    """The record of this opcode, None for one that recovery skips; CorruptRecord if it does not parse."""
    if opcode == Opcode.MESSAGE:
        if len(body) < MESSAGE_FIELDS:
            raise CorruptRecord(f"message record of {len(body)} bytes")
        return Message.read(ReadDataStream(_Body(body)), len(body))
    if opcode in READERS:
        try:
            return READERS[opcode](ReadDataStream(_Body(body)))
        except (struct.error, UnicodeDecodeError) as exc:
            raise CorruptRecord(f"opcode {opcode:#04x}: {exc}") from exc
    if opcode in DEFINED or opcode >= FIRST_PRIVATE_OPCODE:
        return None
    raise CorruptRecord(f"opcode {opcode:#04x} is not an MCAP record")


def _decompress(chunk: Chunk) -> bytes:
    if chunk.compression == "":
        return chunk.data
    try:
        if chunk.compression == "zstd":
            import zstandard

            return zstandard.decompress(chunk.data, max_output_size=chunk.uncompressed_size)
        if chunk.compression == "lz4":
            import lz4.frame

            return lz4.frame.decompress(chunk.data)
    except Exception as exc:  # the codecs raise several unrelated types for damaged data
        raise CorruptRecord(f"{chunk.compression} chunk does not decompress: {exc}") from exc
    raise CorruptRecord(f"chunk compression {chunk.compression!r} is not supported")


def _chunk_records(chunk: Chunk) -> list[McapRecord]:
    """The schemas, channels and messages of a chunk, in order; CorruptRecord unless it is whole and its CRC matches."""
    data = _decompress(chunk)
    if len(data) != chunk.uncompressed_size:
        raise CorruptRecord(f"chunk holds {len(data)} bytes, announces {chunk.uncompressed_size}")
    if chunk.uncompressed_crc != 0 and zlib.crc32(data) != chunk.uncompressed_crc:
        raise CorruptRecord("chunk CRC mismatch")
    records: list[McapRecord] = []
    offset = 0
    while offset < len(data):
        if offset + PREFIX.size > len(data):
            raise CorruptRecord("record prefix runs past the chunk's end")
        opcode, length = PREFIX.unpack_from(data, offset)
        body = data[offset + PREFIX.size : offset + PREFIX.size + length]
        if len(body) < length:
            raise CorruptRecord("record runs past the chunk's end")
        record = _parse(opcode, body)
        if record is not None and not isinstance(record, IN_CHUNK):
            raise CorruptRecord(f"{type(record).__name__} record inside a chunk")
        if record is not None:
            records.append(record)
        offset += PREFIX.size + length
    return records


def _top_records(stream: IO[bytes], size: int) -> Iterator[tuple[int, int, bytes]]:
    """(offset, opcode, body) of each complete record after the magic; ends at the first that the file cuts."""
    offset = len(MAGIC)
    stream.seek(offset)
    while offset + PREFIX.size <= size:
        opcode, length = PREFIX.unpack(stream.read(PREFIX.size))
        if length > size - offset - PREFIX.size:
            return
        yield offset, opcode, stream.read(length)
        offset += PREFIX.size + length


class _Copy:
    """Writes the kept records, in order, to a fresh writer, mapping schema and channel ids."""

    def __init__(self, writer: Writer) -> None:
        self.writer = writer
        self.started = False
        self.schemas: dict[int, int] = {}
        self.channels: dict[int, int] = {}
        self.messages = 0
        self.chunks = 0
        self.last_log_time: int | None = None

    def start(self, header: Header = DEFAULT_HEADER) -> None:
        if not self.started:
            self.writer.start(profile=header.profile, library=header.library)
            self.started = True

    def check(self, records: list[McapRecord]) -> None:
        """CorruptRecord if a channel names an unknown schema or a message an unknown channel (before writing any)."""
        schemas, channels = set(self.schemas) | {0}, set(self.channels)
        for record in records:
            if isinstance(record, Schema):
                schemas.add(record.id)
            elif isinstance(record, Channel) and record.schema_id not in schemas:
                raise CorruptRecord(f"channel {record.id} names unknown schema {record.schema_id}")
            elif isinstance(record, Channel):
                channels.add(record.id)
            elif isinstance(record, Message) and record.channel_id not in channels:
                raise CorruptRecord(f"message on unknown channel {record.channel_id}")

    def add(self, record: McapRecord) -> None:
        self.start()
        if isinstance(record, Schema) and record.id not in self.schemas:
            self.schemas[record.id] = self.writer.register_schema(record.name, record.encoding, record.data)
        elif isinstance(record, Channel) and record.id not in self.channels:
            schema = self.schemas.get(record.schema_id, 0)
            self.channels[record.id] = self.writer.register_channel(
                record.topic, record.message_encoding, schema, record.metadata
            )
        elif isinstance(record, Message):
            self._message(record)
        elif isinstance(record, Metadata):
            self.writer.add_metadata(record.name, record.metadata)
        elif isinstance(record, Attachment):
            self.writer.add_attachment(record.create_time, record.log_time, record.name, record.media_type, record.data)

    def _message(self, message: Message) -> None:
        self.writer.add_message(
            self.channels[message.channel_id], message.log_time, message.data, message.publish_time, message.sequence
        )
        self.messages += 1
        last = self.last_log_time
        self.last_log_time = message.log_time if last is None else max(last, message.log_time)

    def record(self, opcode: int, body: bytes) -> bool:
        """Copy one top-level record; True at the end of the data section. CorruptRecord if it does not parse."""
        record = _parse(opcode, body)
        if isinstance(record, Header):
            self.start(record)
        elif isinstance(record, DataEnd | Footer):
            return True
        elif record is not None:
            records = _chunk_records(record) if isinstance(record, Chunk) else [record]
            self.check(records)
            for item in records:
                self.add(item)
            if isinstance(record, Chunk):
                self.chunks += 1
        return False


def _check_source(src: Path, stream: IO[bytes], size: int) -> None:
    if size == 0:
        raise RecoveryError(f"{src}: empty file, not an MCAP")
    if stream.read(len(MAGIC)) != MAGIC:
        raise RecoveryError(f"{src}: not an MCAP file (no MCAP magic at its start)")


def _scan(stream: IO[bytes], size: int, copy: _Copy) -> tuple[int, bool]:
    """Copy top-level records until the data section ends or a record is cut or corrupt.

    (Offset where reading stopped, whether the data section was whole.)
    """
    end = len(MAGIC)
    for offset, opcode, body in _top_records(stream, size):
        try:
            done = copy.record(opcode, body)
        except CorruptRecord:
            return offset, False
        end = offset + PREFIX.size + len(body)
        if done:
            return end, True
    return end, False


def _copy(src: Path, stream: IO[bytes], copy: _Copy) -> RecoveryReport:
    """Copy the readable records of an opened source; the report of what was kept."""
    size = os.fstat(stream.fileno()).st_size
    _check_source(src, stream, size)
    end, complete = _scan(stream, size, copy)
    copy.start()  # a source cut inside its header still gives a valid (empty) MCAP
    unreadable = 0 if complete else size - end
    return RecoveryReport(copy.messages, copy.chunks, unreadable, copy.last_log_time, complete)


def recover(src: Path, dst: Path) -> RecoveryReport:
    """Write to dst a complete, indexed MCAP holding every readable message of src, a possibly truncated MCAP.

    Raises OSError if src cannot be read or dst written, RecoveryError if src is not an MCAP or dst is src.
    dst appears only once complete (written beside it, then renamed).
    """
    if dst.exists() and dst.resolve() == src.resolve():
        raise RecoveryError(f"{dst}: the destination must not be the source")
    with src.open("rb") as source:
        dst.parent.mkdir(parents=True, exist_ok=True)
        partial = dst.with_name(dst.name + ".part")
        try:
            with partial.open("wb") as out:
                writer = Writer(out, compression=CompressionType.ZSTD)
                report = _copy(src, source, _Copy(writer))
                writer.finish()
            partial.replace(dst)
        finally:
            partial.unlink(missing_ok=True)
    return report
