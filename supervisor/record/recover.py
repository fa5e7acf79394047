"""Recovery of an MCAP whose writer died (SIGKILL, power cut) or whose bytes were damaged: no summary, no footer,
a partial last chunk, chunks overwritten, lengths corrupted, garbage in between.

The source is read record by record from its start. Every record that checks is kept (schemas, channels, messages,
chunks whose data decompresses to the announced size and CRC, metadata, attachments). At a record that is cut or
damaged, the scan resynchronises: it looks for the next whole chunk (supervisor/record/records.py) from the end of
the last record it trusted, skips what lies between, and goes on from there to the end of the data section. What
was kept is written, in the same order, to a new MCAP with a summary and an index: same topics, schemas, encodings,
times, sequences and bytes. A chunk lost to damage may have been the one that defined a channel; the channel is
then taken from the source's summary when that is whole (its CRC matches), else its messages cannot be named and
are counted as lost. The report says what was skipped and, when the source's summary counts them, how many
messages were lost.
The Recorder (supervisor/record/recorder.py) finishes a chunk at least every half second, so a killed run loses at most
about its last second. A similar repair with the mcap CLI: `mcap recover in.mcap -o out.mcap`.
"""

from __future__ import annotations

import mmap
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from mcap.opcode import Opcode
from mcap.records import Attachment, Channel, Chunk, DataEnd, Footer, Header, McapRecord, Message, Metadata, Schema
from mcap.writer import CompressionType, Writer

from supervisor.errors import CorruptRecord, RecoveryError
from supervisor.record.provenance import RECOVERED
from supervisor.record.records import (
    MAGIC,
    PREFIX,
    SourceSummary,
    chunk_records,
    next_chunk,
    parse,
    record_at,
    trusted_summary,
)

__all__ = ["MAGIC", "RecoveryError", "RecoveryReport", "recover"]

DEFAULT_HEADER = Header(profile="", library="cpf recover")  # for a source cut before its header ends


@dataclass(frozen=True)
class RecoveryReport:
    """What recover() kept and what it could not.

    unreadable_bytes: bytes of the source skipped (damaged regions and a cut end; the index records among them are
    rebuilt, not lost). damaged_regions: places where the scan had to resynchronise before the end of the file.
    unnamed: messages of whole chunks dropped because the chunk defining their channel was lost and no whole summary
    names it. expected: the message count of the source's summary, when it has a whole one. last_log_time: ns, None
    without messages. complete: the data section was whole (it ended with its DataEnd record, nothing skipped)."""

    messages: int
    chunks: int
    unreadable_bytes: int
    last_log_time: int | None
    complete: bool
    damaged_regions: int = 0
    unnamed: int = 0
    expected: int | None = None

    def describe(self) -> str:
        last = "-" if self.last_log_time is None else f"{self.last_log_time / 1e9:.3f} s"
        kept = f"{self.messages} messages recovered from {self.chunks} chunk(s), last log time {last}"
        if self.complete:
            return f"{kept}; complete source"
        lost = [f"{self.unreadable_bytes} unreadable bytes dropped"]
        if self.damaged_regions:
            lost[0] += f" ({self.damaged_regions} damaged region(s) skipped)"
        if self.expected is not None:
            missing = max(self.expected - self.messages, 0)
            lost.append(f"{missing} of the {self.expected} messages its summary counts lost")
        if self.unnamed:
            lost.append(f"{self.unnamed} messages of whole chunks dropped: their channel was defined in a lost chunk")
        return f"{kept}; " + "; ".join(lost)


@dataclass
class _Copy:
    """Writes the kept records, in order, to a fresh writer, mapping schema and channel ids."""

    writer: Writer
    summary: SourceSummary | None = None  # the source's, if whole: channels and schemas a lost chunk defined
    started: bool = False
    schemas: dict[int, int] = field(default_factory=dict)
    channels: dict[int, int] = field(default_factory=dict)
    messages: int = 0
    chunks: int = 0
    unnamed: int = 0
    last_log_time: int | None = None

    def start(self, header: Header = DEFAULT_HEADER) -> None:
        if not self.started:
            self.writer.start(profile=header.profile, library=header.library)
            self.started = True

    def add(self, record: McapRecord) -> None:
        self.start()
        if isinstance(record, Schema):
            self._schema(record)
        elif isinstance(record, Channel):
            self._channel(record)
        elif isinstance(record, Message):
            self._message(record)
        elif isinstance(record, Metadata):
            self.writer.add_metadata(record.name, record.metadata)
        elif isinstance(record, Attachment):
            self.writer.add_attachment(record.create_time, record.log_time, record.name, record.media_type, record.data)

    def _schema(self, schema: Schema) -> None:
        if schema.id not in self.schemas:
            self.schemas[schema.id] = self.writer.register_schema(schema.name, schema.encoding, schema.data)

    def _channel(self, channel: Channel) -> None:
        if channel.id in self.channels:
            return
        if channel.schema_id not in self.schemas and self.summary is not None:
            lost = self.summary.schemas.get(channel.schema_id)
            if lost is not None:
                self._schema(lost)
        schema = self.schemas.get(channel.schema_id, 0)  # defined in a lost chunk, and no summary: none
        self.channels[channel.id] = self.writer.register_channel(
            channel.topic, channel.message_encoding, schema, channel.metadata
        )

    def _message(self, message: Message) -> None:
        if message.channel_id not in self.channels:
            lost = None if self.summary is None else self.summary.channels.get(message.channel_id)
            if lost is None:
                self.unnamed += 1
                return
            self._channel(lost)
        self.writer.add_message(
            self.channels[message.channel_id], message.log_time, message.data, message.publish_time, message.sequence
        )
        self.messages += 1
        last = self.last_log_time
        self.last_log_time = message.log_time if last is None else max(last, message.log_time)

    def record(self, opcode: int, body: bytes) -> tuple[bool, bool]:
        """Copy one top-level record: (whether it was one to trust, whether the data section ends with it).
        CorruptRecord if it does not parse or check, before anything of it is written."""
        record = parse(opcode, body)
        if isinstance(record, Header):
            if self.started:  # a file has one header, first: another is damage that happens to parse
                raise CorruptRecord("a second header")
            self.start(record)
        elif isinstance(record, DataEnd | Footer):
            return True, True
        elif isinstance(record, Chunk):
            self.chunk(chunk_records(record))
        elif record is not None:
            self.add(record)
        return record is not None, False

    def chunk(self, records: list[McapRecord]) -> None:
        for item in records:
            self.add(item)
        self.chunks += 1


@dataclass
class _Scan:
    """Where the scan of the source stands: trusted is the end of the last record that checked (index records,
    which do not, are read past). A resynchronisation searches from resume: the end of the last whole chunk, or
    the body of the last other record that parsed, since one without a CRC can parse with a byte removed from it
    and so swallow the start of the next record (a header that took the next chunk's opcode)."""

    offset: int = len(MAGIC)
    trusted: int = len(MAGIC)
    resume: int = len(MAGIC)
    skipped: int = 0
    regions: int = 0
    complete: bool = False


def _resync(data: Any, scan: _Scan, copy: _Copy) -> bool:
    """After a record that is cut or damaged: go on at the next whole chunk (copied), False if there is none."""
    found = next_chunk(data, scan.resume)
    if found is None:
        scan.skipped += len(data) - scan.trusted
        return False
    start, records, end = found
    scan.skipped += max(start - scan.trusted, 0)
    scan.regions += 1
    copy.chunk(records)
    scan.offset = scan.trusted = scan.resume = end
    return True


def _scan(data: Any, copy: _Copy) -> _Scan:
    """Copy the records of the data section, resynchronising past damage, until its end or the file's."""
    scan = _Scan()
    while scan.offset < len(data):
        found = record_at(data, scan.offset)
        try:
            if found is None:
                raise CorruptRecord("a record runs past the end of the file")
            trusted, done = copy.record(*found)
        except CorruptRecord:
            if not _resync(data, scan, copy):
                return scan
            continue
        start, scan.offset = scan.offset, scan.offset + PREFIX.size + len(found[1])
        if trusted:
            # A resynchronisation searches from the first record without a CRC since the last whole chunk: a run of
            # them may be damage that parses (each one swallowing the start of the next), so a later one proves
            # nothing about where the next chunk starts.
            after_chunk = scan.resume == scan.trusted
            scan.trusted = scan.offset
            if found[0] == Opcode.CHUNK:
                scan.resume = scan.offset
            elif after_chunk:
                scan.resume = start + PREFIX.size
        if done:
            scan.complete = scan.regions == 0
            return scan
    scan.skipped += scan.offset - scan.trusted
    return scan


def _check_source(src: Path, stream: IO[bytes], size: int) -> None:
    if size == 0:
        raise RecoveryError(f"{src}: empty file, not an MCAP")
    if stream.read(len(MAGIC)) != MAGIC:
        raise RecoveryError(f"{src}: not an MCAP file (no MCAP magic at its start)")


def _copy(src: Path, stream: IO[bytes], writer: Writer) -> RecoveryReport:
    """Copy the readable records of an opened source; the report of what was kept."""
    _check_source(src, stream, os.fstat(stream.fileno()).st_size)
    with mmap.mmap(stream.fileno(), 0, access=mmap.ACCESS_READ) as data:
        summary = trusted_summary(data)
        copy = _Copy(writer, summary)
        scan = _scan(data, copy)
    copy.start()  # a source cut inside its header still gives a valid (empty) MCAP
    expected = None if summary is None else summary.message_count
    kept = (copy.messages, copy.chunks, scan.skipped, copy.last_log_time, scan.complete)
    return RecoveryReport(*kept, scan.regions, copy.unnamed, expected)


def recover(src: Path, dst: Path) -> RecoveryReport:
    """Write to dst a complete, indexed MCAP holding every readable message of src, a possibly truncated or damaged
    MCAP.

    Raises OSError if src cannot be read or dst written, RecoveryError if src is not an MCAP or dst is src.
    dst appears only once complete (written beside it, then renamed).
    """
    if dst.exists() and dst.resolve() == src.resolve():
        raise RecoveryError(f"{dst}: the destination must not be the source")
    if dst.is_symlink():  # written through: the rename below would put a file in the link's place
        dst = dst.resolve()
    with src.open("rb") as source:
        dst.parent.mkdir(parents=True, exist_ok=True)
        partial = dst.with_name(dst.name + ".part")
        try:
            with partial.open("wb") as out:
                writer = Writer(out, compression=CompressionType.ZSTD)
                report = _copy(src, source, writer)
                writer.add_metadata(RECOVERED, {"source": str(src), "kept": report.describe()})  # for cpf report
                writer.finish()
            partial.replace(dst)
        finally:
            partial.unlink(missing_ok=True)
    return report
