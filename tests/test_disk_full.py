"""A full disk (issue 29, item 5): exit 1 and one line, "no space left on device writing RUN.mcap; `cpf recover ...`
keeps what was written", never a traceback; what was written recovers. The full disk is injected (ENOSPC from the
log's file once it holds LIMIT bytes), so the test needs no tmpfs."""

from __future__ import annotations

import errno
import io
from pathlib import Path
from typing import IO, Any

import pytest

from supervisor import cli
from supervisor.record import recorder
from supervisor.record.logfile import read_messages
from supervisor.record.recover import recover
from tests.conftest import CONFIGS, shortened

LIMIT = 150_000  # bytes the "disk" takes: a few chunks of a run, far from all of it


class FullDisk(io.RawIOBase):
    """A file that takes LIMIT bytes, then fails every write with ENOSPC as a full disk does."""

    def __init__(self, path: Path) -> None:
        self.file = path.open("wb")
        self.size = 0

    def writable(self) -> bool:
        return True

    def write(self, data: Any) -> int:
        if self.size + len(data) > LIMIT:
            raise OSError(errno.ENOSPC, "No space left on device")
        self.size += len(data)
        return self.file.write(data)

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = 0) -> int:
        return self.file.seek(offset, whence)

    def tell(self) -> int:
        return self.file.tell()

    def fileno(self) -> int:
        return self.file.fileno()

    def close(self) -> None:
        self.file.close()
        super().close()


def full_disk(path: Path) -> IO[bytes]:
    return io.BufferedWriter(FullDisk(path))


@pytest.mark.parametrize("engine", ["inprocess", "zenoh"])
def test_a_full_disk_is_one_line_and_exit_1_and_the_log_recovers(engine, tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(recorder, "open_exclusively", full_disk)
    # Chunks every 0.05 s of wall time rather than 0.5 s: a run that starts fast (forked processes) filled the disk
    # within its first chunk, and the log kept only the meta's (25 messages, in 1 of 5 runs).
    monkeypatch.setattr(recorder, "FLUSH_INTERVAL", 0.05)
    scenario = tmp_path / "s.toml"
    scenario.write_text(shortened((CONFIGS / "paper.toml").read_text(), 60.0))
    out = tmp_path / "run.mcap"
    code = cli.main(["run", str(scenario), "--engine", engine, "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 1, err
    assert err == f"cpf: error: no space left on device writing {out}; `cpf recover {out}` keeps what was written\n"
    fixed = tmp_path / "fixed.mcap"
    recover(out, fixed)
    assert len(read_messages(fixed)) > 100  # what was written before the disk filled
