"""The floor the bus sets: `.venv/bin/python -m benchmarks.bench_bus_floor [--sizes 3,50] [--steps 2000]`.

The Zenoh engine's message pattern with no work in it, to tell the cost of the process-per-vehicle architecture
from the cost of our code. A router (in this process, which also takes in and decodes what the supervisor records:
the vehicles' step messages and the broker's events), a broker process and N vehicle processes on comms.bus.bus, as the
real ones: per step the supervisor publishes a tick, the broker waits for the tick and every vehicle's step message
of the step before and publishes one batches message (each vehicle's part packed on its own) and one events
message, each vehicle waits for the batches and publishes a step message of about the real size. No dynamics, no
channel, no recording. Prints wall time per step; if the bus alone needs more than 1.5x the in-process engine's
whole step, the issue-7 ratio cannot be met with this architecture. --per-process M puts M vehicles in each
process (each still with its own messages), to see what grouping them would buy. --lean adds issue 15's leaner
pattern beside it: the broker's batch -> the N vehicles' step messages -> the next batch, no tick and no events
message (one tick starts the run); the engine's own step is measured against it (benchmarks.bench_critical_path).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any

import msgpack

from benchmarks import save
from comms.bus.bus import Handler, Inbox, Publishers, Received, free_port, open_session, serve
from comms.records.messages import ALIVE_PREFIX, STOP_END, STOP_KEY, SUPERVISOR_ALIVE, decode
from comms.records.run import Stop

ROOT_KEY = "floor"
TICK, STEP, EVENTS = f"{ROOT_KEY}/tick", f"{ROOT_KEY}/comms/step", f"{ROOT_KEY}/comms/events"
STATE_FLOATS = 40  # about what a vehicle's state message carries (position, rotation, velocities, errors, ...)


def state_key(vid: int) -> str:
    return f"{ROOT_KEY}/vehicle/{vid}/state"


def vehicles_handler(vids: range) -> Callable[[Publishers], Handler]:
    """One process's vehicles (one each, as the engine; several only to see what grouping would buy)."""

    def make(publishers: Publishers) -> Handler:
        def handle(key: str, payload: bytes) -> None:
            message = decode(payload)
            for vid in vids:
                mine = msgpack.unpackb(message["rx"][vid]) if vid in message["rx"] else []
                state = {"k": message["k"], "vehicle": vid, "heard": len(mine)}
                state.update({f"x{i}": 0.1 * i + message["k"] for i in range(STATE_FLOATS)})
                publishers.put(state_key(vid), state)

        return handle

    return make


def broker_handler(n: int, lean: bool = False) -> Callable[[Publishers], Handler]:
    """lean: no ticks (the next batch goes out once the N states of the step before are in) and no events
    message: the leanest pattern the engine's step could have."""

    def make(publishers: Publishers) -> Handler:
        ticks: set[int] = set()
        states: dict[int, int] = {}
        next_k = 0

        def handle(key: str, payload: bytes) -> None:
            nonlocal next_k
            message = decode(payload)
            if key == TICK:
                ticks.add(message["k"])
            else:
                states[message["k"]] = states.get(message["k"], 0) + 1
                if lean:
                    ticks.add(message["k"] + 1)
            while next_k in ticks and (next_k == 0 or states.get(next_k - 1) == n):
                reception = {"sender": 1, "seq": next_k, "stamp": 0.1, "arrival": 0.2, "gamma": 1.0, "gamma_dot": 1.0}
                rx = {v: msgpack.packb([reception, reception]) for v in range(1, n + 1)}
                publishers.put(STEP, {"t": next_k * 0.1, "k": next_k, "tick": {"k": next_k}, "rx": rx})
                if not lean:
                    event = {"t": next_k * 0.1, "sender": 1, "receiver": 2, "seq": next_k, "kind": "delivered"}
                    publishers.put(EVENTS, {"t": next_k * 0.1, "k": next_k, "events": [event] * (4 * n)})
                ticks.discard(next_k)
                states.pop(next_k - 1, None)
                next_k += 1

        return handle

    return make


def child(argv: list[str]) -> int:
    role, connect, n = argv[0], [argv[1]], int(argv[2])
    if role in ("broker", "lean-broker"):
        keys = (TICK, f"{ROOT_KEY}/vehicle/*/state")
        return serve("floor broker", connect, keys, f"{ALIVE_PREFIX}/comms", broker_handler(n, role == "lean-broker"))
    first, last = (int(v) for v in role.split("-"))
    token = f"{ALIVE_PREFIX}/vehicle/{first}-{last}"
    return serve(f"floor vehicles {role}", connect, (STEP,), token, vehicles_handler(range(first, last + 1)))


def measure(n: int, steps: int, per_process: int = 1, lean: bool = False) -> float:
    """Wall time per step (s) of the bare pattern with n vehicles, per_process of them in each process. lean: the
    leaner pattern (broker batch -> N vehicle reports -> next batch: no tick, no events message)."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with open_session("router", listen=[endpoint]) as session:
        inbox = Inbox()
        for key in (f"{ROOT_KEY}/vehicle/*/state", EVENTS):  # as the supervisor: not the batches
            inbox.subscribe(session, key)
        inbox.watch_liveliness(session, f"{ALIVE_PREFIX}/**")
        token = session.liveliness().declare_token(SUPERVISOR_ALIVE)
        pubs = Publishers(session)
        me = [sys.executable, "-m", "benchmarks.bench_bus_floor", "--child"]
        procs = [subprocess.Popen([*me, role, endpoint, str(n)], stderr=subprocess.DEVNULL, start_new_session=True)
                 for role in ["lean-broker" if lean else "broker", *_groups(n, per_process)]]  # fmt: skip
        try:
            _wait_alive(inbox, len(procs))
            return _steps(inbox, pubs, n, steps, lean)
        finally:
            pubs.put(STOP_KEY, Stop(0.0, STOP_END).to_message())
            token.undeclare()
            _stop(procs)


def _wait_alive(inbox: Inbox, count: int) -> None:
    """Readiness: every child's liveliness token (count of them)."""
    present: set[str] = set()
    while len(present) < count:
        item = inbox.get(60.0)
        if item is None:
            raise TimeoutError("children did not come up")
        if isinstance(item, str) and item.startswith("+") and item != f"+{SUPERVISOR_ALIVE}":
            present.add(item)


def _steps(inbox: Inbox, pubs: Publishers, n: int, steps: int, lean: bool = False) -> float:
    """Wall time per step (s) of steps lockstep ticks, each complete when its n states are in (lean: one tick
    starts the run, the broker goes on by itself)."""
    started = time.perf_counter()
    pubs.put(TICK, {"k": 0})
    done: dict[int, int] = {}
    for k in range(steps):
        if not lean:
            pubs.put(TICK, {"k": k + 1})  # one step ahead, as the lockstep clock
        while done.get(k, 0) < n:
            item = inbox.get(60.0)
            if item is None:
                raise TimeoutError(f"step {k} did not complete")
            if isinstance(item, Received):
                message = decode(item.payload)  # the supervisor decodes everything it records
                if item.key != EVENTS:
                    done[message["k"]] = done.get(message["k"], 0) + 1
    return (time.perf_counter() - started) / steps


def _stop(procs: list[subprocess.Popen[bytes]]) -> None:
    for proc in procs:
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        sys.exit(child(sys.argv[2:]))
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default="3,50", help="fleet sizes, comma-separated")
    parser.add_argument("--steps", type=int, default=2000, help="sync steps per size")
    parser.add_argument("--per-process", type=int, default=1, help="vehicles per process (the engine: 1)")
    parser.add_argument("--lean", action="store_true", help="also the lean pattern: batch -> N states -> batch")
    args = parser.parse_args()
    patterns = (False, True) if args.lean else (False,)
    rows = [measure_row(int(n), args.steps, args.per_process, lean) for n in args.sizes.split(",") for lean in patterns]
    for row in rows:
        print(summary(row), flush=True)
    save("bus_floor", rows)


def _groups(n: int, per_process: int) -> list[str]:
    """Child roles "first-last": the vehicles of each process."""
    return [f"{a}-{min(a + per_process - 1, n)}" for a in range(1, n + 1, per_process)]


def measure_row(n: int, steps: int, per_process: int = 1, lean: bool = False) -> dict[str, Any]:
    steps = steps if n <= 10 else max(200, steps // 10)  # a large fleet: fewer steps, the same precision
    per_step = measure(n, steps, per_process, lean)
    return {"vehicles": n, "vehicles_per_process": per_process, "steps": steps, "ms_per_step": per_step * 1e3,
            "realtime_factor_at_0.1s": 0.1 / per_step, "pattern": "lean" if lean else "engine"}  # fmt: skip


def summary(row: dict[str, Any]) -> str:
    grouped = f", {row['vehicles_per_process']} vehicles per process" if row["vehicles_per_process"] > 1 else ""
    pattern = "lean bus pattern" if row.get("pattern") == "lean" else "bare bus pattern"
    return (
        f"N={row['vehicles']:3d}  {pattern}{grouped}: {row['ms_per_step']:6.2f} ms per sync step "
        f"({row['realtime_factor_at_0.1s']:6.1f}x real time at a 0.1 s step)"
    )


if __name__ == "__main__":
    main()
