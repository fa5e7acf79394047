"""What a validated scenario would run, in one paragraph (`cpf validate`): the fleet and its paths, time, graph,
channel, transmission and faults, with the numbers the scenario file leaves implicit (modem airtime, TDMA frame)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from typing import Any

from supervisor.config.comms_schema import TransmitSection
from supervisor.config.controller_choice import AUTO, controller_name, estimated_spread
from supervisor.config.derived import steps_of, tube_radius
from supervisor.config.describe import describe_fault
from supervisor.config.fleet import coupling_k
from supervisor.config.links import tdma_schedule
from supervisor.config.medium import message_bytes, modem_params, sound_speed
from supervisor.config.plant import actuation
from supervisor.config.plant import spreads as plant_spreads
from supervisor.config.scenario_schema import Scenario, VehicleSection
from vehicles.transmission import Tdma
from vehicles.uncertainty import GROUPS

__all__ = ["what_would_run"]


def what_would_run(sc: Scenario) -> str:
    """One paragraph: what `cpf run` would simulate with this scenario."""
    run = sc.scenario
    steps = steps_of(sc)
    model = "the 6-DOF model" if run.dimension == 3 else "the planar model"
    sentences = [
        f"{run.name}: {len(sc.vehicles)} vehicles ({_fleet(sc)}{_overrides(sc)}, {model}) for "
        f"{_num(run.duration)} s in {steps} steps of {_num(run.step)} s, seed {run.seed}",
        "paths: " + "; ".join(_vehicle(v) for v in sc.vehicles),
        "plant: " + _plant(sc),
        "path following: " + _controller(sc),
        f"coordination: {sc.coordination.law} law, {_gain(sc)}, predictor {sc.coordination.predictor}, "
        f"v_r {_num(sc.coordination.v_r)} per s, over the graph {_edges(sc.graph.edges)}",
        "comms: " + _comms(sc),
        "transmission: " + _transmit(sc.comms.transmit, tdma_schedule(sc)),
        "faults: " + ("; ".join(describe_fault(f.model_dump(), run.step) for f in sc.faults) or "none"),
        f"a vehicle lost: {run.on_vehicle_loss}",
    ]
    return ". ".join([sentences[0], *(s[0].upper() + s[1:] for s in sentences[1:])]) + "."


def _controller(sc: Scenario) -> str:
    """The controller as it will run and its actuators if not ideal; in a mixed fleet whose vehicles steer or actuate
    differently, each group's, ideal inputs named too ("vehicles 1, 3: ... on ...; vehicle 2: ... on ideal inputs")."""
    groups: dict[tuple[str, str | None], list[int]] = {}
    for vid in sc.vehicle_ids:
        groups.setdefault(_steering(sc, vid), []).append(vid)
    if len(groups) == 1:
        (text, actuators), *_ = groups
        return text if actuators is None else f"{text}; {actuators}"
    named = [(f"{_who(vids)}: {text} on {actuators or 'ideal inputs'}") for (text, actuators), vids in groups.items()]
    return "; ".join(named)


def _steering(sc: Scenario, vehicle_id: int) -> tuple[str, str | None]:
    """(vehicle_id's controller: auto's choice and why, and the delta of the designs that have one (the tube radius
    of those that do not); its actuators, None: ideal)."""
    pf, name = sc.path_following, controller_name(sc, vehicle_id)
    shifted = name in ("backstepping", "supervisory")  # the delta-shifted designs: |delta| makes their tube
    text = f"{name}, delta {_num(pf.delta)} m" if shifted else f"{name}, tube {_num(tube_radius(sc))} m"
    if pf.controller == AUTO:
        text += f" (auto: {_why(sc, name)})"
    actuators = actuation(sc, vehicle_id)
    if actuators == "ideal":
        return text, None
    return text, f"{actuators if isinstance(actuators, str) else 'the scenario'}'s fins and propeller"


def _who(vids: list[int]) -> str:
    return f"vehicle {vids[0]}" if len(vids) == 1 else "vehicles " + ", ".join(str(v) for v in vids)


def _why(sc: Scenario, name: str) -> str:
    """Why auto chose name (supervisor.config.controller_choice)."""
    if name == "line_of_sight":
        return "fins whose moment falls with the speed"
    spread = estimated_spread(sc)
    return f"inertia or damping uncertain by up to +-{_num(100 * spread)} %" if spread else "the nominal plant"


def _gain(sc: Scenario) -> str:
    """k as law (5) will run with it: fitted to the links if the schedule lowers it (stability.schedule)."""
    given, used = sc.coordination.k, coupling_k(sc)
    return f"k {_num(given)}" if used == given else f"k {_num(used)} (fitted to the links; {_num(given)} given)"


def _fleet(sc: Scenario) -> str:
    """The vehicle model, or each preset with how many vehicles fly it (a mixed fleet says so)."""
    if sc.vehicle.model:
        return sc.vehicle.model
    presets = Counter(v.preset or sc.vehicle.preset for v in sc.vehicles)
    if len(presets) == 1:
        return next(iter(presets))
    return ", ".join(f"{count} {name}" for name, count in sorted(presets.items()))


def _plant(sc: Scenario) -> str:
    """What the vehicles meet that the nominal model has not: current, mismatch, navigation, saturation."""
    env, parts = sc.environment, []
    if not env.still:
        told = "known to the controllers" if env.current_known else "not known to the controllers"
        kinds = [k for k, on in (("tide", env.tide is not None), ("shear", any(env.shear))) if on]
        parts.append(f"current {_value(env.current)} m/s" + (f" with {' and '.join(kinds)}" if kinds else "") +
                     f", {told}")  # fmt: skip
    spreads = plant_spreads(sc)
    if spreads:
        by_size: dict[float, list[str]] = {}
        for group, spread in spreads.items():
            by_size.setdefault(spread, []).append(group)
        every = len(spreads) == len(GROUPS) and len(by_size) == 1
        sizes = "; ".join(
            f"+-{_num(100 * s)} % in {'every group' if every else ', '.join(g)}" for s, g in by_size.items()
        )
        parts.append(f"model mismatch ({sizes})")
    nav = sc.navigation
    if nav is not None:
        fixes = f"fixes every {_num(nav.fix_period)} s" if nav.fix_period else "no fixes"
        parts.append(f"dead reckoning (DVL noise {_num(nav.dvl_noise)} m/s, {fixes})")
    sat = sc.saturation
    if sat.top_speed is not None:
        parts.append(f"speed along the path held to {_value(sat.top_speed)}")
    parts.append(f"coordination correction bounded ({_value(sat.correction)})" if sat.correction != "none"
                 else "coordination correction unbounded")  # fmt: skip
    if env.still and not spreads and nav is None:
        parts.insert(0, "the nominal model in still water, exact navigation")
    return ", ".join(parts)


def _vehicle(v: VehicleSection) -> str:
    spec = v.path.model_dump()
    shape = ", ".join(f"{key} {_value(value)}" for key, value in spec.items() if key != "type")
    gamma0 = v.gamma0 if isinstance(v.gamma0, str) else _num(v.gamma0)
    return f"{v.id} from {_value(v.position)} on a {spec['type']} ({shape}), gamma0 {gamma0}"


def _comms(sc: Scenario) -> str:
    c = sc.comms
    radio = modem_params(sc)
    size = message_bytes(sc)
    parts = [f"{c.modem} modem"]
    if radio.bitrate is not None:
        parts.append(f"{_num(radio.bitrate)} bit/s, {_num(radio.airtime(size))} s on air per {size}-B packet")
    parts += [name.replace("_", "-") for name in ("half_duplex", "collisions") if getattr(radio, name)]
    parts.append(f"sound speed {sound_speed(sc):.0f} m/s")
    if c.loss:
        parts.append(f"loss {_num(c.loss)}")
    if c.burst is not None:
        b = c.burst
        length = f"{_num(b.mean_burst)} packets" if b.mean_burst is not None else f"{_num(b.mean_duration)} s"
        parts.append(f"bursts (mean loss {_num(b.mean_loss)}, mean burst {length})")
    if c.range is not None:
        parts.append(f"range-dependent loss ({c.range.type})")
    if c.loss_model is not None:
        options = ", ".join(f"{key} {_value(value)}" for key, value in sorted(c.loss_model_options.items()))
        parts.append(f"loss model {c.loss_model}" + (f" ({options})" if options else ""))
    if c.reception == "sinr":
        parts.append(f"SINR capture at {_num(c.capture_threshold)} dB")
    if c.jitter:
        parts.append(f"jitter up to {_num(c.jitter)} s")
    if c.links:
        parts.append(f"own settings on {len(c.links)} directed link{'s' if len(c.links) > 1 else ''}")
    if len(parts) == 2 and c.modem == "ideal":
        parts.append("no loss")
    return ", ".join(parts)


def _transmit(tx: TransmitSection, tdma: Tdma | None) -> str:
    if tx.policy == "periodic":
        text = "periodic, " + (f"every {_num(tx.period)} s" if tx.period is not None else "every step")
    elif tx.policy != "event":  # an extension's: it reads its options, none of the keys below (a new user)
        options = ", ".join(f"{key} {_value(value)}" for key, value in sorted(tx.options.items()))
        text = f"{tx.policy}" + (f" ({options})" if options else "")
    else:
        text = f"event-triggered (threshold {_num(tx.threshold)}"
        text += f", at least {_num(tx.min_interval)} s apart" if tx.min_interval else ""
        text += f", heartbeat {_num(tx.heartbeat)} s" if tx.heartbeat is not None else ""
        text += ")"
    if tdma is not None:
        text += f", on TDMA slots of {_num(tdma.slot)} s (frame {_num(tdma.frame)} s)"
    return text


def _overrides(sc: Scenario) -> str:
    names = sorted(sc.vehicle.overrides)
    return f" with {', '.join(names)} overridden" if names else ""


def _edges(edges: Iterable[tuple[int, int]]) -> str:
    return ", ".join(f"{i}-{j}" for i, j in edges)


def _value(value: Any) -> str:
    if isinstance(value, tuple | list):
        return "(" + ", ".join(_value(item) for item in value) + ")"
    return _num(value) if isinstance(value, float) else str(value)


def _num(value: float | None) -> str:
    return "-" if value is None else f"{value:g}"
