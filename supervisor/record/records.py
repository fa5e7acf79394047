"""The records of an MCAP read one by one, for `cpf recover` (record/recover.py): whole or damaged, and where the
next whole chunk starts after damage.

A record is trusted only as far as it checks: a chunk must decompress to the size it announces and match its CRC;
the other records must parse within their own length. After damage, `next_chunk` scans forward byte by byte for a
chunk record that checks (opcode, a known codec, lengths that agree with each other and fit in the file, then size
and CRC): the chunk's own record-length field is not needed, so a chunk whose only damage is that field is kept.
"""

from __future__ import annotations

import io
import struct
import zlib
from dataclasses import dataclass, field
from typing import Any

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
    Statistics,
)

from supervisor.errors import CorruptRecord

MAGIC = b"\x89MCAP0\r\n"
PREFIX = struct.Struct("<BQ")  # every record: opcode, length of what follows
CHUNK_HEAD = struct.Struct("<QQQII")  # a chunk: start and end time, uncompressed size and CRC, codec name length
CHUNK_DATA_LENGTH = struct.Struct("<Q")  # after the codec name: the length of the compressed data
FOOTER = struct.Struct("<BQQQI")  # opcode, length, summary start, summary offset start, summary CRC
CODECS = (b"", b"zstd", b"lz4")
DATA_END = PREFIX.pack(Opcode.DATA_END, 4)  # a DataEnd record: this prefix, then a CRC (4 bytes)
MAX_CHUNK = 1 << 30  # bytes, uncompressed: more is a damaged size field, not a chunk to allocate for
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
DEFINED = frozenset(int(opcode) for opcode in Opcode)


class _Body(io.BytesIO):
    """A record's bytes: a field running past the record's end is corruption, not a short read."""

    def __init__(self, body: bytes) -> None:
        super().__init__(body)
        self.size = len(body)

    def read(self, size: int | None = -1, /) -> bytes:
        if size is not None and size > self.size - self.tell():  # also a size no index can hold
            raise CorruptRecord(f"field of {size} bytes runs past the record's end")
        return super().read(size)


def parse(opcode: int, body: bytes) -> McapRecord | None:
    """The record of this opcode, None for one that recovery skips; CorruptRecord if it does not parse."""
    if opcode == Opcode.MESSAGE:
        if len(body) < MESSAGE_FIELDS:
            raise CorruptRecord(f"message record of {len(body)} bytes")
        return Message.read(ReadDataStream(_Body(body)), len(body))
    if opcode in READERS:
        stream = _Body(body)
        try:
            record = READERS[opcode](ReadDataStream(stream))
        except (struct.error, UnicodeDecodeError) as exc:
            raise CorruptRecord(f"opcode {opcode:#04x}: {exc}") from exc
        if opcode == Opcode.CHUNK and stream.tell() != len(body):  # its length field is damaged: it tells where
            raise CorruptRecord(f"chunk of {stream.tell()} bytes in a record of {len(body)}")  # the next one starts
        return record
    if opcode in DEFINED or opcode >= FIRST_PRIVATE_OPCODE:
        return None
    raise CorruptRecord(f"opcode {opcode:#04x} is not an MCAP record")


def _decompress(chunk: Chunk) -> bytes:
    if chunk.uncompressed_size > MAX_CHUNK:
        raise CorruptRecord(f"chunk announces {chunk.uncompressed_size} bytes")
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


def chunk_records(chunk: Chunk) -> list[McapRecord]:
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
        record = parse(opcode, body)
        if record is not None and not isinstance(record, IN_CHUNK):
            raise CorruptRecord(f"{type(record).__name__} record inside a chunk")
        if record is not None:
            records.append(record)
        offset += PREFIX.size + length
    return records


def record_at(data: bytes | memoryview | Any, offset: int) -> tuple[int, bytes] | None:
    """(opcode, body) of the record at offset; None if the data ends before it does (a cut, or a damaged length)."""
    if offset + PREFIX.size > len(data):
        return None
    opcode, length = PREFIX.unpack_from(data, offset)
    if length > len(data) - offset - PREFIX.size:
        return None
    return opcode, bytes(data[offset + PREFIX.size : offset + PREFIX.size + length])


def chunk_at(data: Any, offset: int) -> tuple[list[McapRecord], int] | None:
    """The records of the chunk whose record starts at offset and the offset just past it, if a whole chunk is there.

    Its record-length field is checked only against the chunk's own fields when the chunk has no CRC: with a CRC
    that matches, the content is whole whatever that field says."""
    head = offset + PREFIX.size
    if data[offset] != Opcode.CHUNK or head + CHUNK_HEAD.size > len(data):
        return None
    *_, crc, codec_length = CHUNK_HEAD.unpack_from(data, head)
    codec_at = head + CHUNK_HEAD.size
    if bytes(data[codec_at : codec_at + codec_length]) not in CODECS or codec_at + codec_length + 8 > len(data):
        return None
    (data_length,) = CHUNK_DATA_LENGTH.unpack_from(data, codec_at + codec_length)
    end = codec_at + codec_length + CHUNK_DATA_LENGTH.size + data_length
    (announced,) = CHUNK_DATA_LENGTH.unpack_from(data, offset + 1)
    if end > len(data) or (crc == 0 and announced != end - head):
        return None
    try:
        chunk = Chunk.read(ReadDataStream(_Body(bytes(data[head:end]))))
        return chunk_records(chunk), end
    except (CorruptRecord, struct.error, UnicodeDecodeError):
        return None


def next_chunk(data: Any, start: int) -> tuple[int, list[McapRecord], int] | None:
    """(offset, records, end) of the first whole chunk at or after start, None if there is none."""
    offset = start
    while (offset := data.find(bytes([Opcode.CHUNK]), offset)) >= 0:
        found = chunk_at(data, offset)
        if found is not None:
            return offset, *found
        offset += 1
    return None


@dataclass
class SourceSummary:
    """What recovery takes from a source's summary section: the channels and schemas (some may have been defined
    only in a lost chunk) and the message count."""

    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    message_count: int | None = None


def trusted_summary(data: Any) -> SourceSummary | None:
    """The source's summary, if it has one whose CRC is written and matches. It is looked for where its footer says
    and, since bytes inserted or removed before it move it, just after the last DataEnd record: the CRC covers the
    footer's own fields, not the summary's place. None if neither checks."""
    footer_at = len(data) - len(MAGIC) - FOOTER.size
    if footer_at < len(MAGIC) or bytes(data[len(data) - len(MAGIC) :]) != MAGIC:
        return None
    opcode, _, start, _, crc = FOOTER.unpack_from(data, footer_at)
    if opcode != Opcode.FOOTER or crc == 0:
        return None
    data_end = data.rfind(DATA_END, len(MAGIC), footer_at)
    for candidate in (start, data_end + len(DATA_END) + 4 if data_end >= 0 else -1):
        if len(MAGIC) <= candidate <= footer_at and zlib.crc32(data[candidate : footer_at + FOOTER.size - 4]) == crc:
            return _summary(data, candidate, footer_at)
    return None


def _summary(data: Any, offset: int, end: int) -> SourceSummary | None:
    summary = SourceSummary()
    try:
        while (found := record_at(data, offset)) is not None and offset < end:
            opcode, body = found
            if opcode == Opcode.STATISTICS:
                summary.message_count = Statistics.read(ReadDataStream(_Body(body))).message_count
            record = parse(opcode, body) if opcode in (Opcode.SCHEMA, Opcode.CHANNEL) else None
            if isinstance(record, Schema):
                summary.schemas[record.id] = record
            elif isinstance(record, Channel):
                summary.channels[record.id] = record
            offset += PREFIX.size + len(body)
    except (CorruptRecord, struct.error, UnicodeDecodeError):  # its CRC matched: a writer's bug, not worth failing
        return None
    return summary
