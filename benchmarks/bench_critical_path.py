"""Where a Zenoh step's time goes: `.venv/bin/python -m benchmarks.bench_critical_path [--tree DIR] [--repeat N]`.

Runs `cpf run configs/paper.toml` (Zenoh engine, lockstep) from DIR (default: this tree; another checkout with its
own .venv to compare) and samples, every 50 ms from /proc, the CPU time of every process of the run: the supervisor
(with the Zenoh router in it), the broker and each vehicle. Then the lean bus pattern with the same fleet
(benchmarks.bench_bus_floor --lean: the broker's batch -> the vehicles' step messages -> the next batch, nothing
else) for the floor a step could reach. Prints, best of --repeat by wall time, the run's stepping time per step
against the floor, the CPU seconds per process and each process's context switches per step (over all its
threads: a regression in wake-ups or in runnable threads shows on any machine), and writes
benchmarks/results/critical_path.json.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from benchmarks import ROOT, save
from benchmarks.bench_bus_floor import measure_row

TICKS = os.sysconf("SC_CLK_TCK")
STEPPING = re.compile(r"stepping ([0-9.]+) s")


def _descendants(root: int, tree: dict[int, list[int]]) -> list[int]:
    """Every process below root in tree (_children): its children and theirs (the run's processes are forked by
    its fork server)."""
    found, todo = [], [root]
    while todo:
        below = tree.get(todo.pop(), [])
        found += below
        todo += below
    return found


def _children() -> dict[int, list[int]]:
    """ppid -> pids of every process on the machine."""
    tree: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            tree.setdefault(ppid, []).append(int(entry.name))
    return tree


def _name(pid: int, root: int, tree: dict[int, list[int]]) -> str | None:
    if pid == root:
        return "supervisor"
    try:
        cmdline = (Path(f"/proc/{pid}") / "cmdline").read_bytes()
    except OSError:
        return None
    words = cmdline.replace(b"\0", b" ").decode(errors="replace").split()  # a forked child's title: one string
    if "supervisor.cli.fork_server" in words:
        # cpf's own child; a child it has just forked shows its command line too, until it sets its own title
        return "fork server" if pid in tree.get(root, []) else None
    if "comms" in words:
        return "broker"
    if "vehicle" in words and "--id" in words:
        return f"vehicle {words[words.index('--id') + 1]}"
    return None


def switches(pid: int) -> dict[int, tuple[int, int]]:
    """thread id -> (voluntary, involuntary) context switches, for every thread of the process (/proc/PID/status
    counts the main thread only). Voluntary: a thread waited (a wake-up per message or timer); involuntary: the
    scheduler took the core away (more runnable threads than cores)."""
    counts = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            status = (task / "status").read_text()
        except OSError:
            continue
        fields = dict(line.split(":", 1) for line in status.splitlines() if "ctxt_switches" in line)
        counts[int(task.name)] = (int(fields["voluntary_ctxt_switches"]), int(fields["nonvoluntary_ctxt_switches"]))
    return counts


def sample(
    root: int, expected: int, cpu: dict[str, float], stop: threading.Event, ctx: dict[str, dict[int, tuple[int, int]]]
) -> None:
    """CPU s of the run's processes by name (the last sample of each: a process's CPU only grows), and in ctx the
    context switches of each of their threads (the last sample of each thread: counts only grow);
    expected: how many processes the run has (the supervisor, the fork server, the broker, the vehicles)."""
    names: dict[int, str] = {}
    while not stop.wait(0.05):
        if len(names) < expected:  # until every child is there: /proc scans cost
            tree = _children()  # one scan of /proc per round
            for pid in _descendants(root, tree):
                name = _name(pid, root, tree)
                if name is not None:
                    names[pid] = name
            names[root] = "supervisor"
        for pid, name in names.items():
            try:
                stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            cpu[name] = (int(stat[11]) + int(stat[12])) / TICKS
            try:
                ctx.setdefault(name, {}).update(switches(pid))
            except OSError:
                continue  # gone meanwhile


def run_once(tree: Path, scenario: str, vehicles: int) -> dict[str, Any]:
    cpu: dict[str, float] = {}
    ctx: dict[str, dict[int, tuple[int, int]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        argv = [str(tree / ".venv" / "bin" / "cpf"), "run", scenario, "--out", f"{tmp}/run.mcap", "--quiet"]
        start = time.perf_counter()
        proc = subprocess.Popen(argv, cwd=tree, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        stop = threading.Event()
        sampler = threading.Thread(target=sample, args=(proc.pid, vehicles + 3, cpu, stop, ctx), daemon=True)
        sampler.start()
        out, err = proc.communicate()
        wall = time.perf_counter() - start
        stop.set()
        sampler.join()
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({proc.returncode}):\n{err[-2000:]}")
    stepping = STEPPING.search(out)
    stepping_s = float(stepping.group(1)) if stepping else float("nan")
    totals = {name: [sum(c[0] for c in t.values()), sum(c[1] for c in t.values()), len(t)] for name, t in ctx.items()}
    return {"wall_s": wall, "stepping_s": stepping_s, "cpu_s": cpu, "switches": totals}


def measure(tree: Path, repeat: int, scenario: str, steps: int, vehicles: int) -> dict[str, Any]:
    runs = [run_once(tree, scenario, vehicles) for _ in range(repeat)]
    best = min(runs, key=lambda r: r["wall_s"])
    floor = measure_row(vehicles, 2000, lean=True)
    return {"tree": str(tree), "scenario": scenario, "steps": steps, "best": best, "runs": runs,
            "ms_per_step": best["stepping_s"] / steps * 1e3, "floor_ms_per_step": floor["ms_per_step"]}  # fmt: skip


def measure_paper(tree: Path, repeat: int) -> dict[str, Any]:
    """The paper scenario's row (what `make bench` and this module's command run): 4000 steps of 3 vehicles."""
    return measure(tree, repeat, "configs/paper.toml", 4000, 3)


def summary(row: dict[str, Any]) -> str:
    best = row["best"]
    cpu = "  ".join(f"{name} {s:.2f}" for name, s in sorted(best["cpu_s"].items()))
    per_step = "  ".join(
        f"{name} {v / row['steps']:.1f}/{i / row['steps']:.1f} ({threads} threads)"
        for name, (v, i, threads) in sorted(best["switches"].items())
    )
    return (
        f"{row['tree']}: wall {best['wall_s']:.2f} s, stepping {best['stepping_s']:.2f} s = "
        f"{row['ms_per_step']:.2f} ms per step (lean bus floor {row['floor_ms_per_step']:.2f} ms: "
        f"{row['ms_per_step'] / row['floor_ms_per_step']:.2f}x it; issue 26's target <= 1.5x)\n"
        f"  CPU s per process: {cpu}  (total {sum(best['cpu_s'].values()):.2f})\n"
        f"  context switches per step, voluntary/involuntary: {per_step}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tree", type=Path, default=ROOT, help="the checkout to run (with its .venv)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    row = measure_paper(args.tree.resolve(), args.repeat)
    print(summary(row))
    save("critical_path", row)


if __name__ == "__main__":
    main()
