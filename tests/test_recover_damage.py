"""`cpf recover` on logs damaged in the middle (record/recover.py, record/records.py): bytes overwritten in a chunk,
a chunk's length field corrupted, garbage inserted between chunks, the first chunk (which defines the channels) lost,
and random damage (hypothesis). Every message of every chunk the damage did not touch is kept, in order, and the
result reads with the strict reader (record/logfile.py)."""

from __future__ import annotations

import struct
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap.records import Chunk, Message

from supervisor.record import recorder
from supervisor.record.logfile import messages, verify
from supervisor.record.recorder import Recorder
from supervisor.record.records import chunk_records, parse, record_at
from supervisor.record.recover import MAGIC, RecoveryError, RecoveryReport, recover
from tests.test_recover import Record, read_indexed, run_messages

# (start, end, sequences of its messages) of each chunk record of a log
Span = tuple[int, int, list[int]]


def write_log(path: Path, chunk_bytes: int, steps: int | None = None) -> Path:
    chosen = run_messages()
    if steps is not None:
        chosen = [m for m in chosen if m[1] < 0.1 * steps - 1e-9]
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(recorder, "CHUNK_BYTES", chunk_bytes)
        with Recorder(path) as rec:
            for key, t, message in chosen:
                rec.write(key, t, message)
    return path


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """About 4000 messages in some 45 chunks of 32 KiB."""
    return write_log(tmp_path_factory.mktemp("log") / "run.mcap", 32 * 1024)


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """About 400 messages in some 20 chunks of 8 KiB: cheap enough to damage a few hundred times."""
    return write_log(tmp_path_factory.mktemp("small") / "run.mcap", 8 * 1024, steps=40)


def spans(path: Path) -> list[Span]:
    """Every chunk of a whole log, in file order, with the sequence numbers of its messages."""
    data = path.read_bytes()
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    out = []
    for index in sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
        found = record_at(data, index.chunk_start_offset)
        assert found is not None
        chunk = parse(*found)
        assert isinstance(chunk, Chunk)
        sequences = [r.sequence for r in chunk_records(chunk) if isinstance(r, Message)]
        out.append((index.chunk_start_offset, index.chunk_start_offset + index.chunk_length, sequences))
    return out


def recovered(src: Path, tmp_path: Path) -> tuple[RecoveryReport, list[Record]]:
    dst = tmp_path / f"{src.stem}.recovered.mcap"
    report = recover(src, dst)
    verify(dst)  # the strict reader takes it whole
    assert len(list(messages(dst))) == report.messages
    return report, read_indexed(dst)


def kept_except(records: list[Record], chunks: list[Span], lost: set[int]) -> list[Record]:
    """The run's records without those of the lost chunks (by index in chunks)."""
    gone = {sequence for n in lost for sequence in chunks[n][2]}
    return [r for r in records if r[3] not in gone]


def damaged(path: Path, where: Path, edit: bytes, start: int, end: int | None = None) -> Path:
    """The log with data[start:end] replaced by edit (end None: an insertion at start)."""
    data = path.read_bytes()
    out = where / f"damaged{start}.mcap"
    out.write_bytes(data[:start] + edit + data[start if end is None else end :])
    return out


# --- damage at chosen places --------------------------------------------------------------------------------


def test_bytes_overwritten_in_one_chunk_lose_that_chunk_only(log: Path, tmp_path: Path) -> None:
    records, chunks = read_indexed(log), spans(log)
    n = len(chunks) // 3
    start, end, lost = chunks[n]
    src = damaged(log, tmp_path, b"\xa5" * 64, (start + end) // 2, (start + end) // 2 + 64)
    report, kept = recovered(src, tmp_path)
    assert kept == kept_except(records, chunks, {n})
    assert report.chunks == len(chunks) - 1 and report.damaged_regions == 1 and not report.complete
    assert report.expected == len(records) and report.messages == len(records) - len(lost)
    assert end - start <= report.unreadable_bytes <= chunks[n + 1][0] - chunks[n - 1][1]
    assert f"{len(lost)} of the {len(records)} messages its summary counts lost" in report.describe()


def test_a_chunk_with_a_damaged_length_field_is_kept_whole(log: Path, tmp_path: Path) -> None:
    """Its CRC still matches: the chunk is whole, only the field saying where it ends is wrong."""
    records, chunks = read_indexed(log), spans(log)
    start, end, _ = chunks[len(chunks) // 2]
    for length in (2**62, end - start - 100, end - start + 5000):
        src = damaged(log, tmp_path, struct.pack("<Q", length), start + 1, start + 9)
        report, kept = recovered(src, tmp_path)
        assert kept == records, length
        assert report.chunks == len(chunks) and report.damaged_regions == 1


def test_garbage_between_chunks_is_skipped(log: Path, tmp_path: Path) -> None:
    records, chunks = read_indexed(log), spans(log)
    for garbage in (b"\x06" + bytes(range(256)) * 3, b"\x00" * 100, b"\x08" + struct.pack("<Q", 10**6)):
        src = damaged(log, tmp_path, garbage, chunks[5][1])  # right after a chunk, before its message index
        report, kept = recovered(src, tmp_path)
        assert kept == records
        assert report.chunks == len(chunks) and report.damaged_regions == 1
        assert report.unreadable_bytes >= len(garbage)


def test_a_byte_removed_from_the_header_loses_no_chunk(log: Path, tmp_path: Path) -> None:
    """The header, which has no CRC, still parses with a byte of its library string removed: it then ends one byte
    into the first chunk and takes that chunk's opcode. The resynchronisation must search from inside the header,
    not from its end (found by the random-damage test below)."""
    records, chunks = read_indexed(log), spans(log)
    last = chunks[0][0] - 1  # the header's last byte: a character of its library string
    src = damaged(log, tmp_path, b"", last, last + 1)
    report, kept = recovered(src, tmp_path)
    assert kept == records
    assert report.chunks == len(chunks) and report.damaged_regions == 1 and not report.complete


def test_a_lost_first_chunk_takes_its_channels_from_the_summary(log: Path, tmp_path: Path) -> None:
    """The first chunk defines the channels; without it the later chunks' messages are named by the summary, which
    is found even when inserted bytes moved it away from where the footer says."""
    records, chunks = read_indexed(log), spans(log)
    start = chunks[0][0]
    overwritten = damaged(log, tmp_path, b"\xff" * 32, start + 50, start + 82)
    inserted = damaged(log, tmp_path, b"\xff" * 32, start + 50)
    for src in (overwritten, inserted):
        report, kept = recovered(src, tmp_path)
        assert kept == kept_except(records, chunks, {0}), src.name
        assert report.unnamed == 0 and report.expected == len(records)


def test_without_chunk_or_summary_the_unnamed_messages_are_counted(log: Path, tmp_path: Path) -> None:
    records, chunks = read_indexed(log), spans(log)
    start, _, first = chunks[0]
    cut = damaged(log, tmp_path, b"\xff" * 32, start + 50, start + 82).read_bytes()[: chunks[10][1]]
    src = tmp_path / "cut.mcap"
    src.write_bytes(cut)
    report, kept = recovered(src, tmp_path)
    assert kept == [r for r in records[: records.index(kept[-1]) + 1] if r[3] not in first and r in kept]
    assert report.messages + report.unnamed == sum(len(c[2]) for c in chunks[1:11])
    assert report.unnamed > 0 and "their channel was defined in a lost chunk" in report.describe()


def test_damage_in_the_summary_loses_nothing(log: Path, tmp_path: Path) -> None:
    records = read_indexed(log)
    size = log.stat().st_size
    src = damaged(log, tmp_path, b"\x00" * 40, size - 200, size - 160)
    report, kept = recovered(src, tmp_path)
    assert kept == records and report.complete and report.expected is None


# --- random damage ------------------------------------------------------------------------------------------


def untouched(start: int, end: int, kind: str, offset: int, length: int) -> bool:
    """Whether a damage leaves the chunk at [start, end) of the file whole."""
    if kind == "cut":
        return end <= offset
    if kind == "insert":
        return not start < offset < end
    return offset + length <= start or end <= offset  # overwrite, delete


def intact(chunks: list[Span], kind: str, offset: int, length: int) -> Iterator[int]:
    """The chunks a damage does not touch."""
    return (n for n, (start, end, _) in enumerate(chunks) if untouched(start, end, kind, offset, length))


def is_subsequence(part: list[Record], whole: list[Record]) -> bool:
    items = iter(whole)
    return all(any(r == w for w in items) for r in part)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    kind=st.sampled_from(["overwrite", "insert", "delete", "cut"]),
    where=st.floats(0, 1),
    garbage=st.binary(min_size=1, max_size=64),
)
@example(kind="delete", where=0.000275, garbage=b"\x00")  # inside the header (the test above)
def test_random_damage_keeps_every_untouched_chunk(
    small: Path, tmp_path: Path, kind: str, where: float, garbage: bytes
) -> None:
    data, records, chunks = small.read_bytes(), read_indexed(small), spans(small)
    offset = min(int(where * len(data)), len(data) - 1)
    end = offset + len(garbage)
    edits = {
        "overwrite": data[:offset] + garbage + data[end:],
        "insert": data[:offset] + garbage + data[offset:],
        "delete": data[:offset] + data[end:],
        "cut": data[:offset],
    }
    src = tmp_path / f"{kind}.mcap"
    src.write_bytes(edits[kind])
    try:
        report, kept = recovered(src, tmp_path)
    except RecoveryError as exc:  # only a file without its magic is no MCAP at all
        assert offset < len(MAGIC) and len(str(exc).splitlines()) == 1
        return
    assert is_subsequence(kept, records)
    must_keep = {s for n in intact(chunks, kind, offset, len(garbage)) for s in chunks[n][2]}
    assert must_keep <= {r[3] for r in kept}
    assert report.messages == len(kept)
    if report.complete:  # said only of a source with nothing lost
        assert kept == records
