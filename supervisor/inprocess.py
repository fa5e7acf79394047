"""The single-process engine: every vehicle and the channel stepped in one loop.

It runs exactly the pipeline of the multi-process engine (vehicles.runtime.node_step for each vehicle,
comms.broker_core for the channel, messages built and parsed the same way), in one process and one thread. It is
the reference the Zenoh engine must reproduce, and the speed floor it is measured against.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from comms.channel import Kinematics, LinkEvent
from comms.messages import (
    COMMS_EVENT_KEY,
    COMMS_STATS_KEY,
    FAULT_KEY,
    GRAPH_KEY,
    META_KEY,
    Message,
    event_message,
    parse_rx,
    parse_state,
    rx_key,
    rx_message,
    state_key,
    state_message,
    tx_key,
    tx_message,
)
from supervisor.faults import disturbances, events_at
from supervisor.fleet import broker_core, initial_state, radio, vehicle_config
from supervisor.metadata import graph_message, run_meta
from supervisor.progress import Progress
from supervisor.recorder import Recorder
from supervisor.scenario_schema import Scenario
from supervisor.series import SeriesBuilder
from supervisor.summary import Series
from vehicles.runtime import NodeState, node_step
from vehicles.transmission import Transmission


@dataclass(frozen=True, slots=True)
class RunResult:
    series: Series
    wall_time: float
    messages: int
    link_counts: dict[str, int]
    link_stats: Message | None  # the last cpf/comms/stats snapshot
    stats_history: list[Message]
    estimate_ages: dict[tuple[int, int], list[float]]  # (sender, receiver) -> [sum, count, max] of ages


def run_inprocess(
    scenario: Scenario, scenario_file: str, scenario_toml: str, out: Path, seed: int, progress: Progress
) -> RunResult:
    """Run the scenario, record every message to out (MCAP), and return the series for the summary."""
    dt = scenario.scenario.step
    steps = round(scenario.scenario.duration / dt)
    ids = scenario.vehicle_ids
    configs = {i: vehicle_config(scenario, i) for i in ids}
    nodes = {i: NodeState(initial_state(scenario, configs[i])) for i in ids}
    neighbours = {i: scenario.neighbours(i) for i in ids}
    radios = {i: radio(scenario, i) for i in ids}
    broker = broker_core(scenario, seed)
    snapshots: list[Message] = []
    builder = SeriesBuilder(ids, steps, dt)
    with Recorder(out) as rec:
        rec.write(META_KEY, 0.0, run_meta(scenario, scenario_file, scenario_toml, seed, "inprocess", "lockstep"))
        rec.write(GRAPH_KEY, 0.0, graph_message(0.0, scenario.graph.edges))
        sent: list[Transmission] = []
        where: dict[int, Kinematics] = {}
        for k in range(steps):
            t = k * dt
            for event in events_at(scenario.faults, t, dt):
                rec.write(FAULT_KEY, t, event.message())
            _record_events(rec, broker.submit(sent, where))
            batches, delivered = broker.deliver(t, ids)
            _record_events(rec, delivered)
            _record_stats(rec, broker.snapshot_due(t), snapshots)
            sent, where = [], {}
            for i in ids:
                rx = rx_message(i, k, t, batches[i])
                rec.write(rx_key(i), t, rx)
                dist = disturbances(scenario.faults, i, t, dt)
                nodes[i], result = node_step(
                    configs[i], radios[i], nodes[i], t, dt, parse_rx(rx)[1], neighbours[i], dist
                )
                tx = result.transmission
                if tx is not None:
                    rec.write(tx_key(i), t, tx_message(tx))
                    sent.append(tx)
                state = state_message(result.telemetry, configs[i].model, k, tx.seq if tx else 0, result.estimate_ages)
                rec.write(state_key(i), t, state)
                builder.add(state)
                where[i] = parse_state(state, i).kinematics
            progress.update(t + dt)
        end = steps * dt
        _record_events(rec, broker.submit(sent, where) + broker.deliver(end, ids)[1] + broker.finish(end))
        _record_stats(rec, broker.snapshot_due(end, final=True), snapshots)
        wall = progress.done(end)
        messages = rec.count
    return RunResult(builder.series(), wall, messages, broker.counts, snapshots[-1], snapshots, builder.ages)


def _record_stats(rec: Recorder, snapshot: Message | None, history: list[Message]) -> None:
    if snapshot is not None:
        rec.write(COMMS_STATS_KEY, float(snapshot["t"]), snapshot)
        history.append(snapshot)


def _record_events(rec: Recorder, events: list[LinkEvent]) -> None:
    for event in events:
        rec.write(COMMS_EVENT_KEY, event.t, event_message(event))
