"""The recorder's MCAP fast path writes the bytes mcap's own Writer writes: chunks, indices, statistics, CRCs."""

from __future__ import annotations

import io
import random

import orjson
import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from supervisor.record import fast_mcap
from supervisor.record.fast_mcap import FastWriter

TOPICS = ("cpf/vehicle/1/state", "cpf/comms/event", "cpf/clock/tick", "cpf/vehicle/2/rx")
CHUNK = 4096  # small: many chunks, each finished by size


def messages(count: int) -> list[tuple[int, int, bytes, int]]:
    """(topic index, log time ns, data, sequence): times out of order (events are stamped before the states that
    bring them; now and then much earlier), sizes varied, a topic first seen late, sequence numbers wrapping as
    the recorder's do."""
    rng = random.Random(7)
    out = []
    for i in range(count):
        topic = rng.randrange(3) if i < count // 2 else rng.randrange(4)
        stamp = 10**9 + i * 100_000_000 - rng.randrange(3) * 250_000_000
        stamp = 50_000_000 if i % 997 == 996 else stamp  # now and then one far older (a late chunk's minimum)
        data = orjson.dumps({"i": i, "pad": "x" * rng.randrange(400)})
        out.append((topic, stamp, data, (2**32 - 5 + i) % 2**32))
    return out


def write(fast: bool, flush_every: int) -> bytes:
    stream = io.BytesIO()
    writer = FastWriter(stream, CHUNK, CompressionType.ZSTD) if fast else Writer(stream, chunk_size=CHUNK)
    writer.start(profile="", library="cpf-cosim")
    channels = []
    for topic in TOPICS:
        schema = writer.register_schema(name=topic, encoding="jsonschema", data=b'{"type": "object"}')
        channels.append(writer.register_channel(topic=topic, message_encoding="json", schema_id=schema))
    for n, (which, stamp, data, sequence) in enumerate(messages(3000)):
        if isinstance(writer, FastWriter):
            writer.add(channels[which], stamp, data, sequence)
        else:
            writer.add_message(channel_id=channels[which], log_time=stamp, data=data, publish_time=stamp,
                               sequence=sequence)  # fmt: skip
        if n % flush_every == flush_every - 1:
            writer.flush()  # the recorder's crash-safe chunks: finished by time as well as by size
    writer.finish()
    return stream.getvalue()


def test_the_fast_path_writes_the_bytes_of_mcaps_own_writer() -> None:
    for flush_every in (7, 250, 10_000):
        assert write(fast=True, flush_every=flush_every) == write(fast=False, flush_every=flush_every)


def test_the_fast_path_is_taken_with_the_installed_mcap() -> None:
    writer = FastWriter(io.BytesIO(), CHUNK, CompressionType.ZSTD)
    assert writer.fast and writer.chunk is not None


def test_a_library_with_other_internals_gets_every_message_through_its_own_add_message(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """An mcap release whose Writer keeps its statistics otherwise: no swap, the library writes every message."""
    monkeypatch.setattr(fast_mcap, "Statistics", type("Renamed", (), {}))
    stream = io.BytesIO()
    writer = FastWriter(stream, CHUNK, CompressionType.ZSTD)
    assert not writer.fast and writer.chunk is None
    writer.start(profile="", library="cpf-cosim")
    channel = writer.register_channel(topic="a", message_encoding="json", schema_id=0)
    for i in range(50):
        writer.add(channel, i, b"{}", i)
    writer.finish()
    reader = make_reader(io.BytesIO(stream.getvalue()), validate_crcs=True)
    assert [(m.log_time, m.sequence) for _, _, m in reader.iter_messages()] == [(i, i) for i in range(50)]


def test_a_log_of_the_fast_path_reads_back_with_its_summary_and_crcs() -> None:
    data = write(fast=True, flush_every=100)
    reader = make_reader(io.BytesIO(data), validate_crcs=True)
    summary = reader.get_summary()
    assert summary is not None and summary.statistics is not None
    assert summary.statistics.message_count == 3000
    assert len(summary.chunk_indexes) > 30
    read = [(c.topic, m.log_time, m.data, m.sequence) for _, c, m in reader.iter_messages(log_time_order=False)]
    assert read == [(TOPICS[topic], stamp, data, seq) for topic, stamp, data, seq in messages(3000)]
