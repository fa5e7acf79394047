"""Digests of what a run recorded, by kind of record, to hold a restructuring to bit-identical results.

`python -m tests.run_digest` runs the reference runs (the paper scenario, paper_acoustic, reference_everything.toml
and a 10-seed fault soak, on the engines named below) and writes tests/data/run_digests.json;
tests/test_bit_identical.py runs them again and compares. Regenerate the file only for a change that is meant to
change results, and say so in the commit.

A digest is the SHA-256 of every record of one kind (state, tx, rx, event, fault, graph, stats) in canonical form:
sorted keys, floats as Python prints them (round-trip exact), ordered by log time and then by content (processes
that write at the same simulated instant may reach the recorder in any order). Link events count one by one, each at
its own time, as the logs the fixture was made from kept them (a record each): a cpf/comms/events batch is taken
apart (comms.records.events.logged_events), so the fixture holds whatever the batching.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np

from comms.records.events import EVENT_TOPICS, logged_events
from supervisor.record.recorder import read_messages, seconds_to_ns
from tests.conftest import CONFIGS, shortened
from tests.procs import cpf
from tests.test_faults_e2e import random_schedule

FIXTURE = Path(__file__).resolve().parent / "data" / "run_digests.json"
# Every computation a run can make (navigation, currents, mismatch, saturation, fading, ...): see its header.
EVERYTHING = FIXTURE.parent / "reference_everything.toml"
KINDS = {
    "state": "/state",
    "tx": "/tx",
    "rx": "/rx",
    "event": "cpf/comms/event",
    "fault": "cpf/run/fault",
    "graph": "cpf/run/graph",
    "stats": "cpf/comms/stats",
}
SOAK_SEEDS = range(10)


def kind_of(topic: str) -> str | None:
    for kind, mark in KINDS.items():
        if topic.endswith(mark) or topic == mark:
            return kind
    return None


def digest(log: Path) -> dict[str, str]:
    """kind -> 'count:sha256' of the log's records of that kind."""
    rows: dict[str, list[tuple[int, str]]] = {kind: [] for kind in KINDS}
    for topic, log_time, message in read_messages(log):
        if topic in EVENT_TOPICS:  # one line per link event, as when the log kept one record each (at its own t)
            for event in logged_events(topic, message):
                rows["event"].append((seconds_to_ns(event["t"]), KINDS["event"] + json.dumps(event, sort_keys=True)))
            continue
        kind = kind_of(topic)
        if kind is not None:
            rows[kind].append((log_time, topic + json.dumps(message, sort_keys=True)))
    out = {}
    for kind, found in rows.items():
        found.sort()
        text = "\n".join(line for _, line in found)
        out[kind] = f"{len(found)}:{hashlib.sha256(text.encode()).hexdigest()}"
    return out


# The fixture was written with the vehicle preset the paper scenarios used then, before its drag was corrected
# (issue 16): the reference runs keep that vehicle (vehicles.params "remus100_legacy", the same numbers to the bit),
# so that they still prove the engines and the plan unchanged.
LEGACY_PRESET = 'preset = "remus100_legacy"'


def on_legacy_vehicle(text: str) -> str:
    """The scenario text with its [vehicle] preset replaced by the legacy one (exactly one preset line there)."""
    head, section, rest = text.partition("\n[vehicle]\n")
    body, next_section, tail = rest.partition("\n[")
    lines = [LEGACY_PRESET if line.startswith("preset =") else line for line in body.split("\n")]
    if section == "" or LEGACY_PRESET not in lines:
        raise ValueError("on_legacy_vehicle: no [vehicle] preset line to replace")
    return head + section + "\n".join(lines) + next_section + tail


def reference_runs() -> dict[str, tuple[str, list[str]]]:
    """name -> (scenario text, extra cpf run arguments)."""
    paper = on_legacy_vehicle((CONFIGS / "paper.toml").read_text())
    acoustic = on_legacy_vehicle((CONFIGS / "paper_acoustic.toml").read_text())
    runs: dict[str, tuple[str, list[str]]] = {}
    everything = EVERYTHING.read_text()
    for engine in ("inprocess", "zenoh"):
        runs[f"paper-{engine}"] = (paper, ["--engine", engine])
        runs[f"acoustic-{engine}"] = (acoustic, ["--engine", engine])
        runs[f"everything-{engine}"] = (everything, ["--engine", engine])
    for seed in SOAK_SEEDS:
        faults = random_schedule(np.random.default_rng(seed), 30.0)
        extra = [arg for spec in faults for arg in ("--fault", spec)]
        runs[f"soak{seed}-inprocess"] = (shortened(paper, 30.0), ["--engine", "inprocess", "--seed", str(seed), *extra])
    return runs


def run_and_digest(
    name: str, text: str, extra: list[str], workdir: Path, env: dict[str, str] | None = None
) -> dict[str, str]:
    """The digests of a reference run; env: variables on top of the environment (tests.cpu_targets)."""
    scenario = workdir / f"{name}.toml"
    scenario.write_text(text)
    out = workdir / f"{name}.mcap"
    done = cpf("run", str(scenario), "--quiet", "--out", str(out), *extra, cwd=workdir, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"{name}: cpf run failed: {done.stderr.strip()}")
    return digest(out)


def main(workdir: Path) -> int:
    results = {name: run_and_digest(name, text, extra, workdir) for name, (text, extra) in reference_runs().items()}
    FIXTURE.parent.mkdir(parents=True, exist_ok=True)
    FIXTURE.write_text(json.dumps(results, indent=1, sort_keys=True) + "\n")
    print(f"{len(results)} runs -> {FIXTURE}")
    return 0


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        sys.exit(main(Path(tmp)))
