"""Vehicles stepped as numpy lanes against one at a time: `.venv/bin/python -m benchmarks.bench_lanes [--lanes N]`.

Two measures. The whole step (vehicles.lanes.step_all, what the in-process engine and a sweep's batches run): copies
of the scenario's vehicles at their start, stepped --steps times together as lanes and again each alone, every
state message compared equal, the cost per vehicle step both ways, for each of --counts (how MIN_LANES was chosen).
And the premise, the plant's rates alone (the spatial drift of eqs. (1)-(2), the inputs, the kinematics), called
once with arrays of --lanes states instead of once per state, each lane's bits checked against the scalar call's.
Neither includes the channel, the books or the series, which still run one run at a time.
"""

from __future__ import annotations

import argparse
import pickle
import struct
import time
import timeit
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks import ROOT, save
from supervisor.config.fleet import initial_state, radio, vehicle_config
from supervisor.config.scenario import load_scenario
from vehicles.agent import UNDISTURBED, VehicleConfig
from vehicles.lanes import Job, shape_of, step_all
from vehicles.plant import plant_rates
from vehicles.runtime import NodeState


def rates(cfg: VehicleConfig) -> Callable[[Sequence[Any], Sequence[Any]], tuple[Any, ...]]:
    """The plant's xdot (vehicles.plant.plant_rates: the model's drift, the inputs, the kinematics) of a lifted
    state and inputs, nominal parameters, no current: one state of floats or one of arrays alike."""
    return lambda s, tau: plant_rates(cfg.vehicle, cfg.params, None, 0.0, s, None, (tau[0], tau[1], tau[2]))


def states(cfg: VehicleConfig, start: Sequence[float], lanes: int) -> tuple[np.ndarray, np.ndarray]:
    """lanes lifted states about start and inputs, as (18, lanes) and (3, lanes) arrays (seeded)."""
    rng = np.random.default_rng(26)
    spread = rng.normal(0.0, 0.1, (18, lanes))
    return np.asarray(start)[:, None] + spread, rng.normal(0.0, [[20.0], [2.0], [2.0]], (3, lanes))


def measure(scenario: Path, lanes: int) -> dict[str, Any]:
    sc = load_scenario(scenario)
    cfg = vehicle_config(sc, sc.vehicle_ids[0])
    f = rates(cfg)
    s, tau = states(cfg, cfg.model.lift(initial_state(sc, cfg).x), lanes)
    one = [(list(map(float, s[:, i])), list(map(float, tau[:, i]))) for i in range(lanes)]
    columns = ([s[i] for i in range(18)], [tau[i] for i in range(3)])
    batched = f(*columns)
    for i, (si, ti) in enumerate(one):
        if _bits(float(row[i]) for row in batched) != _bits(f(si, ti)):
            raise AssertionError(f"lane {i}: the array call's result differs from the scalar call's")
    scalar = min(timeit.repeat(lambda: [f(si, ti) for si, ti in one], number=3, repeat=5)) / 3 / lanes
    array = min(timeit.repeat(lambda: f(*columns), number=20, repeat=5)) / 20 / lanes
    return {"scenario": scenario.name, "lanes": lanes, "scalar_us_per_lane": scalar * 1e6,
            "array_us_per_lane": array * 1e6, "speedup": scalar / array}  # fmt: skip


def measure_steps(scenario: Path, count: int, steps: int) -> dict[str, Any]:
    """us per vehicle step of count copies of the scenario's vehicles (in turn), as lanes and alone, best of 3;
    AssertionError if they do not step as lanes (a group whose lanes raise raises: step_all's strict) or a state
    message differs (pickled: each float's bits, NaN's included)."""
    sc = load_scenario(scenario)
    ids = sc.vehicle_ids
    cfgs = [vehicle_config(sc, ids[n % len(ids)], 0) for n in range(count)]
    shapes, radios = [shape_of(cfg) for cfg in cfgs], [radio(sc, cfg.vehicle_id) for cfg in cfgs]
    if not all(shapes):
        raise AssertionError(f"{scenario.name}'s vehicles do not step as lanes: nothing to compare")
    start = [NodeState(initial_state(sc, cfg)) for cfg in cfgs]
    dt = sc.scenario.step

    def run(min_lanes: int) -> tuple[float, list[Any]]:
        nodes, states, began = list(start), [], time.perf_counter()
        for k in range(steps):
            alike = zip(shapes, cfgs, radios, nodes, strict=True)
            jobs = [Job(sh, c, r, nd, k, k * dt, dt, [], [], UNDISTURBED) for sh, c, r, nd in alike]
            outcomes = step_all(jobs, min_lanes, strict=True)
            nodes = [o[0] for o in outcomes]  # type: ignore[index]
            states += [o[1].state for o in outcomes]  # type: ignore[index]
        return time.perf_counter() - began, states

    lanes, alone = [run(2) for _ in range(3)], [run(10**9) for _ in range(3)]
    if pickle.dumps(lanes[0][1]) != pickle.dumps(alone[0][1]):
        raise AssertionError(f"{count} lanes: a state message differs from the vehicle's stepped alone")
    per = 1e6 / (count * steps)
    return {"vehicles": count, "steps": steps, "lanes_us": min(t for t, _ in lanes) * per,
            "alone_us": min(t for t, _ in alone) * per}  # fmt: skip


def steps_summary(rows: list[dict[str, Any]]) -> str:
    parts = [
        f"{r['vehicles']}: {r['lanes_us']:.0f} against {r['alone_us']:.0f} us ({r['lanes_us'] / r['alone_us']:.2f}x)"
        for r in rows
    ]
    return "a vehicle step as lanes against alone, by vehicles stepped (the same state messages): " + "; ".join(parts)


def _bits(values: Iterable[float]) -> bytes:
    """The values' IEEE 754 bits (== would take -0.0 for 0.0 and no NaN for itself)."""
    floats = list(values)
    return struct.pack(f"<{len(floats)}d", *floats)


def summary(row: dict[str, Any]) -> str:
    return (
        f"plant rates of {row['scenario']}'s vehicle on {row['lanes']} lanes: {row['array_us_per_lane']:.3f} us per "
        f"lane as arrays against {row['scalar_us_per_lane']:.2f} us one state at a time ({row['speedup']:.0f}x), "
        "every lane's result the same bits"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenario", type=Path, default=ROOT / "configs" / "paper.toml")
    parser.add_argument("--lanes", type=int, default=1000)
    parser.add_argument("--counts", default="6,16,48,192", help="vehicles stepped, for the whole step")
    parser.add_argument("--steps", type=int, default=20)
    args = parser.parse_args()
    steps = [measure_steps(args.scenario, int(n), args.steps) for n in args.counts.split(",")]
    print(steps_summary(steps))
    row = measure(args.scenario, args.lanes)
    print(summary(row))
    save("lanes", {**row, "steps": steps})


if __name__ == "__main__":
    main()
