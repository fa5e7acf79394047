"""The vehicle process: the only Zenoh code of a vehicle. It moves messages; the math is vehicles.runtime.

Per sync step k it needs the supervisor's tick (time, faults acting on it) and, in lockstep, its reception batch for
k: both come in the one batches message the broker publishes for the whole fleet at each step (the supervisor
publishes it while the broker is down). It runs node_step, then publishes one step message: its state, the
transmission it made (if any) and the receptions it took in. In realtime the broker delivers each reception at its
arrival time on the wall clock; the vehicle takes in at tick k whatever has arrived and reports how late each
delivery was. comms.bus.serve runs its life: it stops on the stop message, or by itself when the supervisor's
liveliness token disappears (no orphans).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

from comms.bus import Handler, Publishers, serve
from comms.messages import (
    COMMS_STEP_KEY,
    Message,
    Tick,
    decode,
    parse_batches,
    parse_rx,
    rx_key,
    state_key,
    state_message,
    step_message,
    tx_message,
    vehicle_alive_key,
)
from vehicles.agent import Disturbances, VehicleConfig
from vehicles.runtime import Heard, NodeState, Radio, node_step

log = logging.getLogger(__name__)


@dataclass
class _Pending:
    """Ticks and receptions that arrived ahead of the step that needs them."""

    ticks: dict[int, Tick] = field(default_factory=dict)
    batches: dict[int, tuple[list[Heard], Message | None]] = field(default_factory=dict)  # by step
    live: list[tuple[Heard, Message, float]] = field(default_factory=list)  # realtime: (heard, item, s late)
    malformed: int = 0

    def ready(self, k: int) -> bool:
        return k in self.ticks

    def receptions(self, tick: Tick, vid: int) -> tuple[list[Heard], Message | None, list[float]]:
        """What the vehicle takes in at this tick, the batch to report (None: the broker is down), lateness (s)."""
        heard, batch = self.batches.pop(tick.k)
        if tick.wall is None:
            return heard, batch, []
        live, self.live = self.live, []  # realtime: whatever reached the vehicle by now
        batch = {"t": tick.t, "k": tick.k, "vehicle": vid, "receptions": [item for _, item, _ in live]}
        return [h for h, _, _ in live], batch if tick.comms else None, [late for _, _, late in live]


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
            while pending.ready(k):
                tick = pending.ticks.pop(k)
                node = _step(cfg, radio, node, tick, pending.receptions(tick, vid), neighbours, dt, publishers)
                k += 1

        return handle

    return serve(f"vehicle {vid}", connect, (COMMS_STEP_KEY, rx_key(vid)), vehicle_alive_key(vid), handler)


def _take(key: str, payload: bytes, vid: int, pending: _Pending) -> None:
    """File an incoming message by step; a malformed one is counted and dropped."""
    try:
        message = decode(payload)
        if key == COMMS_STEP_KEY:
            tick, batch = parse_batches(message, vid)
            if not tick.final:
                pending.ticks[tick.k] = tick
                pending.batches[tick.k] = ([] if batch is None else parse_rx(batch)[1], batch)
        elif key == rx_key(vid):
            _file_rx(message, pending)
    except ValueError as exc:
        pending.malformed += 1
        log.warning("vehicle %d: dropped a malformed message on %s: %s", vid, key, exc)


def _file_rx(message: Message, pending: _Pending) -> None:
    """Realtime deliveries, as they come, with how late each reached the vehicle."""
    now = time.time()
    _, heard = parse_rx(message)
    for h, item in zip(heard, message["receptions"], strict=True):
        due = item.get("due")
        if not isinstance(due, int | float) or isinstance(due, bool):
            raise ValueError("a realtime delivery without a numeric 'due'")
        pending.live.append((h, item, now - due))


def _step(
    cfg: VehicleConfig,
    radio: Radio,
    node: NodeState,
    tick: Tick,
    receptions: tuple[list[Heard], Message | None, list[float]],
    neighbours: Sequence[int],
    dt: float,
    publishers: Publishers,
) -> NodeState:
    vid = cfg.vehicle_id
    heard, batch, lateness = receptions
    dist = tick.disturbed.get(vid, Disturbances())
    current = tick.network.neighbours(vid) if tick.network is not None else neighbours
    node, out = node_step(cfg, radio, node, tick.t, dt, heard, current, dist)
    tx = out.transmission
    state = state_message(out.telemetry, cfg.model, tick.k, tx.seq if tx else 0, out.estimate_ages)
    if tick.wall is not None:
        state["rx_lateness"] = lateness
    publishers.put(state_key(vid), step_message(state, tx_message(tx) if tx else None, batch))
    return node
