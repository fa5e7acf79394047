"""What `cpf validate` and `cpf run` say about a valid scenario's channel and coordination before it runs: errors
where nothing can work (no packet can ever arrive), warnings with the reason and the fix where much cannot. The
model of what can arrive is supervisor.config.feasibility; the stability verdict supervisor.config.stability."""

from __future__ import annotations

import math
from collections.abc import Iterator

from supervisor.config.feasibility import (
    OUT_OF_RANGE,
    Timing,
    dead_links,
    directed_links,
    flight,
    formation_positions,
    range_success,
    start_positions,
    timing_of,
)
from supervisor.config.medium import modem_params
from supervisor.config.scenario_schema import Scenario

__all__ = ["feasibility_errors", "feasibility_warnings"]

DWARF = 5.0  # a delay or jitter this many transmit intervals long is a warning


def feasibility_errors(sc: Scenario) -> list[str]:
    """'<field>: <problem>, got <value>' for each way the channel can deliver nothing at all."""
    return list(_always_on_air(sc)) or list(_synchronous_errors(sc))  # the first says all the second would


def feasibility_warnings(sc: Scenario) -> list[str]:
    """'<field>: <problem>, got <value>' for each way the channel loses much, or the loop is predicted to diverge."""
    if feasibility_errors(sc):
        return []
    return [*_synchronous_warnings(sc), *_on_air_warnings(sc), *_slot(sc), *_late(sc), *_range(sc), *_all_lost(sc),
            *_diverges(sc)]  # fmt: skip


def _t(value: float) -> str:
    return f"{value:.3g} s"


def _modem(sc: Scenario, t: Timing) -> str:
    radio = modem_params(sc)
    kinds = [name.replace("_", "-") for name in ("half_duplex", "collisions") if getattr(radio, name)]
    return f"{sc.comms.modem} modems ({', '.join(kinds) or 'full-duplex'}, {_t(t.airtime)} on air per packet)"


def _fix_slot(sc: Scenario, t: Timing) -> str:
    """The TDMA slot that holds a packet and its longest flight at the start, on the step grid."""
    where, dt = start_positions(sc), sc.scenario.step
    longest = max((flight(where[i], where[j], t.sound_speed) for i, j in directed_links(sc)), default=0.0)
    need = t.airtime + longest + t.jitter + max(t.extra.values(), default=0.0)
    return f"comms.tdma = {{ slot = {dt * max(1, math.ceil(need / dt - 1e-9)):g} }}"


def _always_on_air(sc: Scenario) -> Iterator[str]:
    """A modem sending again before its last packet has left: half-duplex, it never hears; with collisions, each
    packet overlaps the sender's next at every receiver."""
    radio, t = modem_params(sc), timing_of(sc)
    if t.airtime <= 0 or t.interval >= t.airtime or sc.comms.transmit.policy != "periodic":
        return
    why = "it is always transmitting, so it hears nothing" if radio.half_duplex else (
        "each packet overlaps the sender's next at every receiver (collision)")  # fmt: skip
    if radio.half_duplex or radio.collisions:
        yield (
            f"comms.transmit.period: a vehicle transmits every {_t(t.interval)} on {_modem(sc, t)}: {why}; "
            f"no packet can arrive: give a period of at least {_t(2 * t.airtime)}, got {_asked(sc)}"
        )


def _on_air_warnings(sc: Scenario) -> Iterator[str]:
    radio, t = modem_params(sc), timing_of(sc)
    if 0 < t.interval < t.airtime and not (radio.half_duplex or radio.collisions):
        yield (
            f"comms.transmit: a vehicle transmits every {_t(t.interval)} but a packet is {_t(t.airtime)} on air: "
            f"no real modem sends faster than its airtime; give a period of at least {_t(t.airtime)}, "
            f"got {_asked(sc)}"
        )


def _asked(sc: Scenario) -> str:
    """The setting that has a vehicle transmit every interval (timing_of), as the value a message got: the period,
    the event policy's heartbeat, or every step when neither is given ("got None" read oddly, a new user)."""
    tx = sc.comms.transmit
    if tx.policy == "periodic" and tx.period is not None:
        return str(tx.period)
    if tx.policy == "event" and tx.heartbeat is not None:
        return f"heartbeat {tx.heartbeat}"
    return f"every step ({sc.scenario.step:g} s)"


def _dead_text(links: list[tuple[int, int, str]]) -> str:
    return ", ".join(f"{i}->{j} ({why})" for i, j, why in links)


def _synchronous_errors(sc: Scenario) -> Iterator[str]:
    """Every link of the graph deaf at the start and all along the paths (the formation over the run)."""
    dead = dead_links(sc, start_positions(sc))
    if not dead or len(dead) < len(directed_links(sc)):
        return
    if any(len(dead_links(sc, where)) < len(dead) for where in formation_positions(sc)):
        return
    t = timing_of(sc)
    yield (
        f"comms.transmit: every vehicle transmits at the same instants (periodic every {_t(t.interval)}, no "
        f"TDMA) on {_modem(sc, t)}, and on every link the packet meets the receiver's own transmission or "
        f"another packet, at the start and all along the paths: no packet can arrive ({_dead_text(dead)}); "
        f'give {_fix_slot(sc, t)} or transmit.policy = "event", got policy {sc.comms.transmit.policy!r}'
    )


def _synchronous_warnings(sc: Scenario) -> Iterator[str]:
    dead = dead_links(sc, start_positions(sc))
    if dead:
        t = timing_of(sc)
        yield (
            f"comms.transmit: every vehicle transmits at the same instants (periodic every {_t(t.interval)}, no "
            f"TDMA) on {_modem(sc, t)}: at the start {len(dead)} of {len(directed_links(sc))} links deliver "
            f'nothing: {_dead_text(dead)}; give {_fix_slot(sc, t)} or transmit.policy = "event", '
            f"got policy {sc.comms.transmit.policy!r}"
        )


def _slot(sc: Scenario) -> Iterator[str]:
    """A TDMA slot that cannot hold a packet and its flight: it spills into the next vehicle's slot."""
    tdma, t = sc.comms.tdma, timing_of(sc)
    where = start_positions(sc)
    longest = max((flight(where[i], where[j], t.sound_speed) for i, j in directed_links(sc)), default=0.0)
    if tdma is not None and t.airtime > 0 and tdma.slot < t.airtime + longest:
        yield (
            f"comms.tdma.slot: shorter than a packet's airtime {_t(t.airtime)} plus the longest flight at the "
            f"start {_t(longest)}: packets spill into the next slot; give {_fix_slot(sc, t)}, got {tdma.slot}"
        )


def _late(sc: Scenario) -> Iterator[str]:
    """Jitter or extra link delays many transmit intervals long: estimates that old, likely a unit mistaken. Not for a
    policy whose longest silence is unknown (a user's trigger, the event policy without a heartbeat): the step it
    would be measured against is not its interval (a user's trigger sending every 4 s was warned of in steps)."""
    from supervisor.config.fleet import transmit_interval

    if transmit_interval(sc) is None:
        return
    t = timing_of(sc)
    delays = [("comms.jitter", t.jitter)] + [
        (f"comms.links[{n}].extra_delay", link.extra_delay) for n, link in enumerate(sc.comms.links)
    ]
    for key, value in delays:
        if value > DWARF * t.interval:
            yield (
                f"{key}: {_t(value)} is {value / t.interval:.3g} transmit intervals ({_t(t.interval)}; a packet "
                f"is {_t(t.airtime)} on air): neighbours' estimates are that old when they arrive; "
                f"is it in seconds? got {value}"
            )


def _range(sc: Scenario) -> Iterator[str]:
    """Links whose receiver is out of the range model's reach at the start."""
    where, c = start_positions(sc), timing_of(sc).sound_speed
    far = []
    for i, j in directed_links(sc):
        distance = flight(where[i], where[j], c) * c
        success = range_success(sc, distance)
        if success is not None and success < OUT_OF_RANGE:
            far.append(f"{i}->{j} ({distance:.0f} m, {100 * success:.2g} %)")
    if far:
        yield (
            f"comms.range: receivers out of range at the start, a packet arrives with the probability given: "
            f"{', '.join(far)}; raise comms.range.source_level or start the vehicles closer, "
            f"got type {sc.comms.range.type if sc.comms.range else None!r}"
        )


def _all_lost(sc: Scenario) -> Iterator[str]:
    """Every packet lost (comms.loss 1, or a burst model always in its bad state): the run's summary says 'NOTHING
    DELIVERED ... (cpf validate says why before a run)', and it now does."""
    from supervisor.config.links import link_loss_of, loss_of

    lost = [link_loss_of(sc, i, j) >= 1.0 for i, j in directed_links(sc)]  # a link's own loss of 0 hears (a user)
    if not (all(lost) if lost else loss_of(sc) >= 1.0):
        return
    if loss_of(sc) >= 1.0:
        yield f"comms.loss: every packet is lost (long-run loss 1): no vehicle hears another, got {sc.comms.loss}"
    else:
        yield "comms.links: every link loses every packet (its own loss 1): no vehicle hears another, got loss 1"


def _diverges(sc: Scenario) -> Iterator[str]:
    from supervisor.config.stability.scenario import predictions

    growth, offset = predictions(sc)
    if growth is not None:
        yield (
            f"coordination: predicted to diverge (error growing at {growth:.3g} 1/s; cpf stability says which "
            f"period, delay and loss it tolerates), got k {sc.coordination.k}"
        )
    elif offset is not None and offset.spread > sc.report.coordination_tolerance:
        yield (
            f"coordination.predictor: predicted to settle with the gammas {offset.spread:.3g} apart (max|gi-gj|, "
            f"above report.coordination_tolerance {sc.report.coordination_tolerance:g}) and the fleet at "
            f"{offset.rate / sc.coordination.v_r:.2f} v_r: 'hold' keeps each neighbour where it was last heard "
            "('first_order' or 'reference' predict it forward), got 'hold'"
        )
