"""The single-process engine: every vehicle stepped in one loop over an ideal channel.

At each step t_k every vehicle hears each graph neighbour's (gamma, gamma_dot) of time t_k, then all vehicles step
to t_k + dt with the very functions a vehicle process runs. It is the reference the multi-process engine must
reproduce, and the speed floor it is measured against.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from comms.messages import FAULT_KEY, META_KEY, state_key, state_message
from supervisor.faults import disturbances, events_at
from supervisor.fleet import initial_state, vehicle_config
from supervisor.metadata import run_meta
from supervisor.progress import Progress
from supervisor.recorder import Recorder
from supervisor.scenario import Scenario
from supervisor.summary import Series
from vehicles.agent import VehicleState, own_estimate, receive, step


@dataclass(frozen=True, slots=True)
class RunResult:
    series: Series
    wall_time: float
    messages: int


def run_inprocess(
    scenario: Scenario, scenario_file: str, scenario_toml: str, out: Path, seed: int, progress: Progress
) -> RunResult:
    """Run the scenario, record every message to out (MCAP), and return the series for the summary."""
    dt = scenario.scenario.step
    steps = round(scenario.scenario.duration / dt)
    ids = scenario.vehicle_ids
    configs = {i: vehicle_config(scenario, i) for i in ids}
    states: dict[int, VehicleState] = {i: initial_state(scenario, configs[i]) for i in ids}
    neighbours = {i: scenario.neighbours(i) for i in ids}
    columns = np.empty((steps, 3, len(ids)))  # gamma, gamma_dot, |p - p_d|
    with Recorder(out) as recorder:
        recorder.write(META_KEY, 0.0, run_meta(scenario, scenario_file, scenario_toml, seed, "inprocess"))
        for k in range(steps):
            t = k * dt
            for event in events_at(scenario.faults, t, dt):
                recorder.write(FAULT_KEY, t, event.message())
            heard = {i: own_estimate(s) for i, s in states.items()}  # the ideal channel: instant, lossless
            for col, i in enumerate(ids):
                state = states[i]
                for j in neighbours[i]:
                    state = receive(state, j, heard[j])
                dist = disturbances(scenario.faults, i, t, dt)
                states[i], tel = step(configs[i], state, dt, neighbours[i], dist)
                recorder.write(state_key(i), t, state_message(tel, configs[i].model))
                columns[k, :, col] = (tel.gamma, tel.gamma_dot, float(np.linalg.norm(tel.error)))
            progress.update(t + dt)
        wall = progress.done(steps * dt)
        messages = recorder.count
    times = np.arange(steps, dtype=np.float64) * dt
    series = Series(tuple(ids), times, columns[:, 0], columns[:, 1], columns[:, 2])
    return RunResult(series, wall, messages)
