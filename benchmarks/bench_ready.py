"""How soon a vehicle process is ready: `.venv/bin/python -m benchmarks.bench_ready [--repeat N]`.

A router in this process; a vehicle process started as the supervisor starts one (`python -P -m supervisor.cli
vehicle configs/paper.toml --id 1 --plan FILE --connect ...`, its starts handed over in FILE); the time from its
spawn until its liveliness token reaches the router (it declares it once its session is open and it serves). Best
and spread of N starts, each after the last one's token is gone. Issue 15's target: ready within 0.5 s. Written to
benchmarks/results/ready.json.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import zenoh

from benchmarks import ROOT, save
from comms.bus.bus import free_port, open_session
from comms.bus.handover import write_private
from comms.records.messages import vehicle_alive_key
from supervisor.config.scenario import load_scenario
from supervisor.config.vehicle_start import vehicle_starts

TIMEOUT = 30.0  # s: a start slower than this is a failure, not a number


def measure(repeat: int) -> dict[str, Any]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    session = open_session("router", listen=[endpoint])
    token = vehicle_alive_key(1)
    came, went = threading.Event(), threading.Event()

    def changed(sample: zenoh.Sample) -> None:
        if str(sample.key_expr) == token:
            (came if sample.kind == zenoh.SampleKind.PUT else went).set()

    subscriber = session.liveliness().declare_subscriber(token, changed)
    private = tempfile.TemporaryDirectory(prefix="cpf-bench-ready-")
    plan = Path(private.name) / "vehicle-1.starts"
    write_private(plan, vehicle_starts(load_scenario(ROOT / "configs/paper.toml", (), ()), [1]))
    argv = [sys.executable, "-P", "-m", "supervisor.cli", "vehicle", "configs/paper.toml", "--id", "1"]
    argv += ["--plan", str(plan)]
    times = []
    try:
        for _ in range(repeat):
            came.clear()
            went.clear()
            start = time.perf_counter()
            child = subprocess.Popen([*argv, "--connect", endpoint], cwd=ROOT, stdin=subprocess.DEVNULL,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
            try:
                if not came.wait(TIMEOUT):
                    raise SystemExit(f"the vehicle process was not ready within {TIMEOUT:g} s")
                times.append(time.perf_counter() - start)
            finally:
                child.kill()
                child.wait()
            went.wait(TIMEOUT)  # its token gone: the next start is not seen as this one
    finally:
        subscriber.undeclare()
        session.close()
        private.cleanup()
    return {"ready_s_best": min(times), "ready_s_spread": max(times) - min(times), "ready_s_all": times}


def summary(row: dict[str, Any]) -> str:
    return (
        f"vehicle process ready {row['ready_s_best']:.3f} s after its spawn (best of {len(row['ready_s_all'])}, "
        f"spread {row['ready_s_spread']:.3f} s)   [target: <= 0.5 s]"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=5, help="starts measured (best kept)")
    row = measure(parser.parse_args().repeat)
    print(summary(row))
    save("ready", row)


if __name__ == "__main__":
    main()
