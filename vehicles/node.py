"""The vehicle process: the only Zenoh code of a vehicle. It moves messages; the math is vehicles.runtime.

Per sync step k it needs the supervisor's tick (time, faults acting on it) and the broker's reception batch for k;
with both it runs node_step, then publishes its transmission (if any) and its state. comms.bus.serve runs its life:
it stops on the stop message, or by itself when the supervisor's liveliness token disappears (no orphans).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

from comms.bus import Handler, Publishers, decode_or_none, serve
from comms.messages import (
    TICK_KEY,
    Tick,
    parse_rx,
    parse_tick,
    rx_key,
    state_key,
    state_message,
    tx_key,
    tx_message,
    vehicle_alive_key,
)
from vehicles.agent import Disturbances, VehicleConfig
from vehicles.runtime import Heard, NodeState, Radio, node_step

log = logging.getLogger(__name__)


@dataclass
class _Pending:
    """Ticks and reception batches that arrived ahead of the step that needs them."""

    ticks: dict[int, Tick] = field(default_factory=dict)
    batches: dict[int, list[Heard]] = field(default_factory=dict)
    malformed: int = 0


def run_vehicle(
    cfg: VehicleConfig,
    initial: NodeState,
    radio: Radio,
    neighbours: Sequence[int],
    dt: float,
    connect: Sequence[str],
    start_step: int = 0,
) -> int:
    """Serve one vehicle from step start_step (a restarted process resumes mid-run) until told to stop or the
    supervisor disappears; returns the exit code. neighbours: the scenario's, until a tick says otherwise."""
    vid = cfg.vehicle_id

    def handler(publishers: Publishers) -> Handler:
        node, pending, k = initial, _Pending(), start_step

        def handle(key: str, payload: bytes) -> None:
            nonlocal node, k
            _take(key, payload, vid, pending)
            while k in pending.ticks and k in pending.batches:
                tick, heard = pending.ticks.pop(k), pending.batches.pop(k)
                node = _step(cfg, radio, node, tick, heard, neighbours, dt, publishers)
                k += 1

        return handle

    return serve(f"vehicle {vid}", connect, (TICK_KEY, rx_key(vid)), vehicle_alive_key(vid), handler)


def _take(key: str, payload: bytes, vid: int, pending: _Pending) -> None:
    """File an incoming message by step; a malformed one is counted and dropped."""
    message = decode_or_none(payload)
    try:
        if message is None:
            raise ValueError("undecodable")
        if key == TICK_KEY:
            tick = parse_tick(message)
            if not tick.final:
                pending.ticks[tick.k] = tick
            if not tick.comms:
                pending.batches[tick.k] = []  # the broker is down: no receptions will come
        elif key == rx_key(vid):
            k, heard = parse_rx(message)
            pending.batches[k] = heard
    except ValueError as exc:
        pending.malformed += 1
        log.warning("vehicle %d: dropped a malformed message on %s: %s", vid, key, exc)


def _step(
    cfg: VehicleConfig,
    radio: Radio,
    node: NodeState,
    tick: Tick,
    heard: list[Heard],
    neighbours: Sequence[int],
    dt: float,
    publishers: Publishers,
) -> NodeState:
    vid = cfg.vehicle_id
    dist = tick.disturbed.get(vid, Disturbances())
    current = tick.network.neighbours(vid) if tick.network is not None else neighbours
    node, out = node_step(cfg, radio, node, tick.t, dt, heard, current, dist)
    tx = out.transmission
    if tx is not None:
        publishers.put(tx_key(vid), tx_message(tx))
    state = state_message(out.telemetry, cfg.model, tick.k, tx.seq if tx else 0, out.estimate_ages)
    publishers.put(state_key(vid), state)
    return node
