"""Output paths no command can write (issue 28): one line naming the option and the path, exit 2, before any work and
with nothing half-written. /proc takes no new file or directory from anyone, root included (os.access says yes to
root there: the check tries)."""

from __future__ import annotations

from pathlib import Path

import pytest

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
