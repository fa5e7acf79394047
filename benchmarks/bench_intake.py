"""CPU cost of the Zenoh supervisor's intake: `.venv/bin/python -m benchmarks.bench_intake [--rounds N] [--profile]`.

The bus messages are rebuilt from a paper run (in-process engine, recorded to a temporary log and read back) as the
processes publish them: each vehicle's step message (state, transmission, reception batch, next_tx) on its state
key, the broker's link events of each step in one cpf/comms/events message, its statistics. They are fed, packed as
msgpack, through supervisor.engine.intake.Intake into a Recorder (with its Foxglove scene, closed at the end), as
the supervisor does on every step. Prints the best of --rounds in us per step (the paper run has 4000) and writes
benchmarks/results/intake.json; --profile prints cProfile's top functions of one more round instead.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import json
import pstats
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks import ROOT, save
from comms.bus.bus import Received
from comms.records.events import EVENT_TOPICS, logged_events
from comms.records.messages import (
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    encode,
    state_key,
    step_message,
    vehicle_of_key,
)
from supervisor.config.scenario import load_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.intake import Intake
from supervisor.engine.progress import Progress
from supervisor.record.logfile import read_messages
from supervisor.record.recorder import Recorder

SCENARIO = ROOT / "configs" / "paper.toml"


def bus_messages(path: Path) -> list[Received]:
    """The messages the supervisor of a Zenoh run of the scenario at path takes in, in a plausible order."""
    scenario = load_scenario(path)
    dt = scenario.scenario.step
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.mcap"
        run_inprocess(scenario, str(path), path.read_text(), out, 0, Progress(1.0, io.StringIO(), enabled=False))
        logged = read_messages(out)
    parts: dict[tuple[int, int], dict[str, Any]] = {}  # (k, vehicle) -> leaf -> record
    events: dict[int, list[Any]] = {}  # k -> the link events the broker publishes with its tick
    stats: list[Received] = []
    for topic, ns, message in logged:
        owned = vehicle_of_key(topic)
        if owned is not None:
            parts.setdefault((round(ns / 1e9 / dt), owned[0]), {})[owned[1]] = message
        elif topic in EVENT_TOPICS:
            events.setdefault(min(round(ns / 1e9 / dt), len(parts)), []).extend(logged_events(topic, message))
        elif topic == COMMS_STATS_KEY:
            stats.append(Received(topic, encode(message)))
    out_messages: list[Received] = []
    for (k, vid), leaves in sorted(parts.items()):
        if k in events:
            out_messages.append(Received(COMMS_EVENTS_KEY, encode({"t": k * dt, "k": k, "events": events.pop(k)})))
        step = step_message(leaves["state"], leaves.get("tx"), leaves.get("rx"), k + 1)
        out_messages.append(Received(state_key(vid), encode(step)))
    for k, left in sorted(events.items()):  # the end's (no state of its step): after the last states, as live
        out_messages.append(Received(COMMS_EVENTS_KEY, encode({"t": k * dt, "k": k, "events": left})))
    return out_messages + stats


def feed(path: Path, messages: list[Received], out: Path) -> float:
    """s of CPU to take every message in and close the log."""
    scenario = load_scenario(path)
    start = time.process_time()
    with Recorder(out) as rec:
        intake = Intake(scenario, rec, None)
        for item in messages:
            intake.take(item, 0.0)
    spent = time.process_time() - start
    if sum(intake.malformed.values()):
        raise RuntimeError(f"the intake dropped messages: {intake.malformed}")
    return spent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args()
    messages = bus_messages(SCENARIO)
    steps = load_scenario(SCENARIO).scenario.duration / load_scenario(SCENARIO).scenario.step
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "intake.mcap"
        if args.profile:
            profile = cProfile.Profile()
            profile.runcall(feed, SCENARIO, messages, out)
            pstats.Stats(profile).sort_stats("tottime").print_stats(30)
            return
        times = [feed(SCENARIO, messages, out) for _ in range(args.rounds)]
    result = {"messages": len(messages), "steps": steps, "best_s": min(times), "spread_s": max(times) - min(times),
              "us_per_step": min(times) / steps * 1e6}  # fmt: skip
    print(json.dumps(result, indent=2))
    save("intake", result)


if __name__ == "__main__":
    main()
