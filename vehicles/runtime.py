"""What a vehicle does at one sync step, as a pure function shared by both engines.

At sync instant t_k a vehicle (1) takes in the receptions the channel delivered for t_k, (2) transmits its own
(gamma, gamma_dot) of t_k if its policy wants to and its MAC allows, (3) steps its closed loop to t_k + dt and
reports its state of t_k. A message transmitted at t_k therefore affects its receivers from the first sync instant
after t_k that is not earlier than its arrival.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import msgspec

from comms.records.records import Disturbances, Heard, Transmission
from comms.records.state import NeighbourAge
from vehicles.agent import Telemetry, VehicleConfig, VehicleState, own_estimate, receive, step
from vehicles.current import body, body_to_inertial
from vehicles.estimates import NeighbourEstimate
from vehicles.navigation import NavOutput, NavState, initial, navigate
from vehicles.transmission import PeriodicPolicy, Policy, Tdma


@dataclass(frozen=True, slots=True)
class Radio:
    """How a vehicle decides to transmit: its policy, and TDMA if the fleet uses it."""

    policy: Policy = field(default_factory=PeriodicPolicy)
    tdma: Tdma | None = None


class NodeState(msgspec.Struct, frozen=True):
    vehicle: VehicleState
    seq: int = 0  # sequence number of the last transmission
    last_sent: NeighbourEstimate | None = None  # what the neighbours were last told (if it reached them)
    pending: bool = False  # the policy wanted to transmit, the TDMA slot has not come yet
    frozen: NeighbourEstimate | None = None  # a stuck gamma sensor's value, while it is stuck
    nav: NavState | None = None  # the navigation filter's prior for the next step (None: not begun, or no navigation)


class StepOutput(msgspec.Struct, frozen=True):
    telemetry: Telemetry
    transmission: Transmission | None
    estimate_ages: tuple[NeighbourAge, ...]  # (neighbour, t - stamp of the estimate held of it)
    navigation: NavOutput | None = None  # the navigation computer's step (None: the controller sees the truth)
    frozen: NeighbourEstimate | None = None  # a stuck gamma sensor's reading, while it is stuck


def transmission(
    cfg: VehicleConfig, state: VehicleState, seq: int, told: NeighbourEstimate, dist: Disturbances
) -> Transmission:
    """What the modem sends: `told` (the vehicle's belief, possibly corrupted) and its kinematics for the channel."""
    s = cfg.model.lift(state.x)
    position = (s[0], s[1], s[2])
    velocity = body_to_inertial(s[3:12], (s[12], s[13], s[14]))  # R v, in floats: numpy's @ calls BLAS
    if cfg.current is not None:  # the state's v is relative to the water (vehicles.current): over ground add v_c
        c = cfg.current.velocity(state.t, position[2])
        velocity = (velocity[0] + c[0], velocity[1] + c[1], velocity[2] + c[2])
    stamp = state.t + dist.clock_offset if dist.clock_offset else state.t  # the data time a skewed clock claims
    gamma = told.gamma + dist.gamma_offset
    return Transmission(cfg.vehicle_id, seq, state.t, gamma, told.gamma_dot, position, velocity, stamp)


def _sensed(node: NodeState, now: NeighbourEstimate, dist: Disturbances) -> NeighbourEstimate | None:
    """The frozen reading while a gamma sensor is stuck: the value it had when it stuck."""
    if not dist.gamma_freeze:
        return None
    return node.frozen or now


def _wants_and_may(radio: Radio, node: NodeState, vid: int, now: NeighbourEstimate, dt: float) -> tuple[bool, bool]:
    wants = node.pending or radio.policy.due(now.stamp, dt, now, node.last_sent)
    may = radio.tdma is None or radio.tdma.may_transmit(vid, now.stamp, dt)
    return wants, may


def node_step(
    cfg: VehicleConfig,
    radio: Radio,
    node: NodeState,
    t: float,
    dt: float,
    heard: Sequence[Heard],
    neighbours: Sequence[int],
    dist: Disturbances,
) -> tuple[NodeState, StepOutput]:
    """One sync step at time t: receive, maybe transmit, integrate."""
    before = prepare(cfg, radio, node, t, dt, heard, neighbours, dist)
    nav = before.nav
    return complete(before, *step(cfg, before.state, dt, neighbours, dist, None if nav is None else nav.held))


class Prepared(NamedTuple):
    """A sync step up to its integration (node_step): the state that integrates, with the receptions taken in,
    and what the node keeps of the transmission decided."""

    state: VehicleState
    seq: int
    last: NeighbourEstimate | None
    pending: bool
    frozen: NeighbourEstimate | None
    sent: Transmission | None
    ages: tuple[NeighbourAge, ...]
    nav: NavOutput | None


def prepare(
    cfg: VehicleConfig,
    radio: Radio,
    node: NodeState,
    t: float,
    dt: float,
    heard: Sequence[Heard],
    neighbours: Sequence[int],
    dist: Disturbances,
) -> Prepared:
    """Receive and maybe transmit at t, and the navigation computer's step."""
    v = node.vehicle  # at the clock's t, so that every engine steps on the same grid
    state = VehicleState(t, v.x, v.gamma, v.gamma_dot, v.estimates, v.observer, v.memory, v.actuators)
    for h in heard:
        state = receive(state, h.sender, NeighbourEstimate(h.gamma, h.gamma_dot, h.stamp))
    ages = tuple(NeighbourAge(j, t - state.estimates[j].stamp) for j in neighbours if j in state.estimates)
    now = own_estimate(state)
    frozen = _sensed(node, now, dist)
    wants, may = _wants_and_may(radio, node, cfg.vehicle_id, now, dt)
    sent = None
    seq, last = node.seq, node.last_sent
    if wants and may:
        seq, last = seq + 1, now
        sent = transmission(cfg, state, seq, frozen or now, dist)
    return Prepared(state, seq, last, wants and not may, frozen, sent, ages, _navigate(cfg, node, state, t, dt))


def complete(before: Prepared, state: VehicleState, telemetry: Telemetry) -> tuple[NodeState, StepOutput]:
    """The node after its integration (state: the vehicle's after it), and what the step reports."""
    nav = before.nav
    after = NodeState(state, before.seq, before.last, before.pending, before.frozen, None if nav is None else nav.prior)
    return after, StepOutput(telemetry, before.sent, before.ages, nav, before.frozen)


def _navigate(cfg: VehicleConfig, node: NodeState, state: VehicleState, t: float, dt: float) -> NavOutput | None:
    """The navigation computer's step at t on the true state (None without navigation); its first step starts it."""
    params = cfg.navigation
    if params is None:
        return None
    s = cfg.model.lift(state.x)
    current = (0.0, 0.0, 0.0) if cfg.current is None else body(s[3:12], cfg.current.velocity(t, s[2]))
    return navigate(params, node.nav or initial(params, s), s, round(t / dt), dt, current)
