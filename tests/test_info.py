"""Tests for supervisor.tools.info: describing a log from its summary, from reading it, and when it is cut short."""

from __future__ import annotations

import io
import re
from collections import Counter
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.records import ChunkIndex
from mcap.writer import Writer

from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from supervisor.record.logfile import read_raw
from supervisor.record.recorder import read_messages
from supervisor.record.recover import recover
from supervisor.tools import info
from supervisor.tools.info import LogError, describe, overview
from tests.conftest import CONFIGS, shortened

DURATION = 30.0
OVERRIDES = ["faults.0.start=3", "faults.0.end=6", "vehicles.1.preset=remus100_legacy"]  # a mixed fleet
# a broker_kill without an end acts one step: it was described as lasting to the end of the run (a new user)
EXTRA_FAULTS = ["kind=link_down,sender=1,receiver=2,start=4,end=5", "kind=broker_kill,start=20"]
TOPIC_LINE = re.compile(r"^  (\S+)\s+(\d+)$")


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """paper.toml shortened to 30 s (a few chunks), its speed cap moved into the run, a link cut during it, the
    broker killed for a step, vehicle 2 on another preset."""
    text = shortened((CONFIGS / "paper.toml").read_text(), DURATION)
    scenario = parse_scenario(text, "configs/paper.toml", OVERRIDES, EXTRA_FAULTS)
    path = tmp_path_factory.mktemp("info") / "run.mcap"
    run_inprocess(scenario, "configs/paper.toml", text, path, 7, Progress(DURATION, io.StringIO(), enabled=False))
    return path


def topic_counts(text: str) -> dict[str, int]:
    return {m[1]: int(m[2]) for line in text.splitlines() if (m := TOPIC_LINE.match(line))}


def logged_counts(path: Path) -> dict[str, int]:
    """Messages per topic as supervisor.record.recorder reads them (a different reader)."""
    return dict(Counter(topic for topic, _, _ in read_messages(path)))


def chunk_indexes(path: Path) -> list[ChunkIndex]:
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    return summary.chunk_indexes


def test_describe_a_run(log: Path) -> None:
    text = describe(log)
    counts = logged_counts(log)
    assert topic_counts(text) == counts
    assert set(counts) >= {"cpf/run/meta", "cpf/comms/events", "cpf/comms/stats", "cpf/vehicle/3/state"}
    size = log.stat().st_size
    assert text.splitlines()[0].startswith(f"{log}: ")
    assert f"({size} bytes), {sum(counts.values())} messages on {len(counts)} topics" in text
    assert "counts from the file's summary" in text
    for line in (
        "scenario   paper (configs/paper.toml)",
        "engine     inprocess, clock lockstep, seed 7, step 0.1 s",
        "duration   30 s simulated (scenario); messages from t = 0 to 30 s",
        "vehicles   1 remus100_neutral, 2 remus100_legacy, 3 remus100_neutral",
        "graph      1-2, 1-3",
        "faults     speed_cap on [3, 6) s: vehicle 1 (gamma_dot_max 0.5)",
        "           link_down on [4, 5) s: link 1<->2",
        "           broker_kill on [20, 20.1) s: broker",
    ):
        assert line in text.splitlines(), line
    from importlib import metadata

    versions = next(line for line in text.splitlines() if line.startswith("versions   "))
    assert f"numpy {metadata.version('numpy')}" in versions and "cpf-cosim " in versions and "python 3." in versions


def test_describe_reads_only_the_summary_and_meta(log: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A finished log is described without scanning it: the summary has the counts, the index finds the meta."""

    def no_scan(*args: object) -> None:
        raise AssertionError("the whole log was read")

    monkeypatch.setattr(info, "scan", no_scan)
    assert "scenario   paper" in describe(log)


def test_describe_a_cut_log(log: Path, tmp_path: Path) -> None:
    """A log cut short (no summary, a partial chunk) is described as far as it goes: what `cpf recover` keeps."""
    chunks = sorted(c.chunk_start_offset + c.chunk_length // 2 for c in chunk_indexes(log))
    assert len(chunks) > 1
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(log.read_bytes()[: chunks[-1]])  # in the middle of the last chunk
    text, problem = overview(cut)
    assert "CUT SHORT, no summary" in text and "cpf recover" in text
    assert problem is not None and f"try `cpf recover {cut}`" in str(problem)
    assert overview(log)[1] is None
    assert "scenario   paper (configs/paper.toml)" in text
    kept = recover(cut, tmp_path / "fixed.mcap")
    counts = topic_counts(text)
    assert counts == logged_counts(tmp_path / "fixed.mcap")
    assert 0 < sum(counts.values()) == kept.messages < sum(logged_counts(log).values())
    last = re.search(r"messages from t = 0 to ([\d.]+) s", text)
    assert last is not None and kept.last_log_time is not None
    assert float(last[1]) == pytest.approx(kept.last_log_time / 1e9)


def test_describe_a_log_cut_in_its_header(log: Path, tmp_path: Path) -> None:
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(log.read_bytes()[:20])
    text = describe(cut)
    assert "0 messages on 0 topics" in text
    assert "no cpf/run/meta message" in text and "topics     none" in text


def test_describe_a_log_without_statistics(tmp_path: Path) -> None:
    """Unchunked, no statistics: counted by reading; a topic the project does not know is still listed."""
    path = tmp_path / "plain.mcap"
    with path.open("wb") as stream:
        writer = Writer(stream, use_chunking=False, use_statistics=False)
        writer.start()
        channel = writer.register_channel("other/topic", "json", 0)
        for k in range(5):
            writer.add_message(channel, k * 1_000_000_000, b"{}", k * 1_000_000_000)
        writer.finish()
    text = describe(path)
    assert "no statistics in the file: counted by reading it" in text
    assert topic_counts(text) == {"other/topic": 5}
    assert "no cpf/run/meta message" in text
    raw = read_raw(path, lambda topic: True)
    assert raw.complete and [m.log_time for m in raw.messages] == [k * 1_000_000_000 for k in range(5)]


def test_not_a_log(tmp_path: Path) -> None:
    text_file = tmp_path / "notes.mcap"
    text_file.write_text("hello")
    with pytest.raises(LogError, match=r"notes\.mcap: not an MCAP file"):
        describe(text_file)
    with pytest.raises(LogError, match=r"missing\.mcap: no such log file"):
        describe(tmp_path / "missing.mcap")


def test_a_meta_message_that_does_not_read_is_said_and_the_rest_described(tmp_path: Path) -> None:
    """The meta is read through its record (supervisor.record.meta.RunMeta): a malformed one is named, not shown
    as if it were the run's (a step of "fast" was printed as "step fast s")."""
    path = tmp_path / "odd.mcap"
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start()
        channel = writer.register_channel("cpf/run/meta", "json", 0)
        writer.add_message(channel, 0, b'{"scenario_name": "x", "step": "fast"}', 0)
        writer.finish()
    text = describe(path)
    assert "cpf/run/meta does not read (field 'step': Expected `float`, got `str` - at `$.step`)" in text
    assert "step fast" not in text and topic_counts(text) == {"cpf/run/meta": 1}
