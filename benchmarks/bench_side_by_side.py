"""This tree against another checkout, on the same machine at the same time:
`.venv/bin/python -m benchmarks.bench_side_by_side --old DIR [--repeat N] [--engine zenoh|inprocess]`.

DIR is a checkout with its own .venv (e.g. a `git worktree` of an older commit, `make .venv/.installed` in it). The
two run `cpf run configs/paper.toml` alternately, each from its own directory (the Zenoh engine's processes import
the code of the directory they start in), N times each; a shared machine is noisy, so it prints the best and the
spread of the wall time, of the run's own stepping time and of the CPU time of the run and all its processes, and
writes them to benchmarks/results/side_by_side.json. Not part of `make bench`: it needs the other checkout.
"""

from __future__ import annotations

import argparse
import re
import resource
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks import ROOT, save

STEPPING = re.compile(r"stepping ([0-9.]+) s")


def run_once(tree: Path, engine: str, out: Path) -> dict[str, float]:
    """Wall s, the run's stepping s (its summary line) and CPU s (user + system of it and every child it waited)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(
        [str(tree / ".venv" / "bin" / "cpf"), "run", "configs/paper.toml", "--engine", engine, "--out", str(out)],
        cwd=tree, capture_output=True, text=True, check=True,
    )  # fmt: skip
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    stepping = STEPPING.search(done.stdout)
    return {"wall_s": wall, "stepping_s": float(stepping.group(1)) if stepping else float("nan"), "cpu_s": cpu}


def measure(old: Path, engine: str, repeat: int) -> dict[str, Any]:
    runs: dict[str, list[dict[str, float]]] = {"old": [], "new": []}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeat):
            for name, tree in (("old", old), ("new", ROOT)):
                runs[name].append(run_once(tree, engine, Path(tmp) / f"{name}.mcap"))
    return {"old": str(old), "engine": engine, "repeat": repeat, "runs": runs}


def summary(results: dict[str, Any]) -> str:
    lines = [f"{results['engine']} engine, paper scenario, best (min-max) of {results['repeat']} alternating runs"]
    for name in ("old", "new"):
        runs = results["runs"][name]
        cells = []
        for what in ("wall_s", "stepping_s", "cpu_s"):
            values = [r[what] for r in runs]
            cells.append(f"{what[:-2]} {min(values):.2f} s ({min(values):.2f}-{max(values):.2f})")
        lines.append(f"{name:<4} " + "   ".join(cells))
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--old", type=Path, required=True, help="the other checkout (with its .venv)")
    parser.add_argument("--engine", choices=["zenoh", "inprocess"], default="zenoh")
    parser.add_argument("--repeat", type=int, default=4)
    args = parser.parse_args()
    results = measure(args.old.resolve(), args.engine, args.repeat)
    print(summary(results))
    save("side_by_side", results)


if __name__ == "__main__":
    main()
