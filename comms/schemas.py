"""JSON-Schemas of the messages on each key expression, for the MCAP channels (Foxglove reads them).

Each describes one record's to_message (comms.*, supervisor.record.meta.RunMeta); tests/test_state_report.py checks
every record's fields against its schema, tests/test_messages.py every built message.
"""

from __future__ import annotations

from typing import Any

from comms.messages import (
    COMMS_DONE_KEY,
    COMMS_EVENT_KEY,
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    FAULT_KEY,
    GRAPH_KEY,
    HELLO_PREFIX,
    META_KEY,
    STOP_KEY,
    TICK_KEY,
    vehicle_of_key,
)

Schema = dict[str, Any]
NUMBER: Schema = {"type": "number"}
INTEGER: Schema = {"type": "integer"}
STRING: Schema = {"type": "string"}
BOOLEAN: Schema = {"type": "boolean"}


def _vector(n: int | None = None) -> Schema:
    schema: Schema = {"type": "array", "items": NUMBER}
    if n is not None:
        schema["minItems"] = schema["maxItems"] = n
    return schema


def _integers(n: int | None = None) -> Schema:
    return {**_vector(n), "items": INTEGER}


def _object(title: str, properties: Schema, optional: tuple[str, ...] = ()) -> Schema:
    return {
        "$schema": "http://json-schema.org/draft-07/schema#",
        "title": title,
        "type": "object",
        "properties": properties,
        "required": [name for name in properties if name not in optional],
    }


STATE = _object(
    "cpf.VehicleState",
    {
        "t": NUMBER,
        "k": INTEGER,
        "vehicle": INTEGER,
        "gamma": NUMBER,
        "gamma_dot": NUMBER,
        "position": _vector(3),
        "rotation": _vector(9),
        "velocity": _vector(3),
        "angular_velocity": _vector(3),
        "error": _vector(3),
        "tau": _vector(),
        "correction": NUMBER,
        "lyapunov": NUMBER,
        "tx_seq": INTEGER,
        "estimate_age": {"type": "array", "items": _vector(2)},
        "rx_lateness": _vector(),  # realtime: s (wall clock) from each reception's arrival to its coming (< 0: ahead)
        "step_lateness": NUMBER,  # realtime: s (wall clock) from t_k to the vehicle's starting its step
        "nav_estimate": _vector(27),  # navigation on: the filter's [p_hat, bias, covariance upper triangle]
        "nav_fix": INTEGER,  # navigation on: 0 no fix due, 1 fix fused, 2 fix lost
        "current_estimate": _vector(3),  # current observer on: its estimate, inertial, m/s
    },
    optional=("rx_lateness", "step_lateness", "nav_estimate", "nav_fix", "current_estimate"),
)
TRANSMISSION = _object(
    "cpf.Transmission",
    {
        "t": NUMBER,
        "stamp": NUMBER,  # the data time the sender claims: t, unless its clock is skewed
        "sender": INTEGER,
        "seq": INTEGER,
        "gamma": NUMBER,
        "gamma_dot": NUMBER,
        "position": _vector(3),
        "velocity": _vector(3),
    },
)
_RECEPTION = _object(
    "cpf.Reception",
    {
        "sender": INTEGER,
        "seq": INTEGER,
        "stamp": NUMBER,
        "arrival": NUMBER,
        "gamma": NUMBER,
        "gamma_dot": NUMBER,
        "due": NUMBER,
    },
    optional=("due",),  # realtime: the wall-clock time (time.time()) the delivery was due
)
RECEPTIONS = _object(
    "cpf.Receptions",
    {"t": NUMBER, "k": INTEGER, "vehicle": INTEGER, "receptions": {"type": "array", "items": _RECEPTION}},
)
LINK_EVENT = _object(
    "cpf.LinkEvent",
    {
        "t": NUMBER,
        "sender": INTEGER,
        "receiver": INTEGER,
        "seq": INTEGER,
        "kind": {"enum": ["sent", "delivered", "dropped"]},
        "delay": {"type": ["number", "null"]},
        "reason": {"type": ["string", "null"]},
    },
)
LINK_EVENTS = _object(  # the bus's form of a step's link events (the log keeps one LINK_EVENT record each)
    "cpf.LinkEvents", {"t": NUMBER, "k": INTEGER, "events": {"type": "array", "items": LINK_EVENT}}
)
_DISTURBED = _object(
    "cpf.DisturbedVehicle",
    {"vehicle": INTEGER, "cap": {"type": ["number", "null"]}, "freeze": BOOLEAN, "offset": NUMBER, "skew": NUMBER},
)
_LINKS: Schema = {"type": "array", "items": _integers(2)}  # directed (sender, receiver) pairs
_NETWORK: Schema = {
    **_object(
        "cpf.Network",
        {
            "edges": _LINKS,
            "down": _LINKS,
            "degraded": {"type": "array", "items": _vector(4)},  # [sender, receiver, extra loss, extra delay]
            "blackout": BOOLEAN,
            "silent": _integers(),
        },
    ),
    "type": ["object", "null"],  # null: the scenario's graph, no link faults
}
TICK = _object(
    "cpf.Tick",
    {
        "t": NUMBER,
        "k": INTEGER,
        "final": BOOLEAN,
        "vehicles": {"type": "array", "items": _DISTURBED},  # only vehicles with any fault acting
        "network": _NETWORK,
        "alive": {"type": ["array", "null"], "items": INTEGER},  # null: every vehicle
        "comms": BOOLEAN,
        "wall": {"type": ["number", "null"]},  # realtime: t on the wall clock (time.time()); null: lockstep
        "speed": NUMBER,  # realtime: simulated s per wall-clock s
        "hold": BOOLEAN,  # a process is killed or restarted at the next tick
        "until": INTEGER,  # on the bus only: a lockstep time window of steps k .. until-1 (the log: one per step)
        "span": INTEGER,  # on the bus only: the broker issues the ticks of steps k .. span-1 itself
        "longest": {"type": ["integer", "null"]},  # with span: the broker's windows of at most this many steps
    },
    optional=("wall", "speed", "hold", "until", "span", "longest"),  # old logs lack realtime; the rest: the bus only
)
_LINK_BOOK = _object(
    "cpf.LinkBook",
    {
        "sender": INTEGER,
        "receiver": INTEGER,
        "sent": INTEGER,
        "delivered": INTEGER,
        "dropped": {"type": "object", "additionalProperties": INTEGER},
        "mean_delay": {"type": ["number", "null"]},
        "max_delay": {"type": ["number", "null"]},
    },
)
COMMS_STATS = _object(
    "cpf.CommsStats",
    {
        "t": NUMBER,
        "window": NUMBER,
        "horizon": NUMBER,  # s a delivery keeps its pair in the delivered graph lambda2 is of (absent in older logs)
        "lambda2": NUMBER,
        "links": {"type": "array", "items": _LINK_BOOK},
    },
    optional=("horizon",),
)
COMMS_DONE = _object("cpf.CommsDone", {"t": NUMBER, "k": INTEGER, "events": INTEGER, "malformed": INTEGER})
VEHICLE_DONE = _object(
    "cpf.VehicleDone",
    {"t": NUMBER, "k": INTEGER, "vehicle": INTEGER, "malformed": {"type": "object", "additionalProperties": INTEGER}},
)
META = _object(
    "cpf.RunMeta",
    {
        "scenario_name": STRING,
        "scenario_file": STRING,
        "scenario_toml": STRING,
        "scenario": {"type": "object"},
        "seed": INTEGER,
        "engine": STRING,
        "clock": STRING,
        "step": NUMBER,
        "duration": NUMBER,
        "vehicles": {"type": "array", "items": INTEGER},
        "edges": {"type": "array", "items": _vector(2)},
        "faults": {"type": "array", "items": {"type": "object"}},
        "tube_radius": NUMBER,
        "versions": {"type": "object"},
        "extensions": {"type": "array", "items": {"type": "string"}},
    },
    optional=("extensions",),  # logs of cpf before extensions have none
)
FAULT = _object(
    "cpf.FaultEvent", {"t": NUMBER, "kind": STRING, "phase": {"enum": ["start", "end"]}, "detail": {"type": "object"}}
)
GRAPH = _object("cpf.Graph", {"t": NUMBER, "edges": {"type": "array", "items": _integers(2)}})
STOP = _object("cpf.Stop", {"t": NUMBER, "reason": STRING})  # "end of run", or why the run stopped early
HELLO = _object(
    "cpf.Hello",  # a query's reply, not published: which scenario a process runs (sha256 hex, whole and per section)
    {"process": STRING, "digest": STRING, "sections": {"type": "object", "additionalProperties": STRING}},
)

_BY_KEY = {
    META_KEY: META,
    FAULT_KEY: FAULT,
    GRAPH_KEY: GRAPH,
    STOP_KEY: STOP,
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
