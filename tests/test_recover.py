"""Tests for record.recover and the recorder's crash safety: truncated logs, a SIGKILLed writer, bad input."""

from __future__ import annotations

import json
import os
import random
import re
import signal
import struct
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import orjson
import pytest
from mcap.opcode import Opcode
from mcap.reader import make_reader

from comms.records.messages import COMMS_STATS_KEY, META_KEY, TICK_KEY, rx_key, state_key, tick_message, tx_key
from supervisor.record import recorder
from supervisor.record.recorder import Recorder, seconds_to_ns
from supervisor.record.recover import MAGIC, RecoveryError, recover

ROOT = Path(__file__).resolve().parent.parent
VEHICLES = (1, 2, 3, 4)
STEPS = 400
UNKNOWN_KEY = "cpf/debug/note"  # no schema: recorded on a channel with schema id 0
CUTS = 30
FOOTER_BYTES = 9 + 8 + 8 + 4  # opcode, length, summary start, summary offset start, CRC

# (topic, log time ns, publish time ns, sequence, data) of one message
Record = tuple[str, int, int, int, bytes]


# --- a synthetic run ----------------------------------------------------------------------------------------


def state(vehicle: int, k: int, t: float) -> dict[str, Any]:
    rng = random.Random(vehicle * 100_000 + k)
    return {
        "t": t,
        "k": k,
        "vehicle": vehicle,
        "gamma": 0.01 * k + rng.random(),
        "gamma_dot": rng.random(),
        "position": [rng.uniform(-50, 50) for _ in range(3)],
        "rotation": [rng.uniform(-1, 1) for _ in range(9)],
        "velocity": [rng.random() for _ in range(3)],
        "angular_velocity": [rng.random() for _ in range(3)],
        "error": [rng.random(), rng.random(), 0.0],
        "tau": [rng.random(), rng.random()],
        "correction": rng.random(),
        "lyapunov": rng.random(),
        "tx_seq": k // 5,
        "estimate_age": [[j, rng.random()] for j in VEHICLES if j != vehicle],
    }


def step(k: int) -> Iterator[tuple[str, float, dict[str, Any]]]:
    """The messages of one sync step, in the order the supervisor records them."""
    t = 0.1 * k
    yield TICK_KEY, t, tick_message(k, t, False)
    for vehicle in VEHICLES:
        yield state_key(vehicle), t, state(vehicle, k, t)
        yield rx_key(vehicle), t, {"vehicle": vehicle, "k": k, "t": t, "receptions": []}
        if k % 5 == vehicle:
            tx = {"t": t, "stamp": t, "sender": vehicle, "seq": k // 5, "gamma": 0.01 * k, "gamma_dot": 0.01}
            yield tx_key(vehicle), t, {**tx, "position": [0.0, 1.0, 2.0], "velocity": [1.0, 0.0, 0.0]}
    if k % 20 == 0:
        yield COMMS_STATS_KEY, t, {"t": t, "sent": k, "delivered": k // 2}
        yield UNKNOWN_KEY, t, {"k": k}


def run_messages() -> list[tuple[str, float, dict[str, Any]]]:
    meta = {"name": "recover-test", "vehicles": list(VEHICLES), "versions": {"cpf-cosim": "test"}}
    return [(META_KEY, 0.0, meta)] + [message for k in range(STEPS) for message in step(k)]


def expected(messages: list[tuple[str, float, dict[str, Any]]]) -> list[Record]:
    """What the Recorder stores for these messages, in write order."""
    out = []
    for sequence, (key, t, message) in enumerate(messages, start=1):
        stamp = seconds_to_ns(t)
        out.append((key, stamp, stamp, sequence, orjson.dumps(message, option=recorder.JSON_OPTIONS)))
    return out


def read_indexed(path: Path) -> list[Record]:
    """Every message of a complete MCAP in file order, read through its summary and index."""
    with path.open("rb") as stream:
        reader = make_reader(stream)
        assert reader.get_summary() is not None, f"{path}: no summary"
        return [
            (channel.topic, m.log_time, m.publish_time, m.sequence, m.data)
            for _, channel, m in reader.iter_messages(log_time_order=False)
        ]


def channels(path: Path) -> dict[str, tuple[str, str, str, bytes]]:
    """topic -> (message encoding, schema name, schema encoding, schema data) from the summary."""
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    out = {}
    for channel in summary.channels.values():
        schema = summary.schemas.get(channel.schema_id)
        described = ("", "", b"") if schema is None else (schema.name, schema.encoding, schema.data)
        out[channel.topic] = (channel.message_encoding, *described)
    return out


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[Record]]:
    """A recorded run cut into many small chunks (32 KiB), and what it holds."""
    path = tmp_path_factory.mktemp("run") / "run.mcap"
    messages = run_messages()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(recorder, "CHUNK_BYTES", 32 * 1024)
        with Recorder(path) as rec:
            for key, t, message in messages:
                rec.write(key, t, message)
    return path, expected(messages)


def chunk_ends(path: Path) -> list[int]:
    """Offset just after each chunk record of a complete MCAP."""
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    return sorted(index.chunk_start_offset + index.chunk_length for index in summary.chunk_indexes)


def summary_start(path: Path) -> int:
    """Offset of a complete MCAP's summary section: everything before it is the whole data section."""
    data = path.read_bytes()
    opcode, length, start = struct.unpack_from("<BQQ", data, len(data) - len(MAGIC) - FOOTER_BYTES)
    assert (opcode, length) == (Opcode.FOOTER, FOOTER_BYTES - 9)
    return int(start)


def cut_points(path: Path) -> list[int]:
    """Random cuts plus the edge cases: right after the magic, mid-header, around chunk ends, one byte short."""
    size, ends = path.stat().st_size, chunk_ends(path)
    rng = random.Random(7)
    edges = [len(MAGIC), len(MAGIC) + 5, ends[0] - 1, ends[0], ends[0] + 1, ends[len(ends) // 2], ends[-1]]
    edges += [summary_start(path) - 1, summary_start(path), size - 1]
    return edges + sorted(rng.randrange(len(MAGIC), size) for _ in range(CUTS))


# --- truncated files ----------------------------------------------------------------------------------------


def test_the_run_spans_many_chunks_and_channels(run: tuple[Path, list[Record]]) -> None:
    path, records = run
    assert read_indexed(path) == records
    assert len(records) > 3000
    assert len(chunk_ends(path)) >= 20
    assert len(channels(path)) >= 15


def test_every_truncation_recovers_a_prefix_with_every_complete_chunk(
    run: tuple[Path, list[Record]], tmp_path: Path
) -> None:
    path, records = run
    data, ends, originals = path.read_bytes(), chunk_ends(path), channels(path)
    whole = summary_start(path)
    for cut in cut_points(path):
        src, dst = tmp_path / f"cut{cut}.mcap", tmp_path / f"cut{cut}.recovered.mcap"
        src.write_bytes(data[:cut])
        report = recover(src, dst)
        recovered = read_indexed(dst)
        assert recovered == records[: len(recovered)], f"cut at {cut}: not a prefix of the run"
        assert report.messages == len(recovered)
        assert report.chunks == sum(end <= cut for end in ends), f"cut at {cut}: a complete chunk was dropped"
        assert report.complete == (cut >= whole)
        assert 0 <= report.unreadable_bytes <= cut - len(MAGIC)
        assert report.last_log_time == (max(r[1] for r in recovered) if recovered else None)
        assert all(originals[topic] == described for topic, described in channels(dst).items())


def test_a_complete_file_recovers_to_the_same_messages(run: tuple[Path, list[Record]], tmp_path: Path) -> None:
    path, records = run
    report = recover(path, tmp_path / "copy.mcap")
    assert read_indexed(tmp_path / "copy.mcap") == records
    assert channels(tmp_path / "copy.mcap") == channels(path)
    assert (report.messages, report.chunks) == (len(records), len(chunk_ends(path)))
    assert report.complete and report.unreadable_bytes == 0
    assert report.last_log_time == max(r[1] for r in records)


# --- the recorder's wall-clock flush and a SIGKILLed writer -------------------------------------------------


def test_the_recorder_hands_a_chunk_to_the_os_every_flush_interval(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(recorder, "FLUSH_INTERVAL", 0.05)
    path = tmp_path / "open.mcap"
    with Recorder(path) as rec:
        assert path.read_bytes().startswith(MAGIC)  # the header is on disk at once
        for k in range(10):
            rec.write(state_key(1), 0.1 * k, state(1, k, 0.1 * k))
        time.sleep(0.06)
        rec.write(state_key(1), 1.0, state(1, 10, 1.0))  # past the interval: this write finishes the chunk
        rec.write(state_key(1), 1.1, state(1, 11, 1.1))  # in the next, still open chunk
        (tmp_path / "snapshot.mcap").write_bytes(path.read_bytes())  # what a SIGKILL now would leave
    report = recover(tmp_path / "snapshot.mcap", tmp_path / "recovered.mcap")
    assert (report.messages, report.chunks) == (11, 1)


CHILD = """
import sys, time
from pathlib import Path
from supervisor.record.recorder import Recorder

rec = Recorder(Path(sys.argv[1]))
keys = ["cpf/vehicle/1/state", "cpf/vehicle/2/state", "cpf/vehicle/3/state", "cpf/clock/tick"]
n, start = 0, time.monotonic()
while time.monotonic() - start < 20:  # the test kills it long before
    for _ in range(50):  # about 5000 messages per wall second, like a busy supervisor
        rec.write(keys[n % 4], 0.001 * n, {"n": n, "t": 0.001 * n, "pad": [0.5] * 24})
        n += 1
    print(n, time.monotonic(), flush=True)  # n messages written by then
    time.sleep(0.01)
"""
KILL_AFTER = 2.5  # s of writing
MAY_LOSE = 1.2  # s: what the kill may take, at most


def test_a_sigkilled_recorder_loses_at_most_about_a_second(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(path)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
    )
    assert child.stdout is not None
    reports: list[tuple[int, float]] = []
    try:
        while not reports or reports[-1][1] - reports[0][1] < KILL_AFTER:
            line = child.stdout.readline()
            assert line, f"writer ended early: {child.stderr.read() if child.stderr else ''}"
            count, at = line.split()
            reports.append((int(count), float(at)))
    finally:
        child.send_signal(signal.SIGKILL)
        killed_at = time.monotonic()
        rest, _ = child.communicate(timeout=10)
    assert child.returncode == -signal.SIGKILL
    reports += [(int(c), float(a)) for c, a in (line.split() for line in rest.splitlines())]
    report = recover(path, tmp_path / "recovered.mcap")
    numbers = [json.loads(r[4])["n"] for r in read_indexed(tmp_path / "recovered.mcap")]
    assert numbers == list(range(len(numbers)))
    written = reports[-1][0]
    must_keep = max((count for count, at in reports if at <= killed_at - MAY_LOSE), default=0)
    print(
        f"SIGKILL after {written} messages ({reports[-1][1] - reports[0][1]:.2f} s): recovered {report.messages} "
        f"({report.messages / written:.1%}) in {report.chunks} chunks, {report.unreadable_bytes} bytes unreadable"
    )
    assert report.messages > 0
    assert report.messages >= must_keep, f"lost more than {MAY_LOSE} s: {report.messages} < {must_keep}"


# --- bad input ----------------------------------------------------------------------------------------------


def test_a_missing_source_is_an_os_error_naming_it(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"nothing\.mcap"):
        recover(tmp_path / "nothing.mcap", tmp_path / "out.mcap")
    assert not (tmp_path / "out.mcap").exists()


@pytest.mark.parametrize(
    ("content", "reason"),
    [(b"", "empty file"), (b"\x89MCA", "not an MCAP"), (bytes(range(256)) * 40, "not an MCAP"), (b"{}\n", "not an")],
)
def test_a_source_that_is_not_an_mcap_is_a_value_error_naming_it(tmp_path: Path, content: bytes, reason: str) -> None:
    src = tmp_path / "bad.mcap"
    src.write_bytes(content)
    with pytest.raises(ValueError, match=re.escape(f"bad.mcap: {reason}")):
        recover(src, tmp_path / "out.mcap")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.mcap"]


def test_recovering_a_file_onto_itself_is_refused(run: tuple[Path, list[Record]]) -> None:
    path, _ = run
    with pytest.raises(RecoveryError, match="must not be the source"):
        recover(path, path)
