"""Output paths no command can write (issue 28): one line naming the option and the path, exit 2, before any work and
with nothing half-written. /proc takes no new file or directory from anyone, root included (os.access says yes to
root there: the check tries)."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from mcap.writer import Writer

from tests.test_input_regressions import PAPER, SHORT, cli

NOWHERE = "/proc/cpf-test-nowhere"


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("log") / "run.mcap"
    code, lines = cli("run", str(PAPER), *SHORT, "--out", str(out))
    assert code == 0, lines
    return out


def one_line(code: int, lines: list[str], option: str, path: str) -> str:
    assert code == 2 and len(lines) == 1, lines
    assert lines[0].startswith("cpf: error: ") and f"{option}: " in lines[0] and lines[0].endswith(f"got {path}")
    return lines[0]


@pytest.mark.parametrize(
    ("command", "path", "problem"),
    [
        ("report", f"{NOWHERE}/figures", "cannot make the directory"),
        ("recover", f"{NOWHERE}.mcap", "not writable"),
        ("resim", f"{NOWHERE}.mcap", "not writable"),
    ],
)
def test_a_command_on_a_log_refuses_an_out_it_cannot_write(log: Path, command: str, path: str, problem: str):
    code, lines = cli(command, str(log), "--out", path)
    assert problem in one_line(code, lines, "--out", path)


def test_report_refuses_an_out_that_is_a_file(log: Path):
    code, lines = cli("report", str(log), "--out", str(log))
    assert "--out: not a directory" in one_line(code, lines, "--out", str(log))


def test_sweep_refuses_an_out_it_cannot_make_before_any_run(tmp_path: Path):
    code, lines = cli("sweep", str(PAPER), "--param", "comms.loss=0,0.1", "--out", NOWHERE)
    assert "cannot make the directory" in one_line(code, lines, "--out", NOWHERE)


def test_per_refuses_an_out_it_cannot_write():
    code, lines = cli("per", "--out", f"{NOWHERE}.png")
    assert "not writable" in one_line(code, lines, "--out", f"{NOWHERE}.png")


def test_run_refuses_metrics_it_cannot_write_before_the_run(tmp_path: Path):
    out = tmp_path / "run.mcap"
    code, lines = cli("run", str(PAPER), *SHORT, "--out", str(out), "--metrics", f"{NOWHERE}.json")
    assert "not writable" in one_line(code, lines, "--metrics", f"{NOWHERE}.json")
    assert not out.exists()  # refused before the run: no log


# --- paths that are not regular files (found by a new user) ---------------------------------------------------------


@pytest.fixture
def fifo(tmp_path: Path) -> Path:
    path = tmp_path / "fifo.mcap"
    os.mkfifo(path)
    return path


@pytest.mark.parametrize("command", ["recover", "resim"])
def test_a_log_out_that_is_not_a_regular_file_is_refused_and_left_as_it_is(log: Path, fifo: Path, command: str):
    """recover renamed its file over a device or FIFO given as --out (/dev/null became a regular file)."""
    code, lines = cli(command, str(log), "--out", str(fifo), *(["--set", "coordination.k=0.3"] * (command == "resim")))
    assert "not a regular file" in one_line(code, lines, "--out", str(fifo))
    assert stat.S_ISFIFO(fifo.stat().st_mode)


def test_run_refuses_a_log_out_that_is_not_a_regular_file_rather_than_hang(fifo: Path):
    code, lines = cli("run", str(PAPER), *SHORT, "--out", str(fifo))
    assert "not a regular file" in one_line(code, lines, "--out", str(fifo))


def test_recover_writes_through_a_symlink_given_as_out(log: Path, tmp_path: Path):
    target, link = tmp_path / "target.mcap", tmp_path / "link.mcap"
    target.touch()
    link.symlink_to(target)
    code, lines = cli("recover", str(log), "--out", str(link))
    assert code == 0, lines
    assert link.is_symlink() and target.stat().st_size > 0


@pytest.mark.parametrize("command", ["info", "report", "replay", "recover"])
def test_a_log_that_is_a_fifo_or_a_directory_is_refused_at_once(fifo: Path, tmp_path: Path, command: str):
    """`cpf info FIFO` waited for a writer for ever; recover said 'no such log file' of a directory."""
    for path, what in ((fifo, "not a log file"), (tmp_path, "not a log file")):
        code, lines = cli(command, str(path))
        assert code == 2 and what in lines[-1], lines


def test_metrics_on_a_full_device_is_one_line_naming_it(tmp_path: Path):
    code, lines = cli("run", str(PAPER), *SHORT, "--out", str(tmp_path / "r.mcap"), "--metrics", "/dev/full")
    assert (code, lines[-1]) == (1, "cpf: error: /dev/full: No space left on device"), lines


def another_tools_log(path: Path, topic: str, data: bytes) -> Path:
    """An MCAP of one JSON-encoded message on topic, written by another tool than cpf."""
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="another tool")
        schema = writer.register_schema(name="Any", encoding="jsonschema", data=b'{"type": "object"}')
        channel = writer.register_channel(topic=topic, message_encoding="json", schema_id=schema)
        writer.add_message(channel, log_time=0, publish_time=0, data=data)
        writer.finish()
    return path


@pytest.mark.parametrize("command", ["report", "export"])
def test_a_log_of_another_tool_is_refused_not_reported_empty(tmp_path: Path, command: str):
    """Four empty figures and a metrics.json of nulls, or six empty tables, exit 0."""
    foreign = another_tools_log(tmp_path / "foreign.mcap", "/imu", b'{"x": 1}')
    code, lines = cli(command, str(foreign), "--out", str(tmp_path / "out"))
    assert (code, lines) == (
        2,
        [f"cpf: error: {foreign}: holds no record of a cpf run (no cpf/ message): not a cpf log"],
    )


def test_a_message_that_is_not_json_is_not_sent_to_cpf_recover(tmp_path: Path):
    """'cut short or damaged ...; try cpf recover' of a log whose chunks check but whose message is not JSON: recover
    copied it as it was, and the recovered log got the same advice (a new user went round in a loop)."""
    odd = another_tools_log(tmp_path / "odd.mcap", "cpf/vehicle/1/state", b"garbage")
    code, lines = cli("report", str(odd), "--out", str(tmp_path / "out"))
    assert code == 2 and "is not JSON" in lines[-1] and "recover" not in lines[-1], lines
