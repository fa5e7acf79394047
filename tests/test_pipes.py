"""Every command in a pipe (issue 30, item 4): a reader that stops reading (`cpf presets | head -1`) is SIGPIPE,
which Python turns into BrokenPipeError, at a write (a long output) or at the last flush (a short one): exit 0, not a
word on stderr."""

from __future__ import annotations

import json
import os
import subprocess

import pytest

from tests.procs import CPF


@pytest.mark.parametrize("command", [["presets"], ["schema"]])  # a short output, one longer than a pipe holds
def test_a_reader_gone_is_exit_0_without_a_word(command):
    read, write = os.pipe()
    os.close(read)  # the reader has left before the first write: every write fails with EPIPE
    try:
        done = subprocess.run([CPF, *command], stdout=write, stderr=subprocess.PIPE, text=True, timeout=60)
    finally:
        os.close(write)
    assert (done.returncode, done.stderr) == (0, "")


def test_a_run_piped_into_a_reader_that_left_still_writes_its_metrics(tmp_path, paper_text):
    """`cpf run ... --metrics m.json | head -1`: the summary's print failed before the metrics were written, and the
    run said exit 0 without the file it was asked for (found by a new user)."""
    scenario = tmp_path / "short.toml"
    scenario.write_text(paper_text.replace("duration = 400.0", "duration = 2.0"))
    read, write = os.pipe()
    os.close(read)
    args = ["run", str(scenario), "--engine", "inprocess", "--quiet", "--out", "r.mcap", "--metrics", "m.json"]
    try:
        done = subprocess.run([CPF, *args], stdout=write, stderr=subprocess.PIPE, text=True, timeout=120, cwd=tmp_path)
    finally:
        os.close(write)
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "m.json").read_text())["comms"]
