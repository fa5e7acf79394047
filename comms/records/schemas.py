"""JSON-Schemas of the messages on each key expression, for the MCAP channels and the live view (Foxglove and
Lichtblick read them).

Every message is described once, by a msgspec Struct (comms.records.*), and its schema is generated from it here
(`struct_schema`). Every schema is in the subset the viewers read (tests/viewer_rules.py, after Lichtblick's
parseJsonSchema): an object's fields each of one type (no unions: an optional field is left out of the message, not
null), arrays of numbers, strings, booleans or objects (no arrays of arrays), every enum typed.
tests/test_state_report.py checks every record's fields against its schema, tests/test_messages.py every built
message, tests/test_viewer_schemas.py and tests/test_foxglove_log.py every record of a run.
"""

from __future__ import annotations

import sys
from typing import Any

import msgspec

from comms.records.events import LinkEvents
from comms.records.messages import (
    COMMS_DONE_KEY,
    COMMS_EVENT_KEY,
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    FAULT_KEY,
    GRAPH_KEY,
    HELLO_PREFIX,
    META_KEY,
    RUN_DONE_KEY,
    STOP_KEY,
    TICK_KEY,
    Hello,
    vehicle_of_key,
)
from comms.records.receptions import RxBatch
from comms.records.records import LinkEvent, Transmission
from comms.records.reports import CommsDone, CommsStats, SupervisorDone, VehicleDone
from comms.records.run import FaultEvent, Graph, RunMeta, Stop
from comms.records.state import StateReport
from comms.records.tick import Tick

Schema = dict[str, Any]
DRAFT = "http://json-schema.org/draft-07/schema#"
NUMBER: Schema = {"type": "number"}
FREE: Schema = {"type": "object", "properties": {}}  # any map (a viewer reads none of its fields)


def struct_schema(kind: type, title: str, always: tuple[str, ...] = ()) -> Schema:
    """The JSON Schema of a struct's message (msgspec's, from the struct), in the subset viewers read: references
    inlined, an optional field (T | None = None, left out of the message when None) as T and not required, a number
    that may be an integer (comms.records.fields.Real) as a number, a fixed-length tuple as an array of its items'
    type. always: optional fields (older messages may lack them) that the struct always writes, required."""
    raw = msgspec.json.schema(kind)
    schema: Schema = {"$schema": DRAFT, "title": title, **_viewed(raw, raw.get("$defs", {}))}
    schema["required"] = [name for name in schema["properties"] if name in schema["required"] or name in always]
    return schema


def _viewed(node: Schema, defs: dict[str, Schema]) -> Schema:
    if "$ref" in node:
        node = defs[node["$ref"].rsplit("/", 1)[-1]]
    if "anyOf" in node:
        return _one_of(node["anyOf"], defs)
    kind = node.get("type")
    if kind == "object" and "properties" not in node:  # a map: of anything, or of values of one type
        values = node.get("additionalProperties", {})
        return FREE if values == {} else {**FREE, "additionalProperties": _viewed(values, defs)}
    if kind == "object":
        properties = {name: _viewed(field, defs) for name, field in node["properties"].items()}
        return {"type": "object", "properties": properties, "required": list(node.get("required", []))}
    if kind == "array":
        return _array(node, defs)
    if "enum" in node:
        return {"type": _enum_type(node["enum"]), "enum": node["enum"]}
    # A bound at the largest float says only "finite", which every JSON number is (comms.records.fields.Finite).
    return {key: value for key, value in node.items() if key in ("type", "minimum", "maximum") and value not in _FLOATS}


_FLOATS = (-sys.float_info.max, sys.float_info.max)


def _one_of(options: list[Schema], defs: dict[str, Schema]) -> Schema:
    kept = [option for option in options if option.get("type") != "null"]  # None: the field left out
    if {option.get("type") for option in kept} == {"integer", "number"}:
        return NUMBER  # comms.records.fields.Real: an integer a float holds, or a float
    if len(kept) != 1:
        raise ValueError(f"no viewer form for a union of {options}")
    return _viewed(kept[0], defs)


def _array(node: Schema, defs: dict[str, Schema]) -> Schema:
    items = [_viewed(item, defs) for item in node.get("prefixItems", [])] or [_viewed(node["items"], defs)]
    if any(item != items[0] for item in items):
        raise ValueError(f"no viewer form for an array of mixed items {items}")
    out: Schema = {"type": "array", "items": items[0]}
    out.update({key: node[key] for key in ("minItems", "maxItems") if key in node})
    return out


def _enum_type(values: list[Any]) -> str:
    kinds = {type(v) for v in values}
    if kinds == {str}:
        return "string"
    if kinds <= {int}:
        return "integer"
    raise ValueError(f"no viewer form for an enum of {values}")


STATE = struct_schema(StateReport, "cpf.VehicleState")
TRANSMISSION = struct_schema(Transmission, "cpf.Transmission", always=("stamp",))  # stamp: t unless skewed
RECEPTIONS = struct_schema(RxBatch, "cpf.Receptions")
LINK_EVENT = struct_schema(LinkEvent, "cpf.LinkEvent")
LINK_EVENTS = struct_schema(LinkEvents, "cpf.LinkEvents")  # a step's batch, on the bus and in the log
TICK = struct_schema(Tick, "cpf.Tick")
COMMS_STATS = struct_schema(CommsStats, "cpf.CommsStats")
COMMS_DONE = struct_schema(CommsDone, "cpf.CommsDone")
VEHICLE_DONE = struct_schema(VehicleDone, "cpf.VehicleDone")
RUN_DONE = struct_schema(SupervisorDone, "cpf.SupervisorDone")
META = struct_schema(RunMeta, "cpf.RunMeta")
FAULT = struct_schema(FaultEvent, "cpf.FaultEvent")
GRAPH = struct_schema(Graph, "cpf.Graph")
STOP = struct_schema(Stop, "cpf.Stop")  # "end of run", or why the run stopped early
HELLO = struct_schema(Hello, "cpf.Hello")  # a query's reply, not published: which scenario a process runs

_BY_KEY = {
    META_KEY: META,
    FAULT_KEY: FAULT,
    GRAPH_KEY: GRAPH,
    STOP_KEY: STOP,
    RUN_DONE_KEY: RUN_DONE,
    TICK_KEY: TICK,
    COMMS_EVENT_KEY: LINK_EVENT,
    COMMS_EVENTS_KEY: LINK_EVENTS,
    COMMS_DONE_KEY: COMMS_DONE,
    COMMS_STATS_KEY: COMMS_STATS,
}
_BY_LEAF = {"state": STATE, "tx": TRANSMISSION, "rx": RECEPTIONS, "done": VEHICLE_DONE}


def schema_for(key: str) -> Schema | None:
    """The JSON schema of the messages on a key expression; None for a key we do not know."""
    owned = vehicle_of_key(key)
    if owned is not None:
        return _BY_LEAF.get(owned[1])
    if key.startswith(HELLO_PREFIX + "/"):
        return HELLO
    return _BY_KEY.get(key)
