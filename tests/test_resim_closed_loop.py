"""cpf resim is open loop across the fleet (each vehicle hears the gammas recorded in the run); --closed-loop keeps
the recorded channel's decisions and carries the re-simulated senders' gammas (supervisor.engine.resim_loop). On
the paper's ideal channel with a periodic policy the channel decides nothing from the gammas, so a closed-loop
re-simulation with another k is the run that k gives, to the bit; the open-loop one is not (issue 28)."""

from __future__ import annotations

import io
import json
from pathlib import Path

from comms.records.messages import META_KEY
from comms.records.records import Heard, Transmission
from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from supervisor.engine.resim import resimulate
from supervisor.engine.resim_loop import ClosedLoop
from supervisor.record.recorder import read_messages
from tests.conftest import CONFIGS, shortened

DURATION = 20.0


def _run(tmp_path: Path, name: str, overrides: list[str]) -> Path:
    text = shortened((CONFIGS / "paper.toml").read_text(), DURATION)
    scenario = parse_scenario(text, "paper.toml", ["faults=[]", *overrides])
    out = tmp_path / f"{name}.mcap"
    run_inprocess(scenario, "paper.toml", text, out, 0, Progress(DURATION, io.StringIO(), enabled=False), scene=False)
    return out


def _states(path: Path) -> dict[tuple[int, int], str]:
    return {(m["vehicle"], m["k"]): json.dumps(m, sort_keys=True) for t, _, m in read_messages(path) if "/state" in t}


def test_closed_loop_resim_with_another_k_is_the_run_that_k_gives(tmp_path):
    log, fresh = _run(tmp_path, "run", []), _states(_run(tmp_path, "k05", ["coordination.k=0.5"]))
    loop = ClosedLoop()
    *_, same = resimulate(log, [], tmp_path / "same.mcap", ClosedLoop())
    assert same.first_difference is None and same.equal == same.total == len(fresh)  # no change: the run itself
    resimulate(log, ["coordination.k=0.5"], tmp_path / "closed.mcap", loop)
    resimulate(log, ["coordination.k=0.5"], tmp_path / "open.mcap")
    closed, open_loop = _states(tmp_path / "closed.mcap"), _states(tmp_path / "open.mcap")
    assert closed == fresh and loop.unmatched == 0
    assert sum(open_loop[key] != fresh[key] for key in fresh) > len(fresh) // 4  # it heard the old gammas


def test_a_reception_whose_sender_did_not_transmit_then_is_dropped_and_counted():
    loop = ClosedLoop()
    loop.transmitted(Transmission(2, 1, 0.5, 1.2345678, 0.9, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0)))
    heard = loop.heard([Heard(2, 0.5, 9.0, 9.0), Heard(3, 0.5, 9.0, 9.0), Heard(2, 0.6, 9.0, 9.0)])
    assert [(h.sender, h.stamp) for h in heard] == [(2, 0.5)] and loop.unmatched == 2
    assert heard[0].gamma != 1.2345678 and abs(heard[0].gamma - 1.2345678) < 1e-6  # as the modem carries it: float32


def test_a_resim_logs_the_extensions_it_ran_with_not_the_recordings(tmp_path):
    """`cpf info` of a resim with another law listed the recorded law's extension (a new user): its meta is the
    re-simulated scenario's, whole."""
    log = _run(tmp_path, "run", [])
    resimulate(log, ["coordination.law=saturated", "coordination.law_options={k_c=0.3}"], tmp_path / "s.mcap")

    def laws(path: Path) -> list[str]:
        (meta,) = [m for t, _, m in read_messages(path) if t == META_KEY]
        return [e.split(" (")[0] for e in meta["extensions"] if e.startswith("law ")]

    assert laws(log) == ["law corrected = vehicles.coordination:Corrected"]
    assert laws(tmp_path / "s.mcap") == ["law saturated = vehicles.coordination:Saturated"]
