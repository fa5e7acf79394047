"""What a vehicle does at one sync step, as a pure function shared by both engines.

At sync instant t_k a vehicle (1) takes in the receptions the channel delivered for t_k, (2) transmits its own
(gamma, gamma_dot) of t_k if its policy says so, (3) steps its closed loop to t_k + dt and reports its state of t_k.
A message transmitted at t_k therefore affects its receivers from the first sync instant after t_k that is not
earlier than its arrival.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

from vehicles.agent import Disturbances, Telemetry, VehicleConfig, VehicleState, receive, step
from vehicles.estimates import NeighbourEstimate
from vehicles.transmission import PeriodicPolicy, Transmission


@dataclass(frozen=True, slots=True)
class Heard:
    """A reception as the vehicle sees it: who, the data and the time of the data."""

    sender: int
    stamp: float
    gamma: float
    gamma_dot: float


@dataclass(frozen=True, slots=True)
class NodeState:
    vehicle: VehicleState
    seq: int = 0  # sequence number of the last transmission
    last_tx: float | None = None


def transmission(cfg: VehicleConfig, state: VehicleState, seq: int) -> Transmission:
    s = cfg.model.spatial(state.x)
    position = tuple(float(v) for v in s.position)
    velocity = tuple(float(v) for v in s.rotation @ s.velocity)
    return Transmission(cfg.vehicle_id, seq, state.t, state.gamma, state.gamma_dot, position, velocity)  # type: ignore[arg-type]


def node_step(
    cfg: VehicleConfig,
    policy: PeriodicPolicy,
    node: NodeState,
    t: float,
    dt: float,
    heard: Sequence[Heard],
    neighbours: Sequence[int],
    dist: Disturbances,
) -> tuple[NodeState, Telemetry, Transmission | None]:
    """One sync step at time t: receive, maybe transmit, integrate. Returns the new node, telemetry and transmission."""
    state = replace(node.vehicle, t=t)  # the clock's t, so that every engine steps on the same grid
    for h in heard:
        state = receive(state, h.sender, NeighbourEstimate(h.gamma, h.gamma_dot, h.stamp))
    sent = None
    seq, last = node.seq, node.last_tx
    if policy.due(t, last, dt):
        seq, last = seq + 1, t
        sent = transmission(cfg, state, seq)
    state, telemetry = step(cfg, state, dt, neighbours, dist)
    return NodeState(state, seq, last), telemetry, sent
