"""Channel lookahead on slow links: `.venv/bin/python -m benchmarks.bench_lookahead [--against DIR] [--repeat 2]`.

Issue 26, part 2: a lockstep window used to stop at the fleet's first transmission; with lookahead
(comms.broker.lookahead) it runs past transmissions for as long as nothing sent can arrive or spoil a reception.
Cases (400 s each):
- acoustic: configs/paper_acoustic.toml as it is (WHOI rate 0, 3.2 s packets, event-triggered on TDMA slots of
  4 s): a slot holds a packet, so no window can run past one: no gain expected;
- acoustic-no-tdma: the same without TDMA (event-triggered, min interval 4 s, heartbeat 12 s, half duplex and
  collisions): the vehicles' transmissions fall at different steps, and windows merge those within a packet's
  airtime of each other unless a packet in flight arrives first;
- every-step: the paper on a 2 s-packet modem (15 B at 60 bit/s), every vehicle transmitting at every step, delay
  only (no half duplex, no collisions): windows of 20 steps instead of 1. Not a real modem (the scenario check warns
  that no modem sends faster than its airtime): the bound's best case;
- delayed-links: the paper's ideal modem (no airtime) with 2 s of extra delay on every link, every vehicle
  transmitting at every step: a study of late messages (the paper's conclusion), windows of 20 steps.
Each case is a whole `cpf run` as a user waits for it: the Zenoh engine of this tree, the in-process engine (the
records are the same; tests/test_windows_e2e.py) and, with --against, the Zenoh engine of another checkout (say the
commit before lookahead) run from there with this venv; alternating, best of --repeat, the spread (max - min) beside.
The bus floor of the same run (bench_bus_floor --lean, 3 vehicles, per step times the run's steps) is printed beside,
as every Zenoh figure's. Written to benchmarks/results/lookahead.json.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path
from typing import Any

from benchmarks import ROOT, bench_bus_floor, best_of, save
from benchmarks.bench_targets import timed

SLOW = ["comms.bitrate=60"]
PAPER_LINKS = ((1, 2), (2, 1), (1, 3), (3, 1))  # the paper's graph 2 - 1 - 3, both ways
DELAYED = "comms.links=[" + ",".join(f"{{sender={i},receiver={j},extra_delay=2.0}}" for i, j in PAPER_LINKS) + "]"
CASES: dict[str, tuple[str, list[str]]] = {  # name -> (scenario file in configs/, --set)
    "acoustic": ("paper_acoustic.toml", []),
    "acoustic-no-tdma": ("paper_acoustic.toml", []),  # its [comms.tdma] table left out (scenario_text)
    "every-step": ("paper.toml", SLOW),
    "delayed-links": ("paper.toml", [DELAYED]),
}
STEPS = 4000  # the paper scenario: 400 s at 0.1 s


def scenario_text(name: str) -> str:
    text = (ROOT / "configs" / CASES[name][0]).read_text()
    if name != "acoustic-no-tdma":
        return text
    head, tdma = text.split("\n[comms.tdma]\n", 1)
    return head + tdma[tdma.index("\n[") :]  # up to the next table


def command(engine: str, scenario: Path, overrides: list[str], out: Path) -> list[str]:
    sets = [arg for o in overrides for arg in ("--set", o)]
    return [sys.executable, "-m", "supervisor.cli", "run", str(scenario), "--engine", engine, *sets, "--out", str(out)]


def measure(name: str, repeat: int, against: Path | None) -> dict[str, Any]:
    trees = {"zenoh": (ROOT, "zenoh"), "inprocess": (ROOT, "inprocess")}
    if against is not None:
        trees["zenoh_against"] = (against, "zenoh")
    times: dict[str, list[float]] = {key: [] for key in trees}
    with tempfile.TemporaryDirectory(prefix="cpf-lookahead-") as tmp:
        scenario = Path(tmp) / CASES[name][0]
        scenario.write_text(scenario_text(name))
        for i in range(repeat):
            for key, (tree, engine) in trees.items():  # alternating: the machine's drift hits each alike
                out = Path(tmp) / f"{key}-{i}.mcap"
                times[key].append(timed(command(engine, scenario, CASES[name][1], out), tree=tree))
    floor = bench_bus_floor.measure(3, 2000, lean=True) * STEPS
    row: dict[str, Any] = {"case": name, "bus_floor_s": floor}
    for key, values in times.items():
        row[key] = best_of(values)
    return row


def summary(row: dict[str, Any]) -> str:
    runs = [key for key in row if isinstance(row[key], dict)]
    parts = [f"{key} {row[key]['best_s']:.2f} s ({row[key]['spread_s']:.2f})" for key in runs]
    ratio = row["zenoh"]["best_s"] / row["inprocess"]["best_s"]
    return (
        f"lookahead {row['case']}: "
        + ", ".join(parts)
        + f"; zenoh/in-process {ratio:.2f}; "
        + (f"lean bus floor of the same run {row['bus_floor_s']:.2f} s for {STEPS} steps")
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--against", type=Path, default=None, help="another checkout, its Zenoh engine run beside")
    parser.add_argument("--cases", default=",".join(CASES))
    args = parser.parse_args()
    rows = []
    for name in args.cases.split(","):
        rows.append(measure(name, args.repeat, args.against))
        print(summary(rows[-1]), flush=True)
    print(f"written: {save('lookahead', rows)}")


if __name__ == "__main__":
    main()
