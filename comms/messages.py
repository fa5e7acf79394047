"""Key expressions and message schemas: the one place that says what travels on the bus and lands in the log.

Every message is a flat dict of JSON-compatible values. On Zenoh it travels as msgpack; in MCAP it is stored as JSON
with a JSON-Schema (what Foxglove and `mcap cat --json` read). Simulation time: float seconds in messages (`t`),
integer nanoseconds as MCAP log time. Vectors are lists; `rotation` is R row-major (9 numbers).
"""

from __future__ import annotations

from typing import Any

import msgpack

from vehicles.agent import Telemetry
from vehicles.dynamics import Model

ROOT = "cpf"
META_KEY = f"{ROOT}/run/meta"
FAULT_KEY = f"{ROOT}/run/fault"
GRAPH_KEY = f"{ROOT}/run/graph"

Message = dict[str, Any]


def state_key(vehicle_id: int) -> str:
    """Per-vehicle state telemetry."""
    return f"{ROOT}/vehicle/{vehicle_id}/state"


def vehicle_of_state_key(key: str) -> int | None:
    """Inverse of state_key; None for any other key."""
    parts = key.split("/")
    if len(parts) == 4 and parts[0] == ROOT and parts[1] == "vehicle" and parts[3] == "state":
        return int(parts[2]) if parts[2].isdigit() else None
    return None


def _number() -> dict[str, str]:
    return {"type": "number"}


def _vector(n: int | None = None) -> dict[str, Any]:
    schema: dict[str, Any] = {"type": "array", "items": {"type": "number"}}
    if n is not None:
        schema["minItems"] = schema["maxItems"] = n
    return schema


def _object(title: str, properties: dict[str, Any]) -> dict[str, Any]:
    return {
        "$schema": "http://json-schema.org/draft-07/schema#",
        "title": title,
        "type": "object",
        "properties": properties,
        "required": list(properties),
    }


STATE_SCHEMA = _object(
    "cpf.VehicleState",
    {
        "t": _number(),
        "vehicle": {"type": "integer"},
        "gamma": _number(),
        "gamma_dot": _number(),
        "position": _vector(3),
        "rotation": _vector(9),
        "velocity": _vector(3),
        "angular_velocity": _vector(3),
        "error": _vector(3),
        "tau": _vector(),
        "correction": _number(),
        "lyapunov": _number(),
    },
)

META_SCHEMA = _object(
    "cpf.RunMeta",
    {
        "scenario_name": {"type": "string"},
        "scenario_file": {"type": "string"},
        "scenario_toml": {"type": "string"},
        "seed": {"type": "integer"},
        "engine": {"type": "string"},
        "step": _number(),
        "duration": _number(),
        "vehicles": {"type": "array", "items": {"type": "integer"}},
        "edges": {"type": "array", "items": _vector(2)},
        "faults": {"type": "array", "items": {"type": "object"}},
        "tube_radius": _number(),
        "versions": {"type": "object"},
    },
)

FAULT_SCHEMA = _object(
    "cpf.FaultEvent",
    {
        "t": _number(),
        "kind": {"type": "string"},
        "phase": {"enum": ["start", "end"]},
        "detail": {"type": "object"},
    },
)

GRAPH_SCHEMA = _object("cpf.Graph", {"t": _number(), "edges": {"type": "array", "items": _vector(2)}})


def schema_for(key: str) -> dict[str, Any]:
    """The JSON schema of the messages on a key expression."""
    if vehicle_of_state_key(key) is not None:
        return STATE_SCHEMA
    return {META_KEY: META_SCHEMA, FAULT_KEY: FAULT_SCHEMA, GRAPH_KEY: GRAPH_SCHEMA}[key]


def encode(message: Message) -> bytes:
    """Wire format (msgpack)."""
    data: bytes = msgpack.packb(message, use_bin_type=True)
    return data


def decode(data: bytes) -> Message:
    """Inverse of encode; raises ValueError for anything that is not a msgpack map."""
    try:
        message = msgpack.unpackb(data, raw=False)
    except Exception as exc:  # msgpack raises several unrelated types for garbage
        raise ValueError(f"undecodable message: {exc}") from exc
    if not isinstance(message, dict):
        raise ValueError(f"message is a {type(message).__name__}, not a map")
    return message


def state_message(telemetry: Telemetry, model: Model) -> Message:
    """A vehicle's telemetry as the message on its state key (planar vehicles embedded in 3-D)."""
    s = model.spatial(telemetry.x)
    error = telemetry.error.tolist() + [0.0] * (3 - len(telemetry.error))
    return {
        "t": telemetry.t,
        "vehicle": telemetry.vehicle_id,
        "gamma": telemetry.gamma,
        "gamma_dot": telemetry.gamma_dot,
        "position": s.position.tolist(),
        "rotation": s.rotation.reshape(9).tolist(),
        "velocity": s.velocity.tolist(),
        "angular_velocity": s.angular_velocity.tolist(),
        "error": error,
        "tau": telemetry.tau.tolist(),
        "correction": telemetry.correction,
        "lyapunov": telemetry.lyapunov,
    }
