"""Every command that reads a log (report, info, resim, replay, export) refuses a log cut short or damaged alike:
exit 2, one line on stderr that names the log and points to `cpf recover`, never a traceback
(supervisor/record/logfile.py)."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader

from comms.bus.bus import free_port
from supervisor import cli
from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from supervisor.record.logfile import LogError, messages, verify
from supervisor.record.recover import recover
from tests.conftest import CONFIGS, shortened

DURATION = 20.0  # s simulated: a few chunks
OFFSETS = 10  # cuts spread over the file
COMMANDS = {
    "report": ["report", "{log}", "--out", "{out}"],
    "info": ["info", "{log}"],
    "export": ["export", "{log}", "--out", "{out}"],
    "resim": ["resim", "{log}", "--out", "{out}/resim.mcap"],
    "replay": ["replay", "{log}", "--speed", "0", "--delay", "0", "--connect", "tcp/127.0.0.1:9", "--quiet"],
}


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    text = shortened((CONFIGS / "paper.toml").read_text(), DURATION)
    scenario = parse_scenario(text, "configs/paper.toml", ["faults.0.start=3", "faults.0.end=6"])
    path = tmp_path_factory.mktemp("damaged") / "run.mcap"
    run_inprocess(scenario, "configs/paper.toml", text, path, 1, Progress(DURATION, io.StringIO(), enabled=False))
    return path


def chunk_starts(path: Path) -> list[int]:
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None and len(summary.chunk_indexes) >= 2
    return sorted(c.chunk_start_offset for c in summary.chunk_indexes)


def cut_logs(log: Path, where: Path) -> list[Path]:
    """The log cut at OFFSETS places from inside its header to just before its last byte."""
    data = log.read_bytes()
    offsets = sorted({12, *(len(data) * i // OFFSETS for i in range(1, OFFSETS)), len(data) - 1})
    paths = []
    for offset in offsets:
        path = where / f"cut{offset}.mcap"
        path.write_bytes(data[:offset])
        paths.append(path)
    return paths


def corrupted_logs(log: Path, where: Path) -> list[Path]:
    """Finished logs (footer and summary intact) with bytes overwritten inside a chunk's compressed data."""
    data = log.read_bytes()
    paths = []
    for n, start in enumerate(chunk_starts(log)):
        damaged = bytearray(data)
        middle = start + 200  # past the chunk's header fields: in its zstd data
        damaged[middle : middle + 16] = bytes(255 - b for b in damaged[middle : middle + 16])
        path = where / f"corrupt{n}.mcap"
        path.write_bytes(bytes(damaged))
        paths.append(path)
    return paths


def run_cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    code = cli.main(argv)  # an uncaught exception (a traceback) fails the test here
    return code, capsys.readouterr().err


def assert_refused(command: str, path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = [part.format(log=path, out=tmp_path / "out") for part in COMMANDS[command]]
    code, err = run_cli(argv, capsys)
    lines = err.splitlines()
    assert code == cli.EXIT_INPUT, (command, path.name, err)
    assert len(lines) == 1, (command, path.name, err)
    assert lines[0].startswith(f"cpf: error: {path}: "), lines[0]
    if path.name != "cut12.mcap":  # cut inside its magic: not an MCAP at all, nothing to recover
        assert f"`cpf recover {path}`" in lines[0], lines[0]
    assert not (tmp_path / "out" / "resim.mcap").exists()  # nothing half-done
    assert not (tmp_path / "out" / "metrics.json").exists()


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_reader_refuses_a_cut_log_pointing_to_recover(
    command: str, log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for path in cut_logs(log, tmp_path):
        assert_refused(command, path, tmp_path, capsys)


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_reader_refuses_a_log_with_damaged_bytes(
    command: str, log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for path in corrupted_logs(log, tmp_path):
        assert_refused(command, path, tmp_path, capsys)


def test_info_still_describes_a_cut_log_and_says_it_is_cut(
    log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(log.read_bytes()[: chunk_starts(log)[-1] + 100])
    code = cli.main(["info", str(cut)])
    out, err = capsys.readouterr()
    assert code == cli.EXIT_INPUT
    assert "scenario   paper (configs/paper.toml)" in out and "CUT SHORT" in out
    assert err == f"cpf: error: {cut}: cut short or damaged (no footer at its end, its writer did not finish it); " \
        f"try `cpf recover {cut}`\n"  # fmt: skip


def test_the_recovered_log_reads_and_every_command_accepts_it(
    log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(log.read_bytes()[: chunk_starts(log)[-1] + 100])
    fixed = tmp_path / "fixed.mcap"
    assert recover(cut, fixed).messages > 0
    verify(fixed)
    assert [m.log_time for m in messages(fixed)] == sorted(m.log_time for m in messages(fixed))
    for command in ("info", "report", "resim"):
        code, err = run_cli([part.format(log=fixed, out=tmp_path / "out") for part in COMMANDS[command]], capsys)
        assert code == 0, (command, err)


def test_the_strict_reader_checks_the_file_before_the_first_message(log: Path, tmp_path: Path) -> None:
    """A cut log fails at once (nothing read from it is handed out), whatever was asked of it."""
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(log.read_bytes()[:-1])
    records = messages(cut, lambda topic: topic == "cpf/run/meta")
    with pytest.raises(LogError, match="no footer"):
        next(records)


# --- random damage, through the command line ----------------------------------------------------------------

DAMAGE = st.tuples(
    st.sampled_from(["overwrite", "insert", "delete", "cut"]), st.floats(0, 1), st.binary(min_size=1, max_size=64)
)
SAYS_DAMAGED = ("cpf recover", "not an MCAP", "no such log")


def damage(data: bytes, kind: str, where: float, garbage: bytes) -> bytes:
    offset = min(int(where * len(data)), len(data) - 1)
    edits = {
        "overwrite": data[:offset] + garbage + data[offset + len(garbage) :],
        "insert": data[:offset] + garbage + data[offset:],
        "delete": data[:offset] + data[offset + len(garbage) :],
        "cut": data[:offset],
    }
    return edits[kind]


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_random_damage_gives_one_line_never_a_traceback(
    command: str, log: Path, tmp_path_factory: pytest.TempPathFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every command on a randomly damaged log: exit 2 with one line naming the log and saying it is damaged (or not
    an MCAP), or exit 0 when the damage missed every byte it reads (an index record it does not use). replay runs
    its own router here, so a log it accepts is replayed (as fast as it can)."""
    data = log.read_bytes()
    argv = COMMANDS[command]
    if command == "replay":
        argv = [*argv[: argv.index("--connect")], "--listen", "{listen}", "--quiet"]

    @settings(max_examples=30, deadline=None, derandomize=True)
    @given(DAMAGE)
    def check(case: tuple[str, float, bytes]) -> None:
        where = tmp_path_factory.mktemp("case")
        path = where / "run.mcap"
        path.write_bytes(damage(data, *case))
        listen = f"tcp/127.0.0.1:{free_port()}"
        code, err = run_cli([part.format(log=path, out=where / "out", listen=listen) for part in argv], capsys)
        lines = err.splitlines()
        if code == 0:
            return
        assert len(lines) == 1, (case, err)
        assert code == cli.EXIT_INPUT, (case, err)
        assert lines[0].startswith(f"cpf: error: {path}: ") and any(s in lines[0] for s in SAYS_DAMAGED), (case, err)
        assert not (where / "out" / "resim.mcap").exists()

    check()


def summary_damaged_logs(log: Path, where: Path) -> list[Path]:
    """Finished logs with bytes overwritten in their summary section (channels, statistics, chunk index)."""
    data = log.read_bytes()
    start = int.from_bytes(data[-37 + 9 : -37 + 17], "little")  # the footer's summary start
    paths = []
    for n, offset in enumerate(range(start + 5, len(data) - 40, max(1, (len(data) - 45 - start) // 8))):
        path = where / f"summary{n}.mcap"
        path.write_bytes(data[:offset] + b"\x13\x37\x42\x99" + data[offset + 4 :])
        paths.append(path)
    return paths


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_reader_refuses_a_log_whose_summary_is_damaged(
    command: str, log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """mcap does not check the summary's CRC: a damaged one gave wrong counts (exit 0) or a KeyError in info."""
    for path in summary_damaged_logs(log, tmp_path):
        assert_refused(command, path, tmp_path, capsys)


def zeroed_logs(log: Path, where: Path) -> list[Path]:
    """The log with each of its chunks in turn zeroed, the whole record (opcode, length, CRC, compression, data):
    the footer and summary intact, the index pointing at nothing (issue 29)."""
    data = log.read_bytes()
    with log.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None and len(summary.chunk_indexes) >= 2
    paths = []
    for n, chunk in enumerate(sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)):
        zeroed = bytearray(data)
        zeroed[chunk.chunk_start_offset : chunk.chunk_start_offset + chunk.chunk_length] = bytes(chunk.chunk_length)
        path = where / f"zeroed{n}.mcap"
        path.write_bytes(bytes(zeroed))
        paths.append(path)
    return paths


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_reader_refuses_a_log_with_a_chunk_zeroed(
    command: str, log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for path in zeroed_logs(log, tmp_path):
        assert_refused(command, path, tmp_path, capsys)
