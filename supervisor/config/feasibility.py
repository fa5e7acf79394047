"""Whether a valid scenario's channel can deliver and its coordination converge, said before it runs (`cpf validate`,
`cpf run`): errors where no packet can ever arrive, warnings (the reason and the fix) where many cannot.

Every number is the channel models' own: the airtime is ModemParams.airtime (comms.channel.modem), the time of
flight comms.channel.acoustics.time_of_flight, the range loss the model fleet.range_model builds (its
success_probability or mean_success), the transmit interval fleet.transmit_interval, the stability verdict
supervisor.config.stability. What they are held against is how comms.channel.channel decides a packet's fate: a
half-duplex receiver loses a packet that overlaps its own transmission, a modem with collisions one that overlaps
another packet at the receiver. Vehicles on a periodic policy without TDMA all transmit at t = 0 and every interval
after, at the same instants: a packet then survives only if it reaches its receiver after the receiver's own
transmission has ended and leaves before its next one starts.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from comms.channel.acoustics import time_of_flight
from comms.channel.link_budget import LinkBudgetRange
from comms.channel.loss import RangeTable
from supervisor.config.medium import message_bytes, modem_params, sound_speed
from supervisor.config.scenario_schema import Scenario

Positions = dict[int, np.ndarray]
OUT_OF_RANGE = 0.01  # success probability below which a link is out of range
ALONG_PATHS = 64  # formation instants sampled along the paths for the "nothing can work" verdict
STILL = np.zeros(3)


@dataclass(frozen=True)
class Timing:
    """What the synchronous check needs: airtime A, transmit interval P, jitter J, sound speed, extra link delays."""

    airtime: float
    interval: float
    jitter: float
    sound_speed: float
    extra: dict[tuple[int, int], float]


def directed_links(sc: Scenario) -> list[tuple[int, int]]:
    return sorted({(i, j) for i, j in sc.graph.edges} | {(j, i) for i, j in sc.graph.edges})


def timing_of(sc: Scenario) -> Timing:
    from supervisor.config.fleet import transmit_interval

    interval = transmit_interval(sc) or sc.scenario.step
    extra = {(link.sender, link.receiver): link.extra_delay for link in sc.comms.links}
    airtime = modem_params(sc).airtime(message_bytes(sc))
    return Timing(airtime, interval, sc.comms.jitter, sound_speed(sc), extra)


def start_positions(sc: Scenario) -> Positions:
    return {v.id: np.asarray(v.position, dtype=float) for v in sc.vehicles}


def flight(a: np.ndarray, b: np.ndarray, c: float) -> float:
    return time_of_flight(a, b, STILL, c)


def synchronous(sc: Scenario) -> bool:
    """Whether every vehicle transmits at the same instants: the built-in periodic policy without TDMA."""
    return sc.comms.transmit.policy == "periodic" and sc.comms.tdma is None


def _inside_own(start: float, t: Timing) -> bool:
    """Whether a packet starting to arrive `start` s after the common instant overlaps the receiver's own
    transmissions [k P, k P + A) (half duplex)."""
    into = start % t.interval
    return into < t.airtime or into + t.airtime > t.interval


def _arrival_window(i: int, j: int, where: Positions, t: Timing) -> tuple[float, float]:
    """Earliest and latest start of i's packet at j after the common instant: flight, extra delay, jitter."""
    first = flight(where[i], where[j], t.sound_speed) + t.extra.get((i, j), 0.0)
    return first, first + t.jitter


def deaf_half_duplex(i: int, j: int, where: Positions, t: Timing) -> bool:
    """Whether no draw of the jitter lets i's packet reach j outside j's own transmissions."""
    lo, hi = _arrival_window(i, j, where, t)
    tries = np.linspace(lo, hi, 33) if hi > lo else (lo,)
    return all(_inside_own(float(s), t) for s in tries)


def collides_always(i: int, j: int, sc: Scenario, where: Positions, t: Timing) -> bool:
    """Whether another vehicle's packet overlaps i's at j whatever the jitter (modems with collisions): its arrival
    window lies within one airtime of i's on both sides."""
    lo, hi = _arrival_window(i, j, where, t)
    neighbours = set(directed_links(sc))
    for m in where:
        if m in (i, j):
            continue
        m_lo, m_hi = _arrival_window(m, j, where, t) if (m, j) in neighbours else (flight(where[m], where[j],
                     t.sound_speed),) * 2  # fmt: skip
        if max(hi - m_lo, m_hi - lo) < t.airtime:
            return True
    return False


def dead_links(sc: Scenario, where: Positions) -> list[tuple[int, int, str]]:
    """The directed links of the graph on which no packet can arrive with the vehicles at `where`, and why."""
    if not synchronous(sc):
        return []
    radio, t = modem_params(sc), timing_of(sc)
    if t.airtime <= 0:
        return []
    out = []
    for i, j in directed_links(sc):
        if radio.half_duplex and deaf_half_duplex(i, j, where, t):
            out.append((i, j, "half_duplex"))
        elif radio.collisions and collides_always(i, j, sc, where, t):
            out.append((i, j, "collision"))
    return out


def formation_positions(sc: Scenario) -> Iterator[Positions]:
    """The vehicles on their paths at a common gamma, sampled over the run (the synchronised formation)."""
    from supervisor.config.fleet import build_path, initial_gamma

    paths = {v.id: build_path(v.path) for v in sc.vehicles}
    start = min(initial_gamma(sc, v.id) for v in sc.vehicles)
    end = start + sc.coordination.v_r * sc.scenario.duration
    for gamma in np.linspace(start, end, ALONG_PATHS):
        yield {i: np.asarray(path.evaluate(float(gamma))[0]) for i, path in paths.items()}


def range_success(sc: Scenario, distance: float) -> float | None:
    """The range model's probability that a packet arrives over distance m (None: no range model)."""
    from supervisor.config.fleet import range_model

    model = range_model(sc, modem_params(sc))
    if isinstance(model, LinkBudgetRange):
        return model.mean_success(distance, message_bytes(sc))
    if isinstance(model, RangeTable):
        return model.success_probability(distance)
    return None
