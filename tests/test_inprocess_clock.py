"""The in-process engine on the realtime clock (issue 28): paced at --speed and recorded as such, as the Zenoh
engine's; it ran as fast as it could and recorded "clock lockstep"."""

from __future__ import annotations

import time
from pathlib import Path

from comms.records.messages import META_KEY
from supervisor.record.recorder import read_messages
from tests.test_input_regressions import PAPER, cli


def test_the_realtime_clock_paces_the_in_process_engine_and_says_so(tmp_path: Path):
    out = tmp_path / "paced.mcap"
    began = time.monotonic()
    code, lines = cli("run", str(PAPER), "--engine", "inprocess", "--quiet", "--clock", "realtime", "--speed", "4",
                      "--set", "scenario.duration=6", "--set", "faults=[]", "--out", str(out))  # fmt: skip
    took = time.monotonic() - began
    assert code == 0, lines
    assert took >= 6.0 / 4 - 0.1  # its last step starts (6 - dt) / 4 s after its first: no sooner
    (meta,) = [m for topic, _, m in read_messages(out) if topic == META_KEY]
    assert meta["engine"] == "inprocess" and meta["clock"] == "realtime"
