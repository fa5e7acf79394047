"""CPU cost of one vehicle's closed-loop step: `.venv/bin/python -m benchmarks.bench_step [--scenario S] [--vehicle I]`.

Times vehicles.agent.step (RK4 of dynamics + path following + coordination) for one vehicle of a scenario, with
estimates of its neighbours held so that coordination does its work, and prints the best of 5 rounds in us per step.
The in-process engine spends about this per vehicle per step; the rest of its time is the channel and the recording.
Then the same step with each on-board addition of issue 24, side by side in the same run, as a ratio to the plain
step: the current observer (an unknown current), the adaptive switching supervisor (a declared +-60 % mismatch),
and a REMUS 100's actuators.
"""

from __future__ import annotations

import argparse
import timeit
from pathlib import Path

import msgspec

from supervisor.config.fleet import initial_state, vehicle_config
from supervisor.config.scenario import load_scenario, parse_scenario
from supervisor.config.scenario_schema import Scenario
from vehicles.agent import step
from vehicles.estimates import NeighbourEstimate

ROOT = Path(__file__).resolve().parent.parent


VARIANTS = {  # what issue 24 added on board, each alone: the scenario changes that turn it on
    "current observer": ["environment.current=[0.2, 0.0, 0.0]"],
    "supervisor": ["vehicle.uncertainty=0.6"],
    "actuators": ['vehicle.actuators="remus100"'],
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenario", type=Path, default=ROOT / "configs" / "paper.toml")
    parser.add_argument("--vehicle", type=int, default=1)
    parser.add_argument("--steps", type=int, default=4000)
    args = parser.parse_args()
    plain = per_step(load_scenario(args.scenario), args.vehicle, args.steps)
    print(f"vehicle {args.vehicle} of {args.scenario.name}: {plain * 1e6:.1f} us per step")
    text = args.scenario.read_text()
    for name, changes in VARIANTS.items():
        cost = per_step(parse_scenario(text, str(args.scenario), changes), args.vehicle, args.steps)
        print(f"  with the {name}: {cost * 1e6:.1f} us per step ({cost / plain:.2f}x)")


def per_step(scenario: Scenario, vehicle: int, steps: int) -> float:
    """Best of 5 rounds, s per step."""
    cfg = vehicle_config(scenario, vehicle)
    dt = scenario.scenario.step
    neighbours = scenario.neighbours(vehicle)
    state = initial_state(scenario, cfg)
    heard = {j: NeighbourEstimate(state.gamma, 0.5 * cfg.coordination.v_r, 0.0) for j in neighbours}
    state = msgspec.structs.replace(state, estimates=heard)
    for _ in range(50):  # away from the start, where some terms are exactly zero
        state = step(cfg, state, dt, neighbours)[0]
    rounds = timeit.repeat(lambda: step(cfg, state, dt, neighbours), number=steps, repeat=5)
    return min(rounds) / steps


if __name__ == "__main__":
    main()
