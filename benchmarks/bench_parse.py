"""CPU cost of reading one bus message through its record: `.venv/bin/python -m benchmarks.bench_parse`.

The messages are those of a run of the scenario (in-process engine, recorded to a temporary log): each vehicle's
state, transmission and reception batch of every step, read as the broker and the Zenoh supervisor read them on
every step. Prints, per kind, the best of 5 rounds in us per message of the reading the engines use (msgspec,
comms.records.fields.read_as, then what its types cannot say: each message is described by its struct alone, so
there are no hand-written checks left to compare), and writes them to benchmarks/results/parse.json. Issue 13 put
these readings on every message of the Zenoh engine (the hand-written checks alone cost ~10 us per state message,
~11 % of a paper run). Then the broker's reading of each vehicle's whole step message (state, transmission and
reception batch in one payload, as the vehicle publishes it: comms.broker.step_reading), in one msgspec pass and,
side by side, the slow way it takes for a message msgspec refuses (the bounded reader, then each record's); and the
same for a vehicle's reading of the broker's batches message of each step (its tick and every vehicle's receptions,
of which it unpacks its own: vehicles.node).
"""

from __future__ import annotations

import argparse
import io
import tempfile
import timeit
from collections.abc import Callable
from pathlib import Path
from typing import Any
from unittest.mock import patch

from benchmarks import ROOT, save
from comms.broker import step_reading
from comms.records.messages import encode, encode_list, step_message, tick_message, vehicle_of_key
from comms.records.receptions import RxBatch
from comms.records.records import Transmission
from comms.records.state import StateReport
from supervisor.config.scenario import load_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from supervisor.record.logfile import read_messages

Reading = Callable[[dict[str, Any], int], object]
# kind -> (topic leaf, reading, hand-written checks: none where a struct is the message's only description)
KINDS: dict[str, tuple[str, Reading, Reading | None]] = {
    "state": ("state", StateReport.from_message, None),
    "transmission": ("tx", Transmission.from_message, None),
    "reception batch": ("rx", lambda m, _: RxBatch.from_message(m), None),
}


def logged(path: Path) -> dict[str, list[tuple[dict[str, Any], int]]]:
    """leaf -> (message, its vehicle) of every state, transmission and reception batch of a run's log."""
    scenario = load_scenario(path)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.mcap"
        run_inprocess(scenario, str(path), path.read_text(), out, 0, Progress(1.0, io.StringIO(), enabled=False))
        found: dict[str, list[tuple[dict[str, Any], int]]] = {}
        for topic, _, message in read_messages(out):
            owned = vehicle_of_key(topic)
            if owned is not None:
                found.setdefault(owned[1], []).append((message, owned[0]))
    return found


def per_message(read: Reading, messages: list[tuple[dict[str, Any], int]]) -> float:
    """Best of 5 rounds over every message, in us per message."""
    rounds = timeit.repeat(lambda: [read(m, v) for m, v in messages], number=1, repeat=5)
    return min(rounds) / len(messages) * 1e6


def measure(path: Path) -> dict[str, Any]:
    found = logged(path)
    results: dict[str, Any] = {"scenario": str(path)}
    for kind, (leaf, read, checked) in KINDS.items():
        messages = found[leaf]
        results[kind] = {"messages": len(messages), "read_us": per_message(read, messages)}
        results[kind]["checked_us"] = None if checked is None else per_message(checked, messages)
    results["broker step message"] = _broker_reading(step_messages(found))
    dt = load_scenario(path).scenario.step
    results["vehicle batches message"] = _vehicle_reading(batches_messages(found, dt), dt)
    return results


def batches_messages(found: dict[str, list[tuple[dict[str, Any], int]]], dt: float) -> list[tuple[bytes, int]]:
    """(payload, vehicle) of the broker's batches message of each step, once per vehicle that reads it: the step's
    tick and every vehicle's receptions of the step, each packed on its own (comms.records.messages.batches_message)."""
    by_step: dict[int, dict[int, list[dict[str, Any]]]] = {}
    for message, vid in found["rx"]:
        by_step.setdefault(message["k"], {})[vid] = message["receptions"]
    payloads = []
    for k, receptions in sorted(by_step.items()):
        tick = tick_message(k, k * dt, False)
        packed = {v: encode_list(r) for v, r in receptions.items()}
        payload = encode({"t": tick["t"], "k": k, "tick": tick, "rx": packed})
        payloads += [(payload, v) for v in receptions]
    return payloads


def _vehicle_reading(payloads: list[tuple[bytes, int]], dt: float) -> dict[str, Any]:
    """us per batches message of vehicles.node._batches, in one pass and the slow way."""
    from vehicles import node

    read = lambda p, v: node._batches(p, v, dt)  # noqa: E731
    one_pass = per_message(read, payloads)  # type: ignore[arg-type]  # payloads, not messages: timed the same
    with patch.object(node, "read_batches", lambda *_: None):
        slow = per_message(read, payloads)  # type: ignore[arg-type]
    return {"messages": len(payloads), "read_us": one_pass, "slow_us": slow}


def step_messages(found: dict[str, list[tuple[dict[str, Any], int]]]) -> list[tuple[bytes, int]]:
    """(payload, vehicle) of each vehicle's step message of each step: its state with the transmission and the
    reception batch of the same step."""
    by_step = {(v, m["k"]): m for v, m in ((v, m) for m, v in found["rx"])}
    sent = {(v, m["stamp"]): m for m, v in found.get("tx", [])}
    return [
        (encode(step_message(m, sent.get((v, m["t"])), by_step.get((v, m["k"])), m["k"] + 1)), v)
        for m, v in found["state"]
    ]


def _broker_reading(payloads: list[tuple[bytes, int]]) -> dict[str, Any]:
    """us per step message of comms.broker.step_reading.read_steps, in one pass and the slow way."""
    read = lambda p, v: step_reading.read_steps(p, v, whole=False)  # noqa: E731
    one_pass = per_message(read, payloads)  # type: ignore[arg-type]  # payloads, not messages: timed the same
    with patch.object(step_reading, "read_window", lambda _: None):
        slow = per_message(read, payloads)  # type: ignore[arg-type]
    return {"messages": len(payloads), "read_us": one_pass, "slow_us": slow}


def summary(results: dict[str, Any]) -> str:
    lines = [f"{'message':<16} {'count':>6} {'read [us]':>10} {'hand-written checks [us]':>25}"]
    for kind in KINDS:
        r = results[kind]
        checked = "-" if r["checked_us"] is None else f"{r['checked_us']:.2f}"
        lines.append(f"{kind:<16} {r['messages']:>6} {r['read_us']:>10.2f} {checked:>25}")
    for name in ("broker step message", "vehicle batches message"):
        b, what = results[name], f"{name.split()[0]}'s {name.split(' ', 1)[1]}"
        lines.append(
            f"{what}: {b['messages']} read in {b['read_us']:.2f} us each in one msgspec pass, "
            f"{b['slow_us']:.2f} us the slow way ({b['slow_us'] / b['read_us']:.1f}x)"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenario", type=Path, default=ROOT / "configs" / "paper.toml")
    args = parser.parse_args()
    results = measure(args.scenario)
    print(summary(results))
    save("parse", results)


if __name__ == "__main__":
    main()
