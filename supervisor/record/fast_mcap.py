"""An MCAP writer whose per-message cost is one struct pack: mcap's Writer with its chunk builder swapped.

mcap's Writer (mcap 1.6) builds each message record in ~12 Python calls (a Message dataclass, then a struct.pack and
a BytesIO write per field, a seek back to patch the length) and updates its statistics per message: ~3 us of a
4.4 us recording, for the ~72000 messages of a paper run. Here a message is one precompiled struct (opcode, length,
channel, sequence, log and publish time) and its data appended to a bytearray, and its (time, offset) to its
channel's index; the chunk's time range and the run's statistics are worked out once per chunk, from the indices.
Everything else stays the library's: the file's structure, the chunk records and their compression and CRC, the
message and chunk indices, the summary, statistics and footer; the bytes written are the library's bytes.

The swap reaches into two of the Writer's private attributes (its chunk builder and statistics); if an mcap release
renames them, FastWriter says so (`fast` is False) and writes every message through the library's own add_message.
"""

from __future__ import annotations

import struct
from typing import IO, Any

from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import Channel, Schema, Statistics
from mcap.writer import CompressionType, Writer

# A message record's head: opcode, record length, then the Message fields in the spec's order (channel id u16,
# sequence u32, log time u64, publish time u64); its data follows.
MESSAGE_HEAD = struct.Struct("<BQHIQQ")
HEAD_FIELDS = MESSAGE_HEAD.size - 9  # the record's own fields before its data (the length counts them)
INDEX_HEAD = struct.Struct("<BQHI")  # a message index's: opcode, record length, channel id u16, entries' bytes u32


class _ChannelIndex:
    """One channel's message index in the open chunk: (log time, offset) pairs, flat; written as mcap's
    MessageIndex record writes them, in one pack."""

    __slots__ = ("channel_id", "flat")

    def __init__(self, channel_id: int) -> None:
        self.channel_id = channel_id
        self.flat: list[int] = []  # time, offset, time, offset, ...

    def write(self, stream: RecordBuilder) -> None:
        """The record in one pack: opcode, its length, channel id, the entries' byte length, the entries. (A
        channel per vehicle and kind of message leaves one entry or two per index: for a fleet of 1000, a record
        built field by field cost 8 us a message.)"""
        size = len(self.flat) * 8
        stream.write(INDEX_HEAD.pack(Opcode.MESSAGE_INDEX, 6 + size, self.channel_id, size))
        stream.write(struct.pack(f"<{len(self.flat)}Q", *self.flat))


class FastChunk:
    """What mcap's Writer asks of its chunk builder (count, num_messages, message_start_time, message_end_time,
    message_indices, add_schema, add_channel, end, reset), and `add`, the message fast path. The run's statistics
    are brought up to date as each chunk ends."""

    def __init__(self, statistics: Statistics) -> None:
        self.statistics = statistics
        self.buffer = bytearray()
        self.message_indices: dict[int, _ChannelIndex] = {}
        self.num_messages = 0
        self.message_start_time = 0
        self.message_end_time = 0

    @property
    def count(self) -> int:
        return len(self.buffer)

    def add(self, channel_id: int, sequence: int, stamp: int, data: bytes) -> None:
        """A message record, log time = publish time = stamp (ns)."""
        index = self.message_indices.get(channel_id)
        if index is None:
            index = self.message_indices[channel_id] = _ChannelIndex(channel_id)
        index.flat += (stamp, len(self.buffer))
        self.buffer += MESSAGE_HEAD.pack(Opcode.MESSAGE, HEAD_FIELDS + len(data), channel_id, sequence, stamp, stamp)
        self.buffer += data
        self.num_messages += 1

    def add_schema(self, schema: Schema) -> None:
        self._record(schema)

    def add_channel(self, channel: Channel) -> None:
        self._record(channel)

    def _record(self, record: Schema | Channel) -> None:
        builder = RecordBuilder()
        record.write(builder)
        self.buffer += builder.end()

    def end(self) -> bytes:
        """The chunk's records (Writer calls it once per chunk with messages, then reset); its time range and the
        run's statistics are brought up to date first."""
        self._account()
        return bytes(self.buffer)

    def _account(self) -> None:
        stats, first, last = self.statistics, None, 0
        for channel_id, index in self.message_indices.items():
            times = index.flat[0::2]
            low, high = min(times), max(times)
            first = low if first is None else min(first, low)
            last = max(last, high)
            stats.channel_message_counts[channel_id] += len(times)
        if first is None:
            return
        self.message_start_time, self.message_end_time = first, last
        if stats.message_count == 0:
            stats.message_start_time = first
        stats.message_start_time = min(stats.message_start_time, first)
        stats.message_end_time = max(stats.message_end_time, last)
        stats.message_count += self.num_messages

    def reset(self) -> None:
        self.buffer = bytearray()
        self.message_indices = {}
        self.num_messages = 0
        self.message_start_time = self.message_end_time = 0


class FastWriter(Writer):
    """mcap's Writer (chunked, with every index, statistics and CRCs) with the message fast path `add`."""

    def __init__(self, output: IO[Any], chunk_size: int, compression: CompressionType) -> None:
        super().__init__(output, chunk_size=chunk_size, compression=compression)
        self.chunk_size = chunk_size
        statistics = getattr(self, "_Writer__statistics", None)
        builder = getattr(self, "_Writer__chunk_builder", None)
        # Only where the library is as this was written against: a chunk builder and a Statistics record.
        self.fast = isinstance(statistics, Statistics) and builder is not None and hasattr(builder, "add_message")
        self.chunk: FastChunk | None = None
        if self.fast:
            assert isinstance(statistics, Statistics)
            self.chunk = FastChunk(statistics)
            self._Writer__chunk_builder = self.chunk

    def add(self, channel_id: int, stamp: int, data: bytes, sequence: int) -> None:
        """A message at log time = publish time = stamp (ns); the chunk is finished once it outgrows chunk_size."""
        chunk = self.chunk
        if chunk is None:
            self.add_message(channel_id=channel_id, log_time=stamp, data=data, publish_time=stamp, sequence=sequence)
            return
        chunk.add(channel_id, sequence, stamp, data)
        if len(chunk.buffer) > self.chunk_size:
            self.flush()
