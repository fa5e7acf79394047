"""What stepping many runs at once as arrays would give: `.venv/bin/python -m benchmarks.bench_lanes [--lanes N]`.

Issue 26 asks for a 1000-run sweep in 2 min; benchmarks.bench_sweep_split shows no vehicle step alone can reach it:
the rest of the engine would have to run many runs at once as arrays ("lanes"), which is not built. This measures
the premise, on code that exists: the vehicle model's float functions (the spatial drift of eqs. (1)-(2), the
kinematics, the plant's rates), unchanged, called once with numpy arrays of --lanes states (one array per state
component) instead of once per state. It checks every lane's result equals the scalar call's bit for bit (numpy's
elementwise +, -, *, / and abs round as Python's floats do) and prints the cost per lane both ways. What it does not
show: the functions with branches on the state or fdlibm's argument reduction (a path's sincos, the saturations, the
re-orthonormalization) need array forms first, and the channel, books and series do not run on lanes at all.
"""

from __future__ import annotations

import argparse
import struct
import timeit
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks import ROOT, save
from supervisor.config.fleet import initial_state, vehicle_config
from supervisor.config.scenario import load_scenario
from vehicles.agent import VehicleConfig
from vehicles.plant import plant_rates


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
    args = parser.parse_args()
    row = measure(args.scenario, args.lanes)
    print(summary(row))
    save("lanes", row)


if __name__ == "__main__":
    main()
