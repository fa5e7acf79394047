"""Cross-field rules of a scenario, the ones pydantic cannot express field by field.

Every rule yields all the errors it finds, each '<field>: <problem>, got <value>' (config/scenario.py adds the
file). A rule runs only if the sections it reads validated: `cross_field_errors` is also called on a scenario whose
other sections pydantic rejected, so that a file shows every error at once without one section's error making up
another's.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable, Iterator, Mapping

import numpy as np

from supervisor.config.authority_checks import authority_warnings
from supervisor.config.derived import STEP_TOLERANCE, active, end_of, first_step, graph_at, steps_of, whole_steps
from supervisor.config.extension_checks import controller_errors, extension_errors, vehicle_model_errors
from supervisor.config.feasibility_checks import feasibility_errors, feasibility_warnings
from supervisor.config.kill_checks import kill_errors
from supervisor.config.parameter_ranges import PARAMETER_RANGES
from supervisor.config.plant import planar_current_errors
from supervisor.config.robustness import resilience_warnings
from supervisor.config.scenario_schema import (
    LINK_FAULTS,
    ClockSkewFault,
    FaultSpec,
    GraphSwitchFault,
    HelixPath,
    LinePath,
    PathSpec,
    Scenario,
    VehicleSection,
)
from supervisor.config.schema_base import MAX_SPEED, MAX_STEPS, MAX_TIME, Vec3
from supervisor.config.transmit_checks import transmit_errors, transmit_warnings
from supervisor.config.turn_checks import turn_warnings
from supervisor.config.unit_checks import unit_warnings
from vehicles.params import PRESETS, VehicleParams
from vehicles.paths import Path as PathLike

Check = Callable[[Scenario], Iterator[str]]
ONE_NUMBER = ("mass",)  # 3-vector parameters also read as one number (vehicle_models.as_read)


def format_location(loc: Iterable[int | str]) -> str:
    """'a.b[0]["odd key"]': a key TOML had to quote in brackets, a key longer than 40 characters shortened."""
    text = ""
    for part in loc:
        if isinstance(part, str) and len(part) > 40:
            part = part[:37] + "..."
        if isinstance(part, int) or not part.isidentifier():
            text += f"[{part!r}]"  # a list index, or a key TOML had to quote
        else:
            text += f".{part}" if text else part
    return text or "(top level)"


# --- the rules ----------------------------------------------------------------------------------------------


def _ids(sc: Scenario) -> Iterator[str]:
    ids = sc.vehicle_ids
    for index, vid in enumerate(ids):
        if ids.index(vid) != index:
            yield f"vehicles[{index}].id: duplicate vehicle id, got {vid}"


def _step(sc: Scenario) -> Iterator[str]:
    """The run is a whole number of steps: the run's end, the summaries and the log agree on its duration."""
    step, duration = sc.scenario.step, sc.scenario.duration
    if step > duration:
        yield f"scenario.step: must not exceed duration ({duration}), got {step}"
        return
    ratio = duration / step
    if not whole_steps(duration, step):
        yield f"scenario.step: must divide duration ({duration}) into whole steps ({ratio:.6g} of them), got {step}"
    elif round(ratio) > MAX_STEPS:
        yield f"scenario.duration: at most {MAX_STEPS} steps of {step:g} s, got {duration} ({ratio:.6g} steps)"


def _graph(sc: Scenario) -> Iterator[str]:
    ids, edges = sc.vehicle_ids, sc.graph.edges
    ends_ok = True
    for index, (i, j) in enumerate(edges):
        for end in (i, j):
            if end not in ids:
                ends_ok = False
                yield f"graph.edges[{index}]: vehicle {end} is not in [[vehicles]] ids {ids}, got {[i, j]}"
        if i == j:
            yield f"graph.edges[{index}]: an edge must join two vehicles, got {[i, j]}"
    if not ends_ok:
        return  # connectivity of a graph with unknown vehicles says nothing more
    reached = {ids[0]}
    for _ in ids:  # each pass reaches at least one more vehicle, or nothing more can be reached
        reached |= {j for i, j in edges if i in reached} | {i for i, j in edges if j in reached}
    unreached = [vid for vid in ids if vid not in reached]
    if unreached:
        yield (
            f"graph.edges: the graph must be connected, vehicles {unreached} cannot reach vehicle {ids[0]}, "
            f"got {[list(e) for e in edges]}"
        )


def _faults(sc: Scenario) -> Iterator[str]:
    for index, fault in enumerate(sc.faults):
        found = list(_fault_fields(index, fault, sc.vehicle_ids))
        yield from found
        if not found:
            timing = list(_fault_timing(index, fault, sc))
            yield from timing
            # one that acts on no step is in no graph: that error is the timing's, not a second one
            starts = first_step(fault.start, sc.scenario.step) < steps_of(sc)
            if not timing and starts and isinstance(fault, LINK_FAULTS):
                yield from _link_in_graph(index, fault, sc)


def _fault_fields(index: int, fault: FaultSpec, ids: list[int]) -> Iterator[str]:
    for field_name in ("vehicle", "sender", "receiver"):
        vid = getattr(fault, field_name, None)
        if vid is not None and vid not in ids:
            yield f"faults[{index}].{field_name}: no such vehicle in {ids}, got {vid}"
    if fault.end is not None and fault.end <= fault.start:
        yield f"faults[{index}].end: must be after start ({fault.start}), got {fault.end}"
    if isinstance(fault, LINK_FAULTS) and fault.sender == fault.receiver:
        yield f"faults[{index}].receiver: a link joins two vehicles, got {fault.receiver}"
    if isinstance(fault, GraphSwitchFault):
        for edge in fault.edges:
            if edge[0] not in ids or edge[1] not in ids or edge[0] == edge[1]:
                yield f"faults[{index}].edges: not an edge between two vehicles {ids}, got {list(edge)}"


def _fault_timing(index: int, fault: FaultSpec, sc: Scenario) -> Iterator[str]:
    """A fault that ends within the step it starts in would act on no step, whatever the run's length: an error.
    (One that starts at or after the end of the run is only a warning: a shortened run of a longer scenario.)"""
    dt = sc.scenario.step
    k = first_step(fault.start, dt)
    if k < steps_of(sc) and not active(fault, k * dt, dt):
        yield f"faults[{index}].end: ends within the step it starts in ({dt:g} s), got {fault.end}"


def _link_in_graph(index: int, fault: FaultSpec, sc: Scenario) -> Iterator[str]:
    """A link fault acts on a link of the communication graph in force at some step while it acts (the scenario's
    graph, or one a graph_switch puts in force then): on any other link it would do nothing."""
    sender, receiver = getattr(fault, "sender"), getattr(fault, "receiver")  # noqa: B009 - LINK_FAULTS have both
    dt, steps = sc.scenario.step, steps_of(sc)
    changes = [fault.start] + [t for f in sc.faults if isinstance(f, GraphSwitchFault) for t in (f.start, f.end)]
    graphs = set()
    for t in changes:
        k = first_step(t, dt) if t is not None else steps
        if k < steps and active(fault, k * dt, dt):
            graphs.add(graph_at(sc, k * dt, dt))
    links = {frozenset(edge) for edges in graphs for edge in edges}
    if frozenset((sender, receiver)) not in links:
        yield f"faults[{index}]: not a link of the graph while the fault acts, got {sender} -> {receiver}"


def _clock_skew(sc: Scenario) -> Iterator[str]:
    """A skewed clock stamps t + offset (the offsets of a vehicle's skews in force add up); the modem frame carries
    0 .. MAX_TIME s (u32 ms). A stamp outside could not be sent, so such an offset is refused here, for both engines
    alike, rather than dropped by one engine and fatal to the other. Checked at the first and last step of each
    stretch over which the vehicle's offset is constant."""
    dt, steps = sc.scenario.step, steps_of(sc)
    for vid in sc.vehicle_ids:
        mine = [(i, f) for i, f in enumerate(sc.faults) if isinstance(f, ClockSkewFault) and f.vehicle == vid]
        times = [t for _, f in mine for t in (f.start, end_of(f, dt)) if math.isfinite(t)]
        edges = sorted({0, steps} | {min(steps, first_step(t, dt)) for t in times})
        for begin, after in itertools.pairwise(edges):
            acting = [(i, f) for i, f in mine if active(f, begin * dt, dt)]
            offset = sum(f.offset for _, f in acting)
            t = begin * dt if offset < 0 else (after - 1) * dt
            if acting and not 0.0 <= t + offset <= MAX_TIME:
                index, fault = acting[0]
                yield (
                    f"faults[{index}].offset: vehicle {vid}'s clock would read {t + offset:g} s at t = {t:g} s, "
                    f"outside the 0 .. {MAX_TIME} s the modem frame's time stamp holds, got {fault.offset}"
                )
                break


def _path_speed(sc: Scenario) -> Iterator[str]:
    """v_r asks each vehicle to move at |v_r| |dp_d/dgamma| m/s along its path: more than MAX_SPEED no vehicle can
    do (its messages would be refused as corrupt), and far more overflows the path's arithmetic."""
    from supervisor.config.fleet import build_path

    v_r = sc.coordination.v_r
    for index, vehicle in enumerate(sc.vehicles):
        gamma = 0.0 if vehicle.gamma0 == "closest" else vehicle.gamma0
        try:
            slope = float(np.linalg.norm(build_path(vehicle.path).evaluate(gamma)[1]))
        except (ValueError, OverflowError):
            continue  # _paths reports it
        if abs(v_r) * slope > MAX_SPEED:
            yield (
                f"coordination.v_r: asks vehicle {vehicle.id} for {abs(v_r) * slope:.6g} m/s along its path "
                f"(vehicles[{index}].path: {slope:.6g} m per unit of gamma), more than {MAX_SPEED:g} m/s, got {v_r}"
            )


def _overrides(sc: Scenario) -> Iterator[str]:
    """Each override ([vehicle] and each [[vehicles]] entry's) names a VehicleParams field and has the shape of its
    preset's value: a number, or an array of 3 numbers (mass either: the rigid body's, or M's diagonal)."""
    yield from _override_errors(sc.vehicle.preset, sc.vehicle.overrides, ["vehicle", "overrides"])
    for index, vehicle in enumerate(sc.vehicles):
        preset = vehicle.preset or sc.vehicle.preset
        yield from _override_errors(preset, vehicle.overrides, ["vehicles", index, "overrides"])


def _override_errors(preset: str, overrides: Mapping[str, float | Vec3], at: list[int | str]) -> Iterator[str]:
    defaults = PRESETS[preset]
    known = list(VehicleParams.__dataclass_fields__)
    for name, value in overrides.items():
        where = format_location([*at, name])
        if name not in known:
            yield f"{where}: unknown vehicle parameter, expected one of {known}"
            continue
        vector = isinstance(getattr(defaults, name), tuple)
        shown = list(value) if isinstance(value, tuple) else value
        if vector != isinstance(value, tuple) and name not in ONE_NUMBER:
            shape = "an array of 3 numbers" if vector else "a number"
            yield f"{where}: must be {shape}, got {shown}"
            continue
        low, high = PARAMETER_RANGES[name]
        if not all(low <= v <= high for v in (value if isinstance(value, tuple) else (value,))):
            yield f"{where}: must be within [{low:g}, {high:g}], got {shown}"


def _finite_at_zero(path: PathLike) -> bool:
    try:
        return all(np.isfinite(vector).all() for vector in path.evaluate(0.0))
    except (ValueError, OverflowError):  # math.cos(inf) and the like
        return False


def _paths(sc: Scenario) -> Iterator[str]:
    """Build each path as the run will: its own checks (e.g. period != 0) become field errors here."""
    from supervisor.config.fleet import build_path  # supervisor.config.fleet imports supervisor.config.scenario

    for index, vehicle in enumerate(sc.vehicles):
        try:
            path = build_path(vehicle.path)
        except ValueError as exc:  # vehicles.paths messages start with the parameter: "period must be ..."
            name, _, problem = str(exc).partition(" ")
            yield f"vehicles[{index}].path.{name}: {problem}"
            continue
        if not _finite_at_zero(path):  # e.g. period = 5e-324: 2 pi / period overflows
            values = ", ".join(f"{key} = {value}" for key, value in vehicle.path if key != "type")
            yield f"vehicles[{index}].path: not finite at gamma = 0, got {values}"


def _comms(sc: Scenario) -> Iterator[str]:
    """Links, TDMA order and packet size against the fleet and the modem; the models' own checks."""
    from supervisor.config.fleet import channel_params
    from supervisor.config.medium import message_bytes, modem_params

    ids = sc.vehicle_ids
    edges = {tuple(e) for e in sc.graph.edges} | {(j, i) for i, j in sc.graph.edges}
    seen: dict[tuple[int, int], int] = {}
    for index, link in enumerate(sc.comms.links):
        if (link.sender, link.receiver) not in edges:
            yield f"comms.links[{index}]: not a link of the graph, got {link.sender} -> {link.receiver}"
        elif (first := seen.setdefault((link.sender, link.receiver), index)) != index:  # one would be ignored
            yield f"comms.links[{index}]: the same link as comms.links[{first}], got {link.sender} -> {link.receiver}"
    yield from transmit_errors(sc)
    tdma = sc.comms.tdma
    step = sc.scenario.step
    if tdma is not None and (tdma.slot < step * (1 - STEP_TOLERANCE) or not whole_steps(tdma.slot, step)):
        yield f"comms.tdma.slot: must be a whole number of steps ({step} s), got {tdma.slot}"
    if tdma is not None and tdma.order is not None and sorted(tdma.order) != sorted(ids):
        yield f"comms.tdma.order: must list every vehicle once {sorted(ids)}, got {list(tdma.order)}"
    radio = modem_params(sc)
    size = message_bytes(sc)
    if radio.max_bytes is not None and size > radio.max_bytes:
        yield f"comms.packet_bytes: the {sc.comms.modem} modem takes {radio.max_bytes} B, got {size}"
    yield from _reception(sc, radio.collisions)
    try:
        channel_params(sc, with_named=False)  # comms.loss_model: extension_errors says what is wrong with it
    except ValueError as exc:
        yield f"comms: {exc}"


def _reception(sc: Scenario, collisions: bool) -> Iterator[str]:
    """SINR capture weighs received levels: it needs the link budget's, and collisions for overlaps to matter."""
    c = sc.comms
    if c.reception == "sinr" and (c.range is None or c.range.type != "link_budget"):
        yield f"comms.reception: sinr needs range type = link_budget (received levels), got {c.reception!r}"
    elif c.reception == "sinr" and not collisions:
        yield f"comms.reception: sinr needs collisions on (by the modem or comms.collisions), got {c.reception!r}"


def _out_of_plane(spec: PathSpec) -> tuple[str, float] | None:
    """(field, value) that takes a path out of its horizontal plane, or None: circles and lawnmowers lie in the
    plane z = center[2] / origin[2] by construction; a helix climbs, a line may go up or down."""
    if isinstance(spec, HelixPath) and spec.climb != 0.0:
        return "climb", spec.climb
    if isinstance(spec, LinePath) and spec.velocity[2] != 0.0:
        return "velocity", spec.velocity[2]
    return None


PLANAR = "dimension 2 (planar) keeps every vehicle in its path's horizontal plane"


def _planar(sc: Scenario) -> Iterator[str]:
    """The planar model simulates x, y and yaw in the plane of each vehicle's path (at the path's z): anything out
    of that plane in a scenario would be dropped without a word, so it is refused instead."""
    if sc.scenario.dimension != 2:
        return
    for index, vehicle in enumerate(sc.vehicles):
        out = _out_of_plane(vehicle.path)
        if out is not None:
            yield f"vehicles[{index}].path.{out[0]}: {PLANAR} (no climb), got {out[1]}"
            continue
        yield from _planar_vehicle(index, vehicle)


def _planar_vehicle(index: int, vehicle: VehicleSection) -> Iterator[str]:
    from supervisor.config.fleet import build_path

    try:
        height = float(build_path(vehicle.path).evaluate(0.0)[0][2])
    except (ValueError, OverflowError):
        return  # _paths reports it
    if vehicle.position[2] != height:
        yield f"vehicles[{index}].position: {PLANAR} (z = {height:g}), got z = {vehicle.position[2]}"
    dropped = {
        "velocity": ("w", vehicle.velocity[2:]),
        "angular_velocity": ("p, q", vehicle.angular_velocity[:2]),
        "attitude_rpy_deg": ("roll, pitch", vehicle.attitude_rpy_deg[:2]),
    }
    for name, (parts, values) in dropped.items():
        if any(v != 0.0 for v in values):
            yield f"vehicles[{index}].{name}: dimension 2 (planar) has no {parts}, got {list(values)}"


# Each rule with the top-level sections it reads: it runs only if all of them validated.
RULES: tuple[tuple[frozenset[str], Check], ...] = (
    (frozenset({"vehicles"}), _ids),
    (frozenset({"scenario"}), _step),
    (frozenset({"vehicles", "graph"}), _graph),
    (frozenset({"vehicles", "graph", "faults", "scenario"}), _faults),
    (frozenset({"vehicles", "faults", "scenario"}), kill_errors),
    (frozenset({"vehicle", "vehicles"}), _overrides),
    (frozenset({"vehicles"}), _paths),
    (frozenset({"vehicles", "graph", "comms", "scenario"}), _comms),
    (frozenset({"vehicles", "scenario"}), _planar),
    (frozenset({"vehicles", "faults", "scenario"}), _clock_skew),
    (frozenset({"vehicles", "coordination"}), _path_speed),
    (frozenset({"scenario", "environment"}), planar_current_errors),
    (frozenset({"coordination", "comms"}), extension_errors),
    (frozenset({"vehicle", "vehicles", "path_following"}), controller_errors),
    (frozenset({"vehicle", "vehicles", "scenario"}), vehicle_model_errors),
)


def cross_field_errors(sc: Scenario, rejected: frozenset[str] | set[str] = frozenset()) -> list[str]:
    """Every cross-field error of sc, '<field>: <problem>, got <value>' each; rules that read a section named in
    rejected (pydantic refused it: sc holds a stand-in there) are skipped."""
    out: list[str] = []
    for sections, rule in RULES:
        if not sections & rejected:
            out += rule(sc)
    if not out and not rejected:  # the channel's feasibility needs every section valid and consistent
        out += feasibility_errors(sc)
    return out


def scenario_warnings(sc: Scenario) -> list[str]:
    """What a valid scenario holds that will not happen, '<field>: <problem>, got <value>' each: faults that start
    at or after the end of the run (a run shortened with --set scenario.duration=... is a fair thing to ask for),
    keys of [comms.transmit] its policy does not read (supervisor.config.transmit_checks), a channel that loses
    much or a loop predicted to diverge (supervisor.config.feasibility_checks), a path a vehicle's fins cannot
    hold it on (supervisor.config.authority_checks) and a graph W-MSR cannot work on (supervisor.config.robustness)."""
    steps, dt, end = steps_of(sc), sc.scenario.step, sc.scenario.duration
    late = [
        f"faults[{index}].start: at or after the end of the run ({end:g} s), the {fault.kind} fault never acts, "
        f"got {fault.start}"
        for index, fault in enumerate(sc.faults)
        if first_step(fault.start, dt) >= steps
    ]
    checked = transmit_warnings(sc) + unit_warnings(sc) + feasibility_warnings(sc) + authority_warnings(sc)
    checked += turn_warnings(sc)
    return late + checked + list(resilience_warnings(sc))
