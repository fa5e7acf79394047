"""The vehicle process: the only Zenoh code of a vehicle. It moves messages; the math is vehicles.runtime.

Per sync step k it needs the supervisor's tick (time, faults acting on it) and the broker's reception batch for k;
with both it runs node_step, then publishes its transmission (if any) and its state. It stops on the stop message,
or by itself when the supervisor's liveliness token disappears (no orphan vehicles).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

from comms.bus import Inbox, Publishers, decode_or_none, open_session
from comms.messages import (
    STOP_KEY,
    SUPERVISOR_ALIVE,
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
from vehicles.agent import Disturbances, VehicleConfig, VehicleState
from vehicles.runtime import Heard, NodeState, Radio, node_step

log = logging.getLogger(__name__)
POLL = 0.5  # s between checks while nothing arrives


@dataclass
class _Pending:
    """Ticks and reception batches that arrived ahead of the step that needs them."""

    ticks: dict[int, Tick] = field(default_factory=dict)
    batches: dict[int, list[Heard]] = field(default_factory=dict)
    malformed: int = 0


def run_vehicle(
    cfg: VehicleConfig,
    initial: VehicleState,
    radio: Radio,
    neighbours: Sequence[int],
    dt: float,
    connect: Sequence[str],
) -> int:
    """Serve one vehicle until told to stop; returns the exit code."""
    vid = cfg.vehicle_id
    with open_session("client", connect=connect) as session:
        inbox = Inbox()
        for key in (TICK_KEY, rx_key(vid), STOP_KEY):
            inbox.subscribe(session, key)
        inbox.watch_liveliness(session, SUPERVISOR_ALIVE)
        token = session.liveliness().declare_token(vehicle_alive_key(vid))
        publishers = Publishers(session)
        node, pending, k = NodeState(initial), _Pending(), 0
        while True:
            item = inbox.get(POLL)
            if item is None:
                continue
            if isinstance(item, str):
                if item == f"-{SUPERVISOR_ALIVE}":
                    log.warning("vehicle %d: supervisor gone, stopping", vid)
                    break
                continue
            if item.key == STOP_KEY:
                break
            _take(item.key, item.payload, vid, pending)
            while k in pending.ticks and k in pending.batches:
                tick, heard = pending.ticks.pop(k), pending.batches.pop(k)
                node = _step(cfg, radio, node, tick, heard, neighbours, dt, publishers)
                k += 1
        token.undeclare()
    return 0


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
    dist = Disturbances(gamma_dot_cap=tick.caps.get(vid))
    node, out = node_step(cfg, radio, node, tick.t, dt, heard, neighbours, dist)
    tx = out.transmission
    if tx is not None:
        publishers.put(tx_key(vid), tx_message(tx))
    state = state_message(out.telemetry, cfg.model, tick.k, tx.seq if tx else 0, out.estimate_ages)
    publishers.put(state_key(vid), state)
    return node
