"""docs/extending.md's tutorial, as a reader follows it: its package (examples/cpf-rate-free) installed with pip, its
law found through the entry point, its commands run as written, the engines' records identical (issue 22 item 5)."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from supervisor.record.recorder import read_messages
from tests.conftest import shortened

ROOT = Path(__file__).resolve().parent.parent
DOC = (ROOT / "docs" / "extending.md").read_text(encoding="utf-8")
PACKAGE = ROOT / "examples" / "cpf-rate-free"
CPF = Path(sys.executable).parent / "cpf"


def blocks(marker: str, language: str) -> list[str]:
    return re.findall(rf"<!-- {marker}[^>]*-->\n```{language}\n(.*?)```", DOC, flags=re.S)


def test_the_tutorials_law_is_the_packages_file():
    (code,) = blocks("the file examples/cpf-rate-free/cpf_rate_free/__init__.py", "python")
    assert code == (PACKAGE / "cpf_rate_free" / "__init__.py").read_text(encoding="utf-8")
    assert len([line for line in code.splitlines() if line.strip()]) < 30  # "a law in under 30 lines"


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The package pip-installed into a directory of its own (not this venv: other tests list what is installed)."""
    target = tmp_path_factory.mktemp("site")
    pip = [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(target), str(PACKAGE)]
    subprocess.run(pip, check=True, capture_output=True, timeout=300)
    return target


SHORT = 60.0  # s of the paper scenario the commands run on
SLOWDOWN = (("start = 150.0", "start = 30.0"), ("end = 250.0", "end = 45.0"))  # AUV 1's speed cap, moved into them


def configs_with_a_shorter_paper(tmp_path: Path) -> None:
    """tmp_path/configs as the repository's, its paper scenario cut to 60 s with AUV 1's slowdown moved to 30-45 s:
    the commands run as written on 15 % of the simulated time (the suite runs on CPU it has not to spare); a full
    paper run is held to its digest on both engines by tests/test_bit_identical.py."""
    (tmp_path / "configs").mkdir()
    for entry in (ROOT / "configs").iterdir():
        if entry.name != "paper.toml":
            (tmp_path / "configs" / entry.name).symlink_to(entry)
    text = shortened((ROOT / "configs" / "paper.toml").read_text(), SHORT)
    for old, new in SLOWDOWN:
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    (tmp_path / "configs" / "paper.toml").write_text(text)


@pytest.mark.timeout(400)  # two paper runs and two four-run sweeps, as the tutorial has them: ~40 s on 2 cores
def test_the_tutorials_commands_run_and_the_engines_agree(installed: Path, tmp_path: Path):
    env = {**os.environ, "PYTHONPATH": str(installed)}
    configs_with_a_shorter_paper(tmp_path)
    plugins = subprocess.run([str(CPF), "plugins"], env=env, capture_output=True, text=True, check=True).stdout
    assert "rate_free     cpf_rate_free:RateFree" in plugins and "cpf-rate-free 0.1.0" in plugins
    for block in blocks("run by tests/test_extending_tutorial.py", "sh"):
        for line in block.strip().splitlines():
            args = shlex.split(line)
            assert args[0] == "cpf"
            done = subprocess.run([str(CPF), *args[1:]], cwd=tmp_path, env=env, capture_output=True, text=True)
            assert done.returncode == 0, (line, done.stderr)
    runs = tmp_path / "runs" / "rate_free"
    states = [
        sorted((t, str(m)) for topic, t, m in read_messages(runs / name) if topic.endswith("/state"))
        for name in ("in.mcap", "zenoh.mcap")
    ]
    assert len(states[0]) == 3 * round(SHORT / 0.1) and states[0] == states[1]
    rows = (runs / "sweep" / "results.csv").read_text().splitlines()
    assert len(rows) == 5 and any("rate_free" in row for row in rows) and any("corrected" in row for row in rows)
    (script,) = blocks("run by tests/test_extending_tutorial.py", "python")
    done = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    printed = done.stdout.splitlines()
    assert len(printed) == 5 and sum("rate_free" in line for line in printed) == 2, done.stdout
