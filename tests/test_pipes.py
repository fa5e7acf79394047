"""Every command in a pipe (issue 30, item 4): a reader that stops reading (`cpf presets | head -1`) is SIGPIPE,
which Python turns into BrokenPipeError, at a write (a long output) or at the last flush (a short one): exit 0, not a
word on stderr."""

from __future__ import annotations

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
