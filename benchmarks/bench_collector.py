"""The garbage collector's pace (supervisor.collector): `.venv/bin/python -m benchmarks.bench_collector
[--repeat 2] [--duration 10]`.

Whole in-process `cpf run` commands as a user waits for them, each with the collector at our pace (a young collection
every collector.YOUNG container objects) and at CPython's (700), alternating, best of --repeat with the spread
(max - min): a generated ring of 1000 AUVs at 1 Hz (bench_targets' ring1000-1hz, --duration s simulated), whose
heap grows by its states and series every step, and the paper scenario (three AUVs, a small heap). The two logs'
messages are compared: the pace frees memory and changes no record. Written to benchmarks/results/collector.json.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path
from typing import Any

from benchmarks import ROOT, best_of, save
from benchmarks.bench_targets import CASES, scenario_text, timed
from supervisor.record.logfile import read_messages

# The command with CPython's own young threshold: the pace is set from collector.YOUNG by cpf's main.
CPYTHON = "import sys, supervisor.collector as c; c.YOUNG = 700; from supervisor.cli import main; " + (
    "sys.exit(main(sys.argv[1:]))"
)
PACES = {"ours": ["-m", "supervisor.cli"], "cpython": ["-c", CPYTHON]}


def scenarios(tmp: Path, duration: float) -> dict[str, Path]:
    ring = next(case for case in CASES if case.name == "ring1000-1hz")
    path = tmp / "ring1000.toml"
    path.write_text(scenario_text(dataclasses.replace(ring, duration=duration)))
    return {"ring1000-1hz": path, "paper": ROOT / "configs" / "paper.toml"}


def measure(name: str, scenario: Path, repeat: int, tmp: Path) -> dict[str, Any]:
    walls: dict[str, list[float]] = {pace: [] for pace in PACES}
    logs = {pace: tmp / f"{name}-{pace}.mcap" for pace in PACES}
    for _ in range(repeat):
        for pace, how in PACES.items():
            argv = [sys.executable, "-P", *how, "run", str(scenario), "--engine", "inprocess", "--quiet"]
            walls[pace].append(timed([*argv, "--out", str(logs[pace])]))
    same = read_messages(logs["ours"]) == read_messages(logs["cpython"])  # the file's metadata says when it was made
    row: dict[str, Any] = {"case": name, "same_log": same}
    for pace, values in walls.items():
        row[pace] = best_of(values)
    row["ratio"] = row["cpython"]["best_s"] / row["ours"]["best_s"]
    return row


def line(row: dict[str, Any]) -> str:
    ours, cpython = row["ours"], row["cpython"]
    return (
        f"{row['case']:<13} our pace {ours['best_s']:6.2f} s (spread {ours['spread_s']:.2f})  CPython's "
        f"{cpython['best_s']:6.2f} s (spread {cpython['spread_s']:.2f})  {row['ratio']:.2f}x  "
        f"logs {'identical' if row['same_log'] else 'DIFFER'}"
    )


def run(repeat: int, duration: float) -> list[dict[str, Any]]:
    with tempfile.TemporaryDirectory(prefix="bench-collector-") as tmp:
        rows = []
        for name, path in scenarios(Path(tmp), duration).items():
            rows.append(measure(name, path, repeat, Path(tmp)))
            print(line(rows[-1]), flush=True)
    save("collector", rows)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--duration", type=float, default=10.0, help="simulated s of the ring of 1000")
    args = parser.parse_args()
    run(args.repeat, args.duration)


if __name__ == "__main__":
    main()
