"""Scenario files: TOML parsed into typed, frozen objects and validated completely before anything starts.

Every error names the file, the field and the bad value on one line, e.g.
    configs/bad.toml: scenario.step: must be greater than 0, got -0.1
See configs/paper.toml for a documented example of every section.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError
from pydantic_core import ErrorDetails

from supervisor.errors import ScenarioError
from supervisor.scenario_schema import LINK_FAULTS, FaultSpec, GraphSwitchFault, Scenario
from vehicles.params import PRESETS, VehicleParams
from vehicles.paths import Path as PathLike

# --- error messages ---------------------------------------------------------------------------------------


def _format_location(loc: Iterable[int | str]) -> str:
    text = ""
    for part in loc:
        if isinstance(part, int) or not part.isidentifier():
            text += f"[{part!r}]"  # a list index, or a key TOML had to quote
        else:
            text += f".{part}" if text else part
    return text or "(top level)"


def _show(value: object) -> str:
    """A bad value for a message: one line (repr escapes line breaks), at most 60 characters."""
    if isinstance(value, dict):
        return "a table"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _child(data: object, part: int | str) -> tuple[bool, object]:
    """(True, data[part]) if part is a key or index of data, else (False, None)."""
    if isinstance(data, dict) and part in data:
        return True, data[part]
    if isinstance(data, list | tuple) and isinstance(part, int) and 0 <= part < len(data):
        return True, data[part]
    return False, None


def _file_location(loc: tuple[int | str, ...], data: object, missing: bool) -> list[int | str]:
    """pydantic's loc without the union-member tags it inserts ('helix', 'float', ...): the parts that index
    the parsed TOML, plus a missing key at the end."""
    out: list[int | str] = []
    for position, part in enumerate(loc):
        found, child = _child(data, part)
        if found:
            out.append(part)
            data = child
        elif missing and position == len(loc) - 1:
            out.append(part)
    return out


_PROBLEMS = {
    "missing": "missing required field",
    "extra_forbidden": "unknown key",
    "tuple_type": "must be an array",
    "dict_type": "must be a table",
    "model_type": "must be a table",
}


def _describe(error: ErrorDetails, data: object) -> tuple[str, str]:
    """(field, problem) of one pydantic error, in terms of the file."""
    kind, value, ctx = error["type"], error.get("input"), error.get("ctx", {})
    loc = _file_location(error["loc"], data, kind == "missing")
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        loc.append(str(ctx["discriminator"]).strip("'"))
        if kind == "union_tag_not_found":
            return _format_location(loc), _PROBLEMS["missing"]
        return _format_location(loc), f"must be one of {ctx['expected_tags']}, got {_show(ctx['tag'])}"
    if kind == "missing" and loc and isinstance(loc[-1], int):  # a short array: pydantic reports its first absent item
        return _format_location(loc[:-1]), f"too few items, got {_show(value)}"
    problem = _PROBLEMS.get(kind) or error["msg"].removeprefix("Value error, ")
    problem = problem.replace("Input should be", "must be").replace("Tuple should have", "must have")
    shown = "" if kind in ("missing", "extra_forbidden") else f", got {_show(value)}"
    return _format_location(loc), re.sub(r" after validation, not \d+$", "", problem) + shown


def _one_line(exc: ValidationError, data: object) -> str:
    errors = exc.errors()
    # A misspelt key also makes the real one "missing": report the misspelling first.
    errors.sort(key=lambda e: e["type"] != "extra_forbidden")
    described = [_describe(error, data) for error in errors]
    field, problem = described[0]
    more = len({f for f, _ in described}) - 1
    suffix = f" (and {more} more field{'s' if more > 1 else ''} with errors)" if more else ""
    return f"{field}: {problem}{suffix}"


def _error(source: str, message: str) -> ScenarioError:
    """ScenarioError('<source>: <message>'), forced onto one line whatever the source and message hold."""
    return ScenarioError("\\n".join(f"{source}: {message}".splitlines()))


# --- cross-field checks -----------------------------------------------------------------------------------


def _check_consistency(sc: Scenario) -> None:
    """Cross-field rules pydantic cannot express field by field."""
    ids = sc.vehicle_ids
    for index, vid in enumerate(ids):
        if ids.index(vid) != index:
            raise ScenarioError(f"vehicles[{index}].id: duplicate vehicle id, got {vid}")
    _check_graph(sc)
    for index, fault in enumerate(sc.faults):
        _check_fault(index, fault, ids)
    if sc.scenario.step > sc.scenario.duration:
        raise ScenarioError(f"scenario.step: must not exceed duration ({sc.scenario.duration}), got {sc.scenario.step}")
    _check_overrides(sc)
    _check_paths(sc)
    _check_comms(sc)


def _check_fault(index: int, fault: FaultSpec, ids: list[int]) -> None:
    named = {"vehicle": getattr(fault, "vehicle", None), "sender": getattr(fault, "sender", None)}
    named["receiver"] = getattr(fault, "receiver", None)
    for field_name, vid in named.items():
        if vid is not None and vid not in ids:
            raise ScenarioError(f"faults[{index}].{field_name}: no such vehicle in {ids}, got {vid}")
    if fault.end is not None and fault.end <= fault.start:
        raise ScenarioError(f"faults[{index}].end: must be after start ({fault.start}), got {fault.end}")
    if isinstance(fault, LINK_FAULTS) and fault.sender == fault.receiver:
        raise ScenarioError(f"faults[{index}].receiver: a link joins two vehicles, got {fault.receiver}")
    if isinstance(fault, GraphSwitchFault):
        for edge in fault.edges:
            if edge[0] not in ids or edge[1] not in ids or edge[0] == edge[1]:
                raise ScenarioError(f"faults[{index}].edges: not an edge between two vehicles {ids}, got {list(edge)}")


def _check_comms(sc: Scenario) -> None:
    """Links, TDMA order and packet size against the fleet and the modem; the models' own checks."""
    from comms.wire import MAX_VEHICLE_ID, SIZE
    from supervisor.fleet import channel_params, modem_params

    ids = sc.vehicle_ids
    if max(ids) > MAX_VEHICLE_ID:
        raise ScenarioError(f"vehicles: ids must fit the 1-byte wire field (<= {MAX_VEHICLE_ID}), got {max(ids)}")
    edges = {tuple(e) for e in sc.graph.edges} | {(j, i) for i, j in sc.graph.edges}
    for index, link in enumerate(sc.comms.links):
        if (link.sender, link.receiver) not in edges:
            raise ScenarioError(f"comms.links[{index}]: not a link of the graph, got {link.sender} -> {link.receiver}")
    tdma = sc.comms.tdma
    slots = tdma.slot / sc.scenario.step if tdma is not None else 1.0
    if tdma is not None and (slots < 1 - 1e-9 or abs(slots - round(slots)) > 1e-6):
        raise ScenarioError(f"comms.tdma.slot: must be a whole number of steps ({sc.scenario.step} s), got {tdma.slot}")
    if tdma is not None and tdma.order is not None and sorted(tdma.order) != sorted(ids):
        raise ScenarioError(f"comms.tdma.order: must list every vehicle once {sorted(ids)}, got {list(tdma.order)}")
    radio = modem_params(sc)
    size = sc.comms.packet_bytes or SIZE
    if radio.max_bytes is not None and size > radio.max_bytes:
        raise ScenarioError(f"comms.packet_bytes: the {sc.comms.modem} modem takes {radio.max_bytes} B, got {size}")
    try:
        channel_params(sc)
    except ValueError as exc:
        raise ScenarioError(f"comms: {exc}") from exc


def _check_graph(sc: Scenario) -> None:
    ids, edges = sc.vehicle_ids, sc.graph.edges
    for index, (i, j) in enumerate(edges):
        for end in (i, j):
            if end not in ids:
                raise ScenarioError(
                    f"graph.edges[{index}]: vehicle {end} is not in [[vehicles]] ids {ids}, got {[i, j]}"
                )
        if i == j:
            raise ScenarioError(f"graph.edges[{index}]: an edge must join two vehicles, got {[i, j]}")
    reached = {ids[0]}
    for _ in ids:  # each pass reaches at least one more vehicle, or nothing more can be reached
        reached |= {j for i, j in edges if i in reached} | {i for i, j in edges if j in reached}
    unreached = [vid for vid in ids if vid not in reached]
    if unreached:
        raise ScenarioError(
            f"graph.edges: the graph must be connected, vehicles {unreached} cannot reach vehicle {ids[0]}, "
            f"got {[list(e) for e in edges]}"
        )


def _check_overrides(sc: Scenario) -> None:
    """Each override names a VehicleParams field and has its shape: a number, or an array of 3 numbers."""
    defaults = PRESETS[sc.vehicle.preset]
    known = list(VehicleParams.__dataclass_fields__)
    for name, value in sc.vehicle.overrides.items():
        where = _format_location(["vehicle", "overrides", name])
        if name not in known:
            raise ScenarioError(f"{where}: unknown vehicle parameter, expected one of {known}")
        vector = isinstance(getattr(defaults, name), tuple)
        if vector != isinstance(value, tuple):
            shape = "an array of 3 numbers" if vector else "a number"
            raise ScenarioError(f"{where}: must be {shape}, got {list(value) if isinstance(value, tuple) else value}")


def _finite_at_zero(path: PathLike) -> bool:
    try:
        return all(np.isfinite(vector).all() for vector in path.evaluate(0.0))
    except (ValueError, OverflowError):  # math.cos(inf) and the like
        return False


def _check_paths(sc: Scenario) -> None:
    """Build each path as the run will: its own checks (e.g. period != 0) become field errors here."""
    from supervisor.fleet import build_path  # supervisor.fleet imports this module

    for index, vehicle in enumerate(sc.vehicles):
        try:
            path = build_path(vehicle.path)
        except ValueError as exc:  # vehicles.paths messages start with the parameter: "period must be ..."
            name, _, problem = str(exc).partition(" ")
            raise ScenarioError(f"vehicles[{index}].path.{name}: {problem}") from exc
        if not _finite_at_zero(path):  # e.g. period = 5e-324: 2 pi / period overflows
            values = ", ".join(f"{key} = {value}" for key, value in vehicle.path if key != "type")
            raise ScenarioError(f"vehicles[{index}].path: not finite at gamma = 0, got {values}")


# --- entry points -----------------------------------------------------------------------------------------


def validate_data(data: dict[str, Any], source: str) -> Scenario:
    """Scenario from parsed TOML; ScenarioError('<source>: <field>: <problem>, got <value>') otherwise."""
    try:
        scenario = Scenario.model_validate(data)
        _check_consistency(scenario)
    except ValidationError as exc:
        raise _error(source, _one_line(exc, data)) from exc
    except ScenarioError as exc:
        raise _error(source, str(exc)) from exc
    return scenario


def parse_scenario(
    text: str, source: str = "<string>", overrides: Sequence[str] = (), faults: Sequence[str] = ()
) -> Scenario:
    """Scenario from TOML text, KEY=VALUE overrides and extra faults ("kind=link_down,sender=1,..."); a
    ScenarioError('<source>: <field>: ...') otherwise."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise _error(source, f"invalid TOML: {exc}") from exc
    for override in overrides:
        apply_override(data, override)
    for fault in faults:
        data.setdefault("faults", []).append(fault_table(fault))
    return validate_data(data, source)


def fault_table(spec: str) -> dict[str, Any]:
    """A --fault value as the table [[faults]] would hold: comma-separated KEY=VALUE, values as TOML values."""
    table: dict[str, Any] = {}
    for part in split_outside_brackets(spec):
        key, sep, text = part.partition("=")
        if not sep or not key.strip():
            raise ScenarioError(f"--fault: expected KEY=VALUE pairs separated by commas, got {spec!r}")
        try:
            table[key.strip()] = tomllib.loads(f"v = {text.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            table[key.strip()] = text.strip()
    return table


def split_outside_brackets(spec: str) -> list[str]:
    """Split at commas outside brackets, so edges=[[1,2],[2,3]] stays whole."""
    parts, depth, current = [], 0, ""
    for char in spec:
        depth += {"[": 1, "]": -1}.get(char, 0)
        if char == "," and depth == 0:
            parts.append(current)
            current = ""
        else:
            current += char
    return [p for p in [*parts, current] if p.strip()]


def apply_override(data: dict[str, Any], override: str) -> None:
    """Set a dotted key (list items by index: vehicles.0.gamma0) to a TOML value; bare words are strings."""
    key, sep, text = override.partition("=")
    if not sep or not key.strip():
        raise ScenarioError(f"--set: expected KEY=VALUE, got {override!r}")
    try:
        value = tomllib.loads(f"v = {text.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = text.strip()
    node: Any = data
    parts = key.strip().split(".")
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        if isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node[int(part)] = value if last else node[int(part)]
            node = node[int(part)]
        elif isinstance(node, dict):
            if last:
                node[part] = value
            node = node.setdefault(part, {})
        else:
            raise ScenarioError(f"--set {key}: no such place in the scenario, got {override!r}")


def load_scenario(path: Path, overrides: Sequence[str] = (), faults: Sequence[str] = ()) -> Scenario:
    """Read and validate a scenario file (UTF-8, as TOML requires)."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise _error(str(path), f"cannot read scenario file: {exc.strerror or exc}") from exc
    except UnicodeDecodeError as exc:
        raise _error(str(path), f"invalid TOML: not UTF-8 text (byte {exc.start})") from exc
    return parse_scenario(text, str(path), overrides, faults)
