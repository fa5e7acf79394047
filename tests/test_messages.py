"""Messages on the bus: builders, wire format, parsers and JSON-Schemas agree; malformed input is a ValueError."""

from __future__ import annotations

import importlib.util
import math
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import msgpack
import numpy as np
import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

from comms.broker_core import BrokerCore
from comms.channel import Channel, ChannelParams, Kinematics, LinkEvent, Reception
from comms.loss import Bernoulli
from comms.messages import (
    COMMS_DONE_KEY,
    COMMS_EVENT_KEY,
    COMMS_STATS_KEY,
    FAULT_KEY,
    GRAPH_KEY,
    META_KEY,
    STOP_KEY,
    TICK_KEY,
    Message,
    Tick,
    decode,
    encode,
    event_message,
    parse_rx,
    parse_state,
    parse_tick,
    parse_tx,
    rx_key,
    rx_message,
    state_key,
    state_message,
    tick_message,
    tx_key,
    tx_message,
    vehicle_of_key,
)
from comms.schemas import (
    COMMS_DONE,
    COMMS_STATS,
    LINK_EVENT,
    RECEPTIONS,
    STATE,
    STOP,
    TICK,
    TRANSMISSION,
    Schema,
    schema_for,
)
from comms.stats import LinkStats
from comms.wire import SIZE, encode_coordination
from supervisor.fleet import initial_state, radio, vehicle_config
from supervisor.scenario import load_scenario
from vehicles.agent import Disturbances, Telemetry
from vehicles.dynamics import PLANAR, SPATIAL, Model
from vehicles.geometry import rotation_2d, rotation_from_rpy
from vehicles.runtime import Heard, NodeState, node_step
from vehicles.transmission import Transmission

PAPER = Path(__file__).resolve().parent.parent / "configs" / "paper.toml"
STILL_AT_150 = Kinematics(np.array([150.0, 0.0, 0.0]), np.zeros(3))
HAVE_JSONSCHEMA = importlib.util.find_spec("jsonschema") is not None

# --- a validator for the subset of JSON-Schema that comms/schemas.py uses ---------------------------------------

KEYWORDS = {
    "$schema",
    "title",
    "type",
    "required",
    "properties",
    "additionalProperties",
    "items",
    "minItems",
    "maxItems",
    "enum",
}


def _has_type(value: object, name: str) -> bool:
    if name == "object":
        return isinstance(value, dict)
    if name == "array":
        return isinstance(value, list)
    if name == "string":
        return isinstance(value, str)
    if name == "boolean":
        return isinstance(value, bool)
    if name == "null":
        return value is None
    if name == "integer":
        return isinstance(value, int) and not isinstance(value, bool)
    if name == "number":
        return isinstance(value, int | float) and not isinstance(value, bool)
    raise AssertionError(f"type {name!r} is outside the subset this validator knows")


def schema_errors(value: object, schema: Schema, where: str = "$") -> list[str]:
    """Every way value breaks schema (empty: valid). Fails loudly on a keyword it does not implement."""
    unknown = set(schema) - KEYWORDS
    assert not unknown, f"{where}: schema keywords {sorted(unknown)} are outside the subset this validator knows"
    if "type" in schema:
        names = schema["type"] if isinstance(schema["type"], list) else [schema["type"]]
        if not any(_has_type(value, name) for name in names):
            return [f"{where}: {value!r} is not of type {names}"]
    errors: list[str] = []
    if "enum" in schema and not any(value == e and type(value) is type(e) for e in schema["enum"]):
        errors.append(f"{where}: {value!r} is not one of {schema['enum']}")
    if isinstance(value, dict):
        errors += [f"{where}: missing {name!r}" for name in schema.get("required", []) if name not in value]
        properties = schema.get("properties", {})
        for name, sub in properties.items():
            if name in value:
                errors += schema_errors(value[name], sub, f"{where}.{name}")
        extra = schema.get("additionalProperties", True)
        for name in (n for n in value if n not in properties):
            if extra is False:
                errors.append(f"{where}: unexpected {name!r}")
            elif isinstance(extra, dict):
                errors += schema_errors(value[name], extra, f"{where}.{name}")
    if isinstance(value, list):
        if len(value) < schema.get("minItems", 0):
            errors.append(f"{where}: {len(value)} items, fewer than {schema['minItems']}")
        if len(value) > schema.get("maxItems", math.inf):
            errors.append(f"{where}: {len(value)} items, more than {schema['maxItems']}")
        if "items" in schema:
            for i, item in enumerate(value):
                errors += schema_errors(item, schema["items"], f"{where}[{i}]")
    return errors


def assert_valid(message: Message, key: str) -> None:
    schema = schema_for(key)
    assert schema is not None, f"no schema for {key}"
    assert schema_errors(message, schema) == []
    assert set(message) == set(schema["properties"]), "the schema describes exactly the fields that are built"
    if HAVE_JSONSCHEMA:  # pragma: no cover - not a dependency; used when present
        import jsonschema

        jsonschema.validate(message, schema)


def wire(message: Message) -> Message:
    return decode(encode(message))


# --- messages built from real vehicles ---------------------------------------------------------------------------


def first_step(overrides: tuple[str, ...] = ()) -> list[tuple[Telemetry, Model, Transmission]]:
    """Every vehicle of the paper's scenario after one sync step from its initial state."""
    scenario = load_scenario(PAPER, overrides)
    out = []
    for vid in scenario.vehicle_ids:
        cfg = vehicle_config(scenario, vid)
        node = NodeState(initial_state(scenario, cfg))
        _, result = node_step(
            cfg,
            radio(scenario, vid),
            node,
            0.0,
            scenario.scenario.step,
            [],
            scenario.neighbours(vid),
            Disturbances(),
        )
        assert result.transmission is not None and result.estimate_ages == ()  # nothing heard yet
        out.append((result.telemetry, cfg.model, result.transmission))
    return out


@pytest.fixture(scope="module")
def spatial_fleet() -> list[tuple[Telemetry, Model, Transmission]]:
    return first_step()


@pytest.fixture(scope="module")
def planar_fleet() -> list[tuple[Telemetry, Model, Transmission]]:
    return first_step(("scenario.dimension=2",))


def turning_telemetry(model: Model) -> Telemetry:
    """A vehicle rolled, pitched and yawed, moving and turning: the body-to-inertial rotation matters."""
    if model is SPATIAL:
        rot = rotation_from_rpy(0.1, -0.2, 2.5)
        x = SPATIAL.pack(np.array([3.0, -4.0, -12.5]), rot, np.array([1.2, 0.1, -0.05]), np.array([0.01, 0.02, 0.3]))
        error, tau = np.array([0.5, -0.25, 0.125]), np.array([10.0, -2.0, 3.0])
    else:
        rot = rotation_2d(2.5)
        x = PLANAR.pack(np.array([3.0, -4.0]), rot, np.array([1.2, 0.1]), np.array([0.3]))
        error, tau = np.array([0.5, -0.25]), np.array([10.0, 3.0])
    return Telemetry(4, 12.3, 7.5, 0.98, x, error, tau, -0.02, 0.75)


def test_state_messages_of_real_vehicles_round_trip_and_validate(spatial_fleet, planar_fleet):
    for telemetry, model, sent in spatial_fleet + planar_fleet:
        message = state_message(telemetry, model, 0, sent.seq)
        assert_valid(message, state_key(telemetry.vehicle_id))
        assert wire(message) == message
        report = parse_state(wire(message), telemetry.vehicle_id)
        assert (report.k, report.vehicle, report.tx_seq) == (0, telemetry.vehicle_id, 1)
        np.testing.assert_allclose(report.kinematics.position, sent.position, rtol=0, atol=1e-12)
        np.testing.assert_allclose(report.kinematics.velocity, sent.velocity, rtol=0, atol=1e-12)


@pytest.mark.parametrize("model", [SPATIAL, PLANAR], ids=["spatial", "planar"])
def test_state_message_carries_inertial_kinematics_to_the_broker(model):
    telemetry = turning_telemetry(model)
    message = state_message(telemetry, model, 123, 0)
    assert_valid(message, state_key(4))
    assert wire(message) == message
    s = model.spatial(telemetry.x)
    assert message["error"][: len(telemetry.error)] == telemetry.error.tolist()
    assert len(message["error"]) == 3 and len(message["rotation"]) == 9
    report = parse_state(wire(message), 4)
    assert (report.k, report.vehicle, report.tx_seq) == (123, 4, 0)
    np.testing.assert_allclose(report.kinematics.position, s.position, rtol=0, atol=1e-12)
    np.testing.assert_allclose(report.kinematics.velocity, s.rotation @ s.velocity, rtol=0, atol=1e-12)
    assert not np.allclose(report.kinematics.velocity, s.velocity)  # body-frame velocity would be wrong


def test_tx_message_round_trips_through_parse_tx(spatial_fleet):
    for _, _, sent in spatial_fleet:
        message = tx_message(sent)
        assert_valid(message, tx_key(sent.sender))
        assert wire(message) == message
        assert parse_tx(wire(message), sent.sender) == sent
    moving = Transmission(9, 42, 31.4, -2.5, 1.25, (1.0, -2.0, 3.5), (0.5, -0.25, 0.0))
    assert parse_tx(wire(tx_message(moving)), 9) == moving


def test_rx_message_round_trips_through_parse_rx():
    receptions = [
        Reception(2, 1, 5, 0.4, 0.42, 10.5, 0.99),
        Reception(2, 3, 1, 0.3, np.float64(0.4125), -1.0, 1.01),  # the channel's arrivals are numpy floats
    ]
    message = rx_message(2, 5, 0.5, receptions)
    assert_valid(message, rx_key(2))
    for item in message["receptions"]:
        assert schema_errors(item, RECEPTIONS["properties"]["receptions"]["items"]) == []
        assert set(item) == set(RECEPTIONS["properties"]["receptions"]["items"]["properties"])
    assert wire(message) == message
    assert parse_rx(wire(message)) == (5, [Heard(1, 0.4, 10.5, 0.99), Heard(3, 0.3, -1.0, 1.01)])
    channel = Channel(ChannelParams(jitter=0.01), seed=1)
    channel.transmit(Transmission(1, 8, 0.7, 2.0, 1.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)), 16, {3}, {3: STILL_AT_150})
    delivered, _ = channel.deliver(1.0)
    message = rx_message(3, 10, 1.0, delivered)
    assert_valid(message, rx_key(3))
    assert wire(message) == message
    assert parse_rx(wire(message)) == (10, [Heard(1, 0.7, 2.0, 1.0)])
    empty = rx_message(3, 0, 0.0, [])
    assert_valid(empty, rx_key(3))
    assert parse_rx(wire(empty)) == (0, [])


@pytest.mark.parametrize(
    "event",
    [
        LinkEvent(1.0, 1, 2, 3, "sent"),
        LinkEvent(1.25, 1, 2, 3, "delivered", delay=0.25),
        LinkEvent(1.0, 2, 1, 4, "dropped", reason="loss"),
        LinkEvent(9.0, 2, 1, 5, "dropped", reason="end_of_run"),
    ],
    ids=lambda e: e.kind,
)
def test_event_message_round_trips_and_validates(event):
    message = event_message(event)
    assert_valid(message, COMMS_EVENT_KEY)
    assert wire(message) == message
    assert LinkEvent(**wire(message)) == event


@pytest.mark.parametrize(
    ("caps", "final"), [({}, False), ({3: 0.5, 1: 0.25}, False), ({2: 1}, True)], ids=["none", "two", "final"]
)
def test_tick_message_round_trips_through_parse_tick(caps, final):
    message = tick_message(17, 1.7, final, caps)
    assert_valid(message, TICK_KEY)
    assert wire(message) == message
    assert [pair[0] for pair in message["caps"]] == sorted(caps)
    assert parse_tick(wire(message)) == Tick(17, 1.7, final, caps)


def test_the_coordination_frame_is_the_compact_wire_size_not_the_bus_message():
    sent = Transmission(1, 2, 0.5, 3.0, 1.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert len(encode_coordination(sent)) == SIZE == 15  # sender 1 + seq 2 + time 4 + gamma 4 + gamma_dot 4
    assert SIZE < len(encode({"i": 1, "s": 2, "t": 0.5, "g": 3.0, "d": 1.0})) < len(encode(tx_message(sent)))


def test_state_message_carries_the_ages_of_the_estimates_it_holds(spatial_fleet):
    telemetry, model, sent = spatial_fleet[0]
    assert state_message(telemetry, model, 0, sent.seq)["estimate_age"] == []
    message = state_message(telemetry, model, 7, sent.seq, ages=((2, 0.25), (3, 1.5)))
    assert message["estimate_age"] == [[2, 0.25], [3, 1.5]]
    assert_valid(message, state_key(telemetry.vehicle_id))
    assert wire(message) == message
    assert parse_state(wire(message), telemetry.vehicle_id).k == 7  # the broker does not need it


def stats_snapshot() -> Message:
    """A real cpf/comms/stats message: a lossy run on the graph 2 - 1 - 3, books closed at the end."""
    where = {1: (0.0, 0.0, 0.0), 2: (-300.0, 0.0, 0.0), 3: (0.0, 600.0, 0.0)}
    fleet = {i: Kinematics(np.array(p), np.zeros(3)) for i, p in where.items()}
    core = BrokerCore(
        Channel(ChannelParams(loss=Bernoulli(0.3)), 5), {1: [2, 3], 2: [1], 3: [1]}, LinkStats([1, 2, 3], 2.0)
    )
    for k in range(30):
        t = k * 0.1
        core.submit([Transmission(i, k + 1, t, t, 1.0, p, (0.0, 0.0, 0.0)) for i, p in where.items()], fleet)
        core.deliver(t + 0.1, [1, 2, 3])
    core.finish(3.0)
    snapshot = core.snapshot_due(3.0, final=True)
    assert snapshot is not None
    return snapshot


def test_comms_stats_message_round_trips_and_validates():
    message = stats_snapshot()
    assert_valid(message, COMMS_STATS_KEY)
    assert wire(message) == message
    book = COMMS_STATS["properties"]["links"]["items"]
    assert [(link["sender"], link["receiver"]) for link in message["links"]] == [(1, 2), (1, 3), (2, 1), (3, 1)]
    for link in message["links"]:
        assert schema_errors(link, book) == [] and set(link) == set(book["properties"])
        assert link["sent"] == 30 == link["delivered"] + sum(link["dropped"].values())
        assert set(link["dropped"]) <= {"loss", "end_of_run"} and link["dropped"]["loss"] > 0
        assert 0.0 < link["mean_delay"] <= link["max_delay"]
    assert message["lambda2"] == pytest.approx(1.0)  # every link delivered in the last 2 s: the path graph's 1


def keywords(schema: Schema) -> set[str]:
    """Every keyword used anywhere in a schema."""
    found = set(schema)
    for sub in schema.get("properties", {}).values():
        found |= keywords(sub)
    for name in ("items", "additionalProperties"):
        if isinstance(schema.get(name), dict):
            found |= keywords(schema[name])
    return found


def test_every_schema_stays_within_the_validators_subset():
    for key in (
        META_KEY,
        FAULT_KEY,
        GRAPH_KEY,
        STOP_KEY,
        TICK_KEY,
        COMMS_EVENT_KEY,
        COMMS_DONE_KEY,
        COMMS_STATS_KEY,
        "cpf/vehicle/1/rx",
    ):
        schema = schema_for(key)
        assert schema is not None and keywords(schema) <= KEYWORDS, key
    for schema in (STATE, TRANSMISSION):
        assert keywords(schema) <= KEYWORDS


def test_schema_for_knows_every_key():
    assert schema_for(state_key(7)) is STATE
    assert schema_for(tx_key(7)) is TRANSMISSION
    assert schema_for(rx_key(7)) is RECEPTIONS
    assert schema_for(TICK_KEY) is TICK and schema_for(COMMS_EVENT_KEY) is LINK_EVENT
    assert schema_for(COMMS_DONE_KEY) is COMMS_DONE and schema_for(STOP_KEY) is STOP
    assert schema_for(COMMS_STATS_KEY) is COMMS_STATS
    assert all(schema_for(key) is not None for key in (META_KEY, FAULT_KEY, GRAPH_KEY))
    assert schema_for("cpf/vehicle/7/unknown") is None
    assert schema_for("cpf/elsewhere") is None


def test_the_validator_is_not_vacuous(spatial_fleet):
    telemetry, model, _ = spatial_fleet[0]
    good = state_message(telemetry, model, 0, 1)
    assert schema_errors(good, STATE) == []
    assert schema_errors({**good, "rotation": good["rotation"][:8]}, STATE) != []
    assert schema_errors({**good, "k": 1.5}, STATE) != []
    assert schema_errors({**good, "k": True}, STATE) != []
    assert schema_errors({k: v for k, v in good.items() if k != "tau"}, STATE) != []
    assert schema_errors({**event_message(LinkEvent(0.0, 1, 2, 3, "sent")), "kind": "lost"}, LINK_EVENT) != []
    assert schema_errors({**event_message(LinkEvent(0.0, 1, 2, 3, "sent")), "delay": "1"}, LINK_EVENT) != []
    assert schema_errors({**tick_message(0, 0.0, False, {}), "final": 0}, TICK) != []
    assert schema_errors({**good, "estimate_age": [[2, 0.5, 1.0]]}, STATE) != []
    stats = stats_snapshot()
    assert schema_errors(stats, COMMS_STATS) == []
    bad_book = {**stats["links"][0], "dropped": {"loss": "3"}}  # a count that is not an integer
    assert schema_errors({**stats, "links": [bad_book]}, COMMS_STATS) != []
    assert schema_errors({**stats, "lambda2": None}, COMMS_STATS) != []


@pytest.mark.parametrize(
    ("key", "expected"),
    [
        ("cpf/vehicle/12/state", (12, "state")),
        ("cpf/vehicle/3/tx", (3, "tx")),
        ("cpf/vehicle/x/state", None),
        ("cpf/vehicle/-1/state", None),
        ("cpf/vehicle/1/state/more", None),
        ("cpf/vehicle/1", None),
        ("other/vehicle/1/state", None),
        ("cpf/clock/tick", None),
    ],
)
def test_vehicle_of_key(key, expected):
    assert vehicle_of_key(key) == expected


def test_vehicle_of_key_with_a_unicode_digit_is_not_a_vehicle_key():
    assert vehicle_of_key("cpf/vehicle/²/state") is None


# --- malformed input -------------------------------------------------------------------------------------------------

NAN, INF = float("nan"), float("inf")
VALID_TX = tx_message(Transmission(2, 5, 0.5, 3.0, 1.0, (1.0, 2.0, 3.0), (0.5, 0.0, -0.5)))
VALID_STATE = state_message(turning_telemetry(SPATIAL), SPATIAL, 3, 2)  # vehicle 4
VALID_RX = rx_message(1, 4, 0.4, [Reception(1, 2, 3, 0.3, 0.31, 5.0, 1.0)])
VALID_TICK = tick_message(4, 0.4, False, {1: 0.5})


def without(message: Message, name: str) -> Message:
    return {k: v for k, v in message.items() if k != name}


def with_(message: Message, **changes: Any) -> Message:
    return {**message, **changes}


def tx_cases() -> list[tuple[str, Message]]:
    cases = [(f"missing {name}", without(VALID_TX, name)) for name in VALID_TX]
    cases += [
        ("sender is a string", with_(VALID_TX, sender="2")),
        ("sender is a float", with_(VALID_TX, sender=2.0)),
        ("seq is a bool", with_(VALID_TX, seq=True)),
        ("seq is None", with_(VALID_TX, seq=None)),
        ("t is a string", with_(VALID_TX, t="0.5")),
        ("t is a bool", with_(VALID_TX, t=False)),
        ("t is nan", with_(VALID_TX, t=NAN)),
        ("gamma is inf", with_(VALID_TX, gamma=INF)),
        ("gamma_dot is -inf", with_(VALID_TX, gamma_dot=-INF)),
        ("position has 2 items", with_(VALID_TX, position=[1.0, 2.0])),
        ("position has 4 items", with_(VALID_TX, position=[1.0, 2.0, 3.0, 4.0])),
        ("position is a map", with_(VALID_TX, position={"x": 1.0})),
        ("position is a number", with_(VALID_TX, position=1.0)),
        ("position holds a string", with_(VALID_TX, position=[1.0, "2", 3.0])),
        ("position holds a bool", with_(VALID_TX, position=[1.0, True, 3.0])),
        ("position holds None", with_(VALID_TX, position=[1.0, None, 3.0])),
        ("velocity holds nan", with_(VALID_TX, velocity=[NAN, 0.0, 0.0])),
        ("velocity holds inf", with_(VALID_TX, velocity=[0.0, 0.0, INF])),
        ("velocity is nested", with_(VALID_TX, velocity=[[0.0], [0.0], [0.0]])),
        ("another vehicle's key", with_(VALID_TX, sender=3)),
    ]
    return cases


def state_cases() -> list[tuple[str, Message]]:
    cases = [(f"missing {name}", without(VALID_STATE, name)) for name in ("vehicle", "k", "tx_seq")]
    cases += [(f"missing {name}", without(VALID_STATE, name)) for name in ("position", "rotation", "velocity")]
    cases += [
        ("vehicle is a bool", with_(VALID_STATE, vehicle=True)),
        ("k is a bool", with_(VALID_STATE, k=False)),
        ("k is a float", with_(VALID_STATE, k=3.0)),
        ("tx_seq is a string", with_(VALID_STATE, tx_seq="2")),
        ("tx_seq is a bool", with_(VALID_STATE, tx_seq=True)),
        ("rotation has 8 items", with_(VALID_STATE, rotation=VALID_STATE["rotation"][:8])),
        ("rotation is 3x3", with_(VALID_STATE, rotation=[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])),
        ("rotation holds a string", with_(VALID_STATE, rotation=["1", *VALID_STATE["rotation"][1:]])),
        ("rotation holds a bool", with_(VALID_STATE, rotation=[True, *VALID_STATE["rotation"][1:]])),
        ("rotation holds None", with_(VALID_STATE, rotation=[None, *VALID_STATE["rotation"][1:]])),
        ("position holds nan", with_(VALID_STATE, position=[0.0, NAN, 0.0])),
        ("position has 2 items", with_(VALID_STATE, position=[0.0, 0.0])),
        ("velocity holds inf", with_(VALID_STATE, velocity=[INF, 0.0, 0.0])),
        ("velocity holds a bool", with_(VALID_STATE, velocity=[False, 0.0, 0.0])),
        ("another vehicle's key", with_(VALID_STATE, vehicle=5)),
    ]
    return cases


def rx_cases() -> list[tuple[str, Message]]:
    reception = VALID_RX["receptions"][0]
    cases = [("missing k", without(VALID_RX, "k")), ("missing receptions", without(VALID_RX, "receptions"))]
    cases += [
        (f"reception missing {name}", with_(VALID_RX, receptions=[without(reception, name)]))
        for name in ("sender", "stamp", "gamma", "gamma_dot")
    ]
    cases += [
        ("k is a bool", with_(VALID_RX, k=True)),
        ("k is a string", with_(VALID_RX, k="4")),
        ("receptions is a map", with_(VALID_RX, receptions={"0": reception})),
        ("a reception is a list", with_(VALID_RX, receptions=[list(reception.values())])),
        ("a reception is None", with_(VALID_RX, receptions=[reception, None])),
        ("sender is a bool", with_(VALID_RX, receptions=[with_(reception, sender=True)])),
        ("sender is a float", with_(VALID_RX, receptions=[with_(reception, sender=2.0)])),
        ("stamp is nan", with_(VALID_RX, receptions=[with_(reception, stamp=NAN)])),
        ("gamma is inf", with_(VALID_RX, receptions=[with_(reception, gamma=INF)])),
        ("gamma_dot is a string", with_(VALID_RX, receptions=[with_(reception, gamma_dot="1")])),
    ]
    return cases


def tick_cases() -> list[tuple[str, Message]]:
    cases = [(f"missing {name}", without(VALID_TICK, name)) for name in VALID_TICK]
    cases += [
        ("k is a bool", with_(VALID_TICK, k=True)),
        ("k is a float", with_(VALID_TICK, k=4.0)),
        ("t is nan", with_(VALID_TICK, t=NAN)),
        ("t is inf", with_(VALID_TICK, t=INF)),
        ("t is a bool", with_(VALID_TICK, t=True)),
        ("final is an int", with_(VALID_TICK, final=1)),
        ("final is a string", with_(VALID_TICK, final="true")),
        ("final is None", with_(VALID_TICK, final=None)),
        ("caps is a map", with_(VALID_TICK, caps={"1": 0.5})),
        ("a cap is a number", with_(VALID_TICK, caps=[0.5])),
        ("a cap is a map", with_(VALID_TICK, caps=[{"1": 0.5}])),
        ("a cap has 3 items", with_(VALID_TICK, caps=[[1, 0.5, 0.0]])),
        ("a cap has 1 item", with_(VALID_TICK, caps=[[1]])),
        ("a cap's vehicle is a float", with_(VALID_TICK, caps=[[1.0, 0.5]])),
        ("a cap's vehicle is a bool", with_(VALID_TICK, caps=[[True, 0.5]])),
        ("a cap's vehicle is a string", with_(VALID_TICK, caps=[["1", 0.5]])),
        ("a cap's value is nan", with_(VALID_TICK, caps=[[1, NAN]])),
        ("a cap's value is inf", with_(VALID_TICK, caps=[[1, INF]])),
        ("a cap's value is a bool", with_(VALID_TICK, caps=[[1, False]])),
        ("a cap's value is None", with_(VALID_TICK, caps=[[1, None]])),
    ]
    return cases


Parser = Callable[[Message], object]
PARSERS: dict[str, Parser] = {
    "tx": lambda m: parse_tx(m, 2),
    "state": lambda m: parse_state(m, 4),
    "rx": parse_rx,
    "tick": parse_tick,
}
CASES = [
    pytest.param(kind, message, id=f"{kind}: {name}")
    for kind, cases in (("tx", tx_cases()), ("state", state_cases()), ("rx", rx_cases()), ("tick", tick_cases()))
    for name, message in cases
]


def test_the_valid_baselines_parse():
    for kind, valid in (("tx", VALID_TX), ("state", VALID_STATE), ("rx", VALID_RX), ("tick", VALID_TICK)):
        PARSERS[kind](wire(valid))


@pytest.mark.parametrize(("kind", "message"), CASES)
def test_malformed_messages_raise_value_error(kind, message):
    with pytest.raises(ValueError):
        PARSERS[kind](message)
    with pytest.raises(ValueError):  # the same, as it arrives over the wire
        PARSERS[kind](wire(message))


@pytest.mark.parametrize("bad", [NAN, INF, -INF], ids=["nan", "inf", "-inf"])
def test_parse_state_rejects_a_non_finite_rotation(bad):
    with pytest.raises(ValueError):
        parse_state(with_(VALID_STATE, rotation=[bad, *VALID_STATE["rotation"][1:]]), 4)


@pytest.mark.parametrize(
    ("kind", "message"),
    [
        ("tx", with_(VALID_TX, t=10**400)),
        ("tick", with_(VALID_TICK, caps=[[1, -(10**400)]])),
        ("state", with_(VALID_STATE, rotation=[10**400] * 9)),
    ],
    ids=["tx", "tick", "state"],
)
def test_an_integer_too_large_for_a_float_is_a_value_error(kind, message):
    with pytest.raises(ValueError):
        PARSERS[kind](message)


GARBAGE = [
    b"",
    b"\xc1",  # never used in msgpack
    b"\x81",  # a map of one entry, truncated
    b"\x82\xa1a\x01",  # a map of two entries, one given
    b"\xa5abc",  # a truncated string
    b"\x81\xa1a\x01\x02",  # a map and extra bytes
    b"\xdd\xff\xff\xff\xff",  # an array claiming 4 G items
    b"\x81\x91\x01\x02",  # a map whose key is an array (unhashable)
    b"\xd4\x05\x00",  # an extension type
    b"\xd6\xff\x00\x00\x00\x00",  # a msgpack timestamp
    b"not msgpack at all",
    bytes(range(256)),
]
NOT_MAPS = [None, True, 3, -1.5, "text", b"bytes", [], [1, {"a": 1}]]


@pytest.mark.parametrize("data", GARBAGE)
def test_decode_of_garbage_is_a_value_error(data):
    with pytest.raises(ValueError):
        decode(data)


@pytest.mark.parametrize("value", NOT_MAPS, ids=repr)
def test_decode_of_anything_but_a_map_is_a_value_error(value):
    with pytest.raises(ValueError, match="not a map"):
        decode(msgpack.packb(value, use_bin_type=True))


def test_decode_accepts_maps_with_non_string_keys():
    assert decode(msgpack.packb({1: "a", "b": [1, 2]})) == {1: "a", "b": [1, 2]}


# --- properties ------------------------------------------------------------------------------------------------------

MSGPACK_INTS = st.integers(-(2**63), 2**64 - 1)  # what the wire can carry
SCALARS = st.none() | st.booleans() | MSGPACK_INTS | st.floats() | st.text(max_size=6)
JSON_VALUES = st.recursive(
    SCALARS,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4),
    max_leaves=10,
)
NUMBERISH = st.floats() | MSGPACK_INTS | st.booleans()
NEAR_MISSES = JSON_VALUES | NUMBERISH | st.lists(NUMBERISH, min_size=0, max_size=10)


DROP = object()  # a field left out


def mutations(valid: Message) -> st.SearchStrategy[Message]:
    """The valid message with up to three fields dropped or replaced, and maybe extra fields."""
    replacement: dict[str, st.SearchStrategy[Any]] = {name: NEAR_MISSES | st.just(DROP) for name in valid}
    if isinstance(valid.get("receptions"), list):
        inner = st.lists(mutations(valid["receptions"][0]) | JSON_VALUES, min_size=1, max_size=3)
        replacement["receptions"] = inner | replacement["receptions"]
    if isinstance(valid.get("caps"), list):
        pairs = st.lists(st.lists(NUMBERISH, min_size=1, max_size=3) | JSON_VALUES, min_size=1, max_size=3)
        replacement["caps"] = pairs | replacement["caps"]
    changes = st.lists(st.sampled_from(sorted(valid)), max_size=3, unique=True).flatmap(
        lambda names: st.fixed_dictionaries({name: replacement[name] for name in names})
    )
    extra = st.dictionaries(st.text(max_size=6).filter(lambda name: name not in valid), JSON_VALUES, max_size=2)
    return st.builds(
        lambda changed, more: {
            **more,
            **{k: changed.get(k, v) for k, v in valid.items() if changed.get(k, v) is not DROP},
        },
        changes,
        extra,
    )


def succeeds_or_value_error(parser: Parser, message: Message) -> bool:
    """Whether parser accepts message; any exception but ValueError propagates."""
    with warnings.catch_warnings():
        # numpy's overflow warning (a nan/huge rotation) is not an exception in a real process
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            parser(message)
        except ValueError:
            return False
        return True


@settings(max_examples=300, deadline=None, database=None)
@given(st.binary(max_size=64))
def test_decode_of_arbitrary_bytes_gives_a_map_or_a_value_error(data):
    try:
        message = decode(data)
    except ValueError:
        return
    assert isinstance(message, dict)


@settings(max_examples=200, deadline=None, database=None)
@given(JSON_VALUES)
def test_decode_inverts_msgpack_for_maps_only(value):
    data = msgpack.packb(value, use_bin_type=True)
    if isinstance(value, dict):
        decoded = decode(data)
        assert isinstance(decoded, dict) and encode(decoded) == data
    else:
        with pytest.raises(ValueError):
            decode(data)


@pytest.mark.parametrize(
    ("kind", "valid"),
    [("tx", VALID_TX), ("state", VALID_STATE), ("rx", VALID_RX), ("tick", VALID_TICK)],
    ids=["tx", "state", "rx", "tick"],
)
@settings(max_examples=150, deadline=None, database=None)
@given(data=st.data())
def test_parsers_succeed_or_raise_value_error_only(kind, valid, data):
    message = data.draw(mutations(valid) | st.dictionaries(st.text(max_size=8), JSON_VALUES, max_size=6))
    accepted = succeeds_or_value_error(PARSERS[kind], message)
    assert succeeds_or_value_error(PARSERS[kind], wire(message)) == accepted
    event("accepted" if accepted else "rejected")


@pytest.mark.parametrize(
    ("name", "value"), [("gamma", 1e39), ("gamma_dot", -1e39), ("t", -1.0)], ids=["gamma", "gamma_dot", "t"]
)
def test_parse_tx_rejects_what_the_wire_frame_cannot_carry(name, value):
    message = with_(VALID_TX, **{name: value})
    with pytest.raises(ValueError):
        parse_tx(message, 2)
