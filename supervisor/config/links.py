"""What a scenario's links give its coordination loop, and the gain law (5) runs with on them: the transmit period or
TDMA frame with each sender's offset, the delay, the long-run loss, and whether law (5)'s k must be fitted to them
(supervisor.config.stability). Light: no scipy, so that a run whose links are continuous never imports it.

The delay is airtime (packet bits / bitrate, preamble included) + time of flight over the mean initial distance of
linked vehicles + half the jitter + the mean extra link delay over the graph's directed links, rounded up to the sync
step as arrivals are; the loss is comms.loss combined with the burst model's long-run rate.
"""

from __future__ import annotations

import math

import numpy as np

from supervisor.config.medium import message_bytes, modem_params, sound_speed
from supervisor.config.scenario_schema import Scenario
from vehicles.transmission import Tdma

PREDICTORS = ("first_order", "hold", "reference")  # the ones the analysis models (stability.model)


def transmit_period(scenario: Scenario, event: str = "heartbeat") -> float:
    """The transmit period; an event-triggered policy's at its heartbeat (event = "heartbeat": the longest silence
    it allows, for a verdict that errs on the safe side) or at the fastest it may send (event = "fastest": it sends
    whenever its neighbours' prediction of it errs, so their estimates are as good as that)."""
    tx, dt = scenario.comms.transmit, scenario.scenario.step
    if tx.policy == "event":
        return (tx.heartbeat or dt) if event == "heartbeat" else max(tx.min_interval, dt)
    return tx.period or dt


def timing(scenario: Scenario, event: str = "heartbeat") -> tuple[float, tuple[float, ...]]:
    """(period or TDMA frame, each vehicle's offset as a fraction of it)."""
    period, tdma, n = transmit_period(scenario, event), tdma_schedule(scenario), len(scenario.vehicles)
    if tdma is None:
        return period, (0.0,) * n
    held = held_to_frames(scenario, period)
    return held, tuple(tdma.order.index(vid) * tdma.slot / held for vid in scenario.vehicle_ids)


def tdma_schedule(scenario: Scenario) -> Tdma | None:
    """The fleet's TDMA schedule as its radios keep it (comms.tdma.order, the vehicles' order if left out), None
    without TDMA: its frame is the one every check, the analysis and the radios take."""
    tdma = scenario.comms.tdma
    return None if tdma is None else Tdma(tdma.slot, tdma.order or tuple(scenario.vehicle_ids))


def held_to_frames(scenario: Scenario, interval: float) -> float:
    """interval [s] between a vehicle's wishes to transmit as its TDMA slots hold it (interval itself without TDMA):
    one slot per vehicle and frame (validated), and a wish due interval after a slot (half a step of slack, as
    vehicles.transmission.PeriodicPolicy.due) waits for the first slot start not before it, a whole frame at least."""
    tdma, dt = tdma_schedule(scenario), scenario.scenario.step
    if tdma is None:
        return interval
    frame = tdma.frame
    return frame * max(1, math.ceil((interval - dt / 2) / frame))


def delay_of(scenario: Scenario) -> float:
    """Airtime + typical time of flight + half the jitter + mean extra link delay, up to the sync step."""
    c, dt = scenario.comms, scenario.scenario.step
    where = {v.id: np.asarray(v.position) for v in scenario.vehicles}
    distances = [float(np.linalg.norm(where[a] - where[b])) for a, b in scenario.graph.edges]
    flight = float(np.mean(distances)) / sound_speed(scenario) if distances else 0.0
    modem = modem_params(scenario)
    on_air = modem.airtime(message_bytes(scenario))
    # over every directed link of the graph: one not listed in [[comms.links]] has none (the mean over those listed
    # changed when a user wrote out a default entry, and the k fitted to it with it)
    directed = 2 * len(scenario.graph.edges)
    extra = sum(link.extra_delay for link in c.links) / directed if directed else 0.0
    raw = on_air + flight + c.jitter / 2 + extra
    return dt * max(1, math.ceil(raw / dt - 1e-9))


def loss_of(scenario: Scenario) -> float:
    """The fleet's long-run loss: comms.loss and [comms.burst]'s, independent."""
    c = scenario.comms
    return _combined(c.loss, c.burst.mean_loss if c.burst is not None else 0.0)


def link_loss_of(scenario: Scenario, sender: int, receiver: int) -> float:
    """One directed link's long-run loss: its own loss and burst where its [[comms.links]] entry gives them (a 0
    too), the fleet's where it leaves them out (as the channel takes them: supervisor.config.fleet)."""
    c = scenario.comms
    own = next((link for link in c.links if (link.sender, link.receiver) == (sender, receiver)), None)
    loss, burst = (c.loss, c.burst) if own is None else own.losses(c.loss, c.burst)
    return _combined(loss, burst.mean_loss if burst is not None else 0.0)


def _combined(loss: float, burst: float) -> float:
    return 1.0 - (1.0 - loss) * (1.0 - burst)


SCHEDULED_LAWS = ("corrected", "literal")  # law (5), the one the analysis models (stability.model)


def unmodelled(scenario: Scenario) -> str | None:
    """Why the stability analysis does not model the scenario's coordination loop (None: it does). It models law
    (5) with a built-in predictor; another law (saturated, a user's) or a user's predictor it cannot linearise."""
    co = scenario.coordination
    if co.law not in SCHEDULED_LAWS:
        return f"coordination.law: the stability analysis models law (5) {SCHEDULED_LAWS}, got {co.law!r}"
    if co.predictor not in PREDICTORS:
        return f"coordination.predictor: the stability analysis models {PREDICTORS}, got {co.predictor!r}"
    return None


def schedules(scenario: Scenario) -> bool:
    """Whether the scenario's k is fitted to its links (law (5), a built-in predictor, schedule = "rate")."""
    return scenario.coordination.schedule == "rate" and unmodelled(scenario) is None


def needs_fitting(scenario: Scenario) -> bool:
    """Whether law (5)'s k must be fitted to the links by the analysis (supervisor.config.stability.scenario
    .coupling_gain): it is scheduled and the links are not continuous."""
    return schedules(scenario) and not continuous(scenario)


def continuous(scenario: Scenario) -> bool:
    """Whether every neighbour is heard every step, one step late at most, without loss and without TDMA: the
    continuous loop, whose decay rate rises with k (its slow root k k2 lambda / (c + k lambda), c = k_zeta + k2, or
    (c + k lambda) / 2 once complex, rises with k), so the schedule would keep k: no analysis needed."""
    dt, c = scenario.scenario.step, scenario.comms
    return (c.tdma is None and transmit_period(scenario, "fastest") <= dt and delay_of(scenario) <= dt
            and loss_of(scenario) == 0.0 and c.range is None and not c.links)  # fmt: skip
