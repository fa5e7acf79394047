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
from hypothesis import event, example, given, settings
from hypothesis import strategies as st

from comms.broker.broker_core import BrokerCore
from comms.broker.stats import LinkStats
from comms.channel.channel import Channel, ChannelParams
from comms.channel.loss import Bernoulli
from comms.records.events import LinkEvents
from comms.records.fields import MAX_TIME
from comms.records.messages import (
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
    batches_message,
    decode,
    encode,
    event_message,
    parse_batches,
    parse_event,
    parse_rx,
    parse_state,
    parse_tick,
    parse_tx,
    rx_key,
    rx_message,
    split_step,
    state_key,
    step_message,
    tick_message,
    tx_key,
    tx_message,
    vehicle_of_key,
)
from comms.records.network import Network
from comms.records.records import Disturbances, Heard, Kinematics, LinkEvent, Reception, Transmission
from comms.records.schemas import (
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
from comms.records.state import NeighbourAge
from comms.records.wire import SIZE, encode_coordination
from supervisor.config.fleet import initial_state, radio, vehicle_config
from supervisor.config.scenario import load_scenario
from vehicles.agent import Telemetry
from vehicles.dynamics import PLANAR, SPATIAL, Model
from vehicles.geometry import rotation_2d, rotation_from_rpy
from vehicles.report import state_message
from vehicles.runtime import NodeState, node_step

PAPER = Path(__file__).resolve().parent.parent / "configs" / "paper.toml"
STILL_AT_150 = Kinematics(np.array([150.0, 0.0, 0.0]), np.zeros(3))
HAVE_JSONSCHEMA = importlib.util.find_spec("jsonschema") is not None

# --- a validator for the subset of JSON-Schema that comms/records/schemas.py uses -------------------------------------

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
    "minimum",
    "maximum",
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
    if "minimum" in schema and value < schema["minimum"]:
        errors.append(f"{where}: {value!r} is less than {schema['minimum']}")
    if "maximum" in schema and value > schema["maximum"]:
        errors.append(f"{where}: {value!r} is more than {schema['maximum']}")
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
    fields, described = set(message), set(schema["properties"])
    assert set(schema["required"]) <= fields <= described, "the schema describes exactly the fields that are built"
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
    # The paper's fleet in the plane z = 0 (the planar model refuses a climb or a vehicle off its path's plane).
    planar = [f"vehicles.{i}.{key}" for i in range(3) for key in ("path.climb=0.0", "position.2=0.0")]
    return first_step(("scenario.dimension=2", *planar))


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


@pytest.mark.parametrize("stamp", [31.0, 32.5, 0.0, MAX_TIME], ids=["behind", "ahead", "zero", "max"])
def test_tx_message_carries_the_stamp_a_skewed_clock_claims(stamp):
    skewed = Transmission(9, 42, 31.4, -2.5, 1.25, (1.0, -2.0, 3.5), (0.5, -0.25, 0.0), stamp)
    message = tx_message(skewed)
    assert_valid(message, tx_key(9))
    assert (message["t"], message["stamp"]) == (31.4, stamp)
    parsed = parse_tx(wire(message), 9)
    assert parsed == skewed and parsed.data_time == stamp != parsed.t


def test_tx_stamp_is_the_transmission_time_unless_skewed():
    honest = Transmission(9, 42, 31.4, -2.5, 1.25, (1.0, -2.0, 3.5), (0.5, -0.25, 0.0))
    assert tx_message(honest)["stamp"] == 31.4
    stated = Transmission(9, 42, 31.4, -2.5, 1.25, (1.0, -2.0, 3.5), (0.5, -0.25, 0.0), 31.4)
    assert parse_tx(wire(tx_message(stated)), 9) == honest  # a stamp equal to t is no skew
    old = without(tx_message(honest), "stamp")  # a sender from before stamps: its data time is t
    assert parse_tx(wire(old), 9) == honest


def test_rx_message_round_trips_through_parse_rx():
    receptions = [
        Reception(2, 1, 5, 0.4, 0.42, 10.5, 0.99),
        Reception(2, 3, 1, 0.3, np.float64(0.4125), -1.0, 1.01),  # the channel's arrivals are numpy floats
    ]
    message = rx_message(2, 5, 0.5, receptions)
    assert_valid(message, rx_key(2))
    for item in message["receptions"]:
        assert schema_errors(item, RECEPTIONS["properties"]["receptions"]["items"]) == []
        assert set(item) == set(RECEPTIONS["properties"]["receptions"]["items"]["required"])
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
        LinkEvent(0.5, 1, 3, 6, "dropped", reason="modem_silent"),
        LinkEvent(2, 3, 1, 7, "delivered", delay=1),  # integers where floats are usual
    ],
    ids=lambda e: e.kind,
)
def test_event_message_round_trips_and_validates(event):
    message = event_message(event)
    assert_valid(message, COMMS_EVENT_KEY)
    assert wire(message) == message
    assert LinkEvent(**wire(message)) == event
    assert parse_event(wire(message)) == event


FAULTY_NETWORK = Network.of(
    ((1, 2), (1, 3), (2, 3)),
    frozenset({(1, 2), (3, 1)}),
    {(2, 1): (0.25, 0.5), (1, 3): (0.0, 1.0)},
    False,
    frozenset({3}),
)
TICKS = {
    "plain": Tick.of(17, 1.7, False, {}, None, None, True),
    "disturbed": Tick.of(
        17,
        1.7,
        False,
        {
            3: Disturbances(gamma_dot_cap=0.5),
            1: Disturbances(None, gamma_freeze=True),
            2: Disturbances(gamma_offset=-1.5, clock_offset=0.25),
            7: Disturbances(1, True, 2, -3),  # integers where floats are usual
        },
        None,
        None,
        True,
    ),
    "network": Tick.of(17, 1.7, False, {}, FAULTY_NETWORK, None, True),
    "blackout": Tick.of(17, 1.7, False, {}, Network.of(((1, 2),), blackout=True), None, True),
    "empty graph": Tick.of(17, 1.7, False, {}, Network.of(()), None, True),
    "alive": Tick.of(17, 1.7, False, {}, None, [1, 3], True),
    "none alive": Tick.of(17, 1.7, False, {}, None, [], True),
    "comms down": Tick.of(17, 1.7, False, {}, None, [1, 2, 3], False),
    "final": Tick.of(4000, 400.0, True, {2: Disturbances(0.5, True, 0.1, 0.2)}, FAULTY_NETWORK, [2, 1], False),
}


def tick_of(tick: Tick) -> Message:
    return tick_message(tick.k, tick.t, tick.final, tick.disturbed, tick.network, tick.alive, tick.comms)


def assert_valid_tick(message: Message) -> None:
    """Valid against the schema, and every nested object has exactly the fields the schema describes."""
    assert_valid(message, TICK_KEY)
    for item in message["vehicles"]:  # the cap only where there is one
        assert set(item) | {"cap"} == set(TICK["properties"]["vehicles"]["items"]["properties"])
    if "network" in message:
        assert set(message["network"]) == set(TICK["properties"]["network"]["properties"])


@pytest.mark.parametrize("tick", TICKS.values(), ids=TICKS.keys())
def test_tick_message_round_trips_through_parse_tick(tick):
    message = tick_of(tick)
    assert_valid_tick(message)
    assert wire(message) == message
    assert [item["vehicle"] for item in message["vehicles"]] == sorted(tick.disturbed)
    assert parse_tick(wire(message)) == tick


def test_tick_message_spells_out_the_faults():
    disturbed = {2: Disturbances(None, True, 0.1, -0.2), 1: Disturbances(0.5)}
    message = tick_message(3, 0.3, False, disturbed, FAULTY_NETWORK, [1, 2], comms=False)
    assert message == {
        "t": 0.3,
        "k": 3,
        "final": False,
        "vehicles": [
            {"vehicle": 1, "cap": 0.5, "freeze": False, "offset": 0.0, "skew": 0.0},
            {"vehicle": 2, "freeze": True, "offset": 0.1, "skew": -0.2},  # no cap: left out, not null
        ],
        "network": {
            "edges": [{"sender": 1, "receiver": 2}, {"sender": 1, "receiver": 3}, {"sender": 2, "receiver": 3}],
            "down": [{"sender": 1, "receiver": 2}, {"sender": 3, "receiver": 1}],
            "degraded": [
                {"sender": 1, "receiver": 3, "loss": 0.0, "delay": 1.0},
                {"sender": 2, "receiver": 1, "loss": 0.25, "delay": 0.5},
            ],
            "blackout": False,
            "silent": [3],
        },
        "alive": [1, 2],
        "comms": False,
        "speed": 1.0,
        "hold": False,
    }
    assert tick_message(0, 0.0, False) == {
        "t": 0.0,
        "k": 0,
        "final": False,
        "vehicles": [],  # no network, no alive list, no wall time: left out, not null
        "comms": True,
        "speed": 1.0,
        "hold": False,
    }
    assert "caps" not in message


def test_a_realtime_tick_maps_simulation_time_to_the_wall_clock():
    message = tick_message(30, 3.0, False, wall=1_000_000.0, speed=4.0)
    assert_valid_tick(message)
    tick = parse_tick(wire(message))
    assert (tick.wall, tick.speed) == (1_000_000.0, 4.0)
    assert tick.wall_of(3.4) == pytest.approx(1_000_000.1)
    old = {key: value for key, value in message.items() if key not in ("wall", "speed", "hold")}  # older logs
    assert (parse_tick(old).wall, parse_tick(old).speed, parse_tick(old).hold) == (None, 1.0, False)
    assert parse_tick(wire(tick_message(30, 3.0, False, hold=True))).hold is True
    with pytest.raises(ValueError, match="speed"):
        parse_tick(message | {"speed": 0.0})


def test_realtime_receptions_say_when_they_were_due():
    reception = Reception(2, 1, 5, 0.4, 0.42, 10.5, 0.99)
    message = rx_message(2, 5, 0.42, [reception], wall_of=lambda t: 100.0 + t)
    assert_valid(message, rx_key(2))
    assert message["receptions"][0]["due"] == pytest.approx(100.42)
    assert parse_rx(wire(message)) == (5, [Heard(1, 0.4, 10.5, 0.99)])


def test_a_step_message_splits_back_into_the_records_the_log_keeps():
    (telemetry, model, sent), *_ = first_step()
    state = state_message(telemetry, model, 0, sent.seq)
    tx = tx_message(sent)
    rx = rx_message(telemetry.vehicle_id, 0, 0.0, [])
    assert split_step(wire(step_message(state, tx, rx))) == (state, tx, rx)
    assert split_step(wire(step_message(state, None, None))) == (state, None, None)
    whole, alone = (parse_state(m, telemetry.vehicle_id) for m in (step_message(state, tx, rx), state))
    assert (whole.k, whole.tx_seq) == (alone.k, alone.tx_seq)  # the broker reads the state part as it is
    assert np.array_equal(whole.kinematics.position, alone.kinematics.position)


def test_a_step_s_link_events_travel_as_one_message():
    events = [LinkEvent(0.1, 1, 2, 3, "sent"), LinkEvent(0.11, 1, 2, 3, "delivered", delay=0.01)]
    batch = wire(LinkEvents(0.2, 2, tuple(events)).to_message())
    assert LinkEvents.from_message(batch) == LinkEvents(0.2, 2, tuple(events))
    for bad, field in (({"t": 0.2, "k": 2}, "events"), ({"t": 0.2, "k": 2, "events": [1]}, "events"),
                       ({"t": 0.2, "k": 2, "events": "x"}, "events"), ({"k": 2, "events": []}, "t")):  # fmt: skip
        with pytest.raises(ValueError, match=field):
            LinkEvents.from_message(bad)


def test_a_parsed_network_acts_as_the_one_sent():
    network = parse_tick(wire(tick_of(TICKS["network"]))).network
    assert network is not None
    assert network.neighbours(1) == [2, 3] and network.neighbours(3) == [1, 2]
    assert network.impairment(1, 2).lost == "link_down" and network.impairment(2, 1).lost is None
    assert (network.impairment(2, 1).extra_loss, network.impairment(2, 1).extra_delay) == (0.25, 0.5)
    assert 3 in network.silent and not network.blackout


def test_the_coordination_frame_is_the_compact_wire_size_not_the_bus_message():
    sent = Transmission(1, 2, 0.5, 3.0, 1.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert len(encode_coordination(sent)) == SIZE == 15  # sender 1 + seq 2 + time 4 + gamma 4 + gamma_dot 4
    assert SIZE < len(encode({"i": 1, "s": 2, "t": 0.5, "g": 3.0, "d": 1.0})) < len(encode(tx_message(sent)))


def test_state_message_carries_the_ages_of_the_estimates_it_holds(spatial_fleet):
    telemetry, model, sent = spatial_fleet[0]
    assert state_message(telemetry, model, 0, sent.seq)["estimate_age"] == []
    message = state_message(telemetry, model, 7, sent.seq, ages=(NeighbourAge(2, 0.25), NeighbourAge(3, 1.5)))
    assert message["estimate_age"] == [{"vehicle": 2, "age": 0.25}, {"vehicle": 3, "age": 1.5}]
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
    tick = tick_of(TICKS["final"])
    assert schema_errors(tick, TICK) == []
    assert schema_errors({**tick, "final": 0}, TICK) != []
    assert schema_errors({**tick, "caps": []}, TICK) == []  # extra fields are allowed; assert_valid forbids them
    assert schema_errors(without(tick, "comms"), TICK) != []
    assert schema_errors({**tick, "alive": [1.5]}, TICK) != []
    assert schema_errors(without(without(tick, "alive"), "network"), TICK) == []
    assert schema_errors({**tick, "alive": None}, TICK) != []  # left out, never null (viewers read no null)
    assert schema_errors({**tick, "vehicles": [with_(tick["vehicles"][0], cap="0.5")]}, TICK) != []
    assert schema_errors({**tick, "vehicles": [without(tick["vehicles"][0], "skew")]}, TICK) != []
    assert schema_errors({**tick, "network": with_(tick["network"], down=[[1, 2, 3]])}, TICK) != []
    assert schema_errors({**tick, "network": with_(tick["network"], edges=[[1.5, 2]])}, TICK) != []
    assert schema_errors({**tick, "network": with_(tick["network"], degraded=[[1, 2, 0.5]])}, TICK) != []
    assert schema_errors({**tick, "network": with_(tick["network"], blackout=None)}, TICK) != []
    assert schema_errors({**tick, "network": without(tick["network"], "silent")}, TICK) != []
    assert schema_errors({**tick, "network": []}, TICK) != []
    assert schema_errors(without(VALID_TX, "stamp"), TRANSMISSION) != []
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
VALID_TICK = tick_message(4, 0.4, False, {1: Disturbances(0.5, True, 0.1, 0.2)}, FAULTY_NETWORK, [1, 2, 3])
VALID_EVENT = event_message(LinkEvent(1.25, 1, 2, 3, "delivered", delay=0.25))


def without(message: Message, name: str) -> Message:
    return {k: v for k, v in message.items() if k != name}


def with_(message: Message, **changes: Any) -> Message:
    return {**message, **changes}


def tx_cases() -> list[tuple[str, Message]]:
    cases = [(f"missing {name}", without(VALID_TX, name)) for name in VALID_TX if name != "stamp"]  # stamp: t
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
        ("stamp is nan", with_(VALID_TX, stamp=NAN)),
        ("stamp is inf", with_(VALID_TX, stamp=INF)),
        ("stamp is negative", with_(VALID_TX, stamp=-0.001)),
        ("stamp is past the frame's clock", with_(VALID_TX, stamp=MAX_TIME + 0.001)),
        ("stamp is a bool", with_(VALID_TX, stamp=True)),
        ("stamp is a string", with_(VALID_TX, stamp="0.5")),
        ("stamp is None", with_(VALID_TX, stamp=None)),
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
        # the diagnostics too: the state report is read whole (comms.records.state.StateReport.from_message)
        ("t holds nan", with_(VALID_STATE, t=NAN)),
        ("gamma is a string", with_(VALID_STATE, gamma="7.5")),
        ("lyapunov is None", with_(VALID_STATE, lyapunov=None)),
        ("error has 2 items", with_(VALID_STATE, error=[0.0, 0.0])),
        ("tau holds a string", with_(VALID_STATE, tau=["1.0"])),
        ("angular_velocity holds nan", with_(VALID_STATE, angular_velocity=[NAN, 0.0, 0.0])),
        ("estimate_age lacks an age", with_(VALID_STATE, estimate_age=[{"vehicle": 1}])),
        ("estimate_age names a float vehicle", with_(VALID_STATE, estimate_age=[{"vehicle": 1.5, "age": 0.5}])),
        ("rx_lateness is a number", with_(VALID_STATE, rx_lateness=0.5)),
        ("step_lateness is a string", with_(VALID_STATE, step_lateness="late")),
    ]
    cases += [(f"missing {name}", without(VALID_STATE, name)) for name in ("t", "gamma", "error", "tau", "lyapunov")]
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
    entry = VALID_TICK["vehicles"][0]
    net = VALID_TICK["network"]

    def vehicle(**changes: Any) -> Message:
        return with_(VALID_TICK, vehicles=[with_(entry, **changes)])

    def network(**changes: Any) -> Message:
        return with_(VALID_TICK, network=with_(net, **changes))

    # an absent `network` or `alive` reads as null, like the explicit null every built tick carries
    cases = [(f"missing {name}", without(VALID_TICK, name)) for name in ("t", "k", "final", "vehicles", "comms")]
    cases += [
        ("k is a bool", with_(VALID_TICK, k=True)),
        ("k is a float", with_(VALID_TICK, k=4.0)),
        ("k is a string", with_(VALID_TICK, k="4")),
        ("k is None", with_(VALID_TICK, k=None)),
        ("t is nan", with_(VALID_TICK, t=NAN)),
        ("t is inf", with_(VALID_TICK, t=INF)),
        ("t is -inf", with_(VALID_TICK, t=-INF)),
        ("t is a bool", with_(VALID_TICK, t=True)),
        ("t is a string", with_(VALID_TICK, t="0.4")),
        ("final is an int", with_(VALID_TICK, final=1)),
        ("final is a string", with_(VALID_TICK, final="true")),
        ("final is None", with_(VALID_TICK, final=None)),
        ("comms is an int", with_(VALID_TICK, comms=0)),
        ("comms is a string", with_(VALID_TICK, comms="false")),
        ("comms is None", with_(VALID_TICK, comms=None)),
        # the disturbed vehicles
        ("vehicles is a map", with_(VALID_TICK, vehicles={"1": entry})),
        ("vehicles is None", with_(VALID_TICK, vehicles=None)),
        ("vehicles is the old caps", with_(VALID_TICK, vehicles=[[1, 0.5]])),
        ("a vehicle entry is a number", with_(VALID_TICK, vehicles=[1])),
        ("a vehicle entry is None", with_(VALID_TICK, vehicles=[entry, None])),
        ("a vehicle entry is a list", with_(VALID_TICK, vehicles=[list(entry.values())])),
        *[
            (f"a vehicle entry misses {name}", with_(VALID_TICK, vehicles=[without(entry, name)]))
            for name in ("vehicle", "freeze", "offset", "skew")
        ],
        ("a vehicle id is a float", vehicle(vehicle=1.0)),
        ("a vehicle id is a bool", vehicle(vehicle=True)),
        ("a vehicle id is a string", vehicle(vehicle="1")),
        ("a vehicle id is None", vehicle(vehicle=None)),
        ("a cap is nan", vehicle(cap=NAN)),
        ("a cap is inf", vehicle(cap=INF)),
        ("a cap is a bool", vehicle(cap=False)),
        ("a cap is a string", vehicle(cap="0.5")),
        ("a cap is a list", vehicle(cap=[0.5])),
        ("a freeze is an int", vehicle(freeze=1)),
        ("a freeze is None", vehicle(freeze=None)),
        ("a freeze is a string", vehicle(freeze="yes")),
        ("an offset is nan", vehicle(offset=NAN)),
        ("an offset is a bool", vehicle(offset=True)),
        ("an offset is None", vehicle(offset=None)),
        ("a skew is -inf", vehicle(skew=-INF)),
        ("a skew is a string", vehicle(skew="0.2")),
        ("a skew is None", vehicle(skew=None)),
        # the network
        ("network is a list", with_(VALID_TICK, network=[net])),
        ("network is a number", with_(VALID_TICK, network=1)),
        ("network is a string", with_(VALID_TICK, network="graph")),
        ("network is a bool", with_(VALID_TICK, network=True)),
        ("network is an empty map", with_(VALID_TICK, network={})),
        *[(f"network misses {name}", with_(VALID_TICK, network=without(net, name))) for name in net],
        ("edges is a map", network(edges={"1": 2})),
        ("edges is None", network(edges=None)),
        ("edges is a flat list", network(edges=[1, 2])),
        ("an edge has 1 item", network(edges=[[1]])),
        ("an edge has 3 items", network(edges=[[1, 2, 3]])),
        ("an edge is a map", network(edges=[{"1": 2}])),
        ("an edge holds a float", network(edges=[[1, 2.0]])),
        ("an edge holds a bool", network(edges=[[True, 2]])),
        ("an edge holds a string", network(edges=[["1", 2]])),
        ("an edge holds None", network(edges=[[1, None]])),
        ("an edge holds nan", network(edges=[[NAN, 2]])),
        ("down is a number", network(down=3)),
        ("a down link has 3 items", network(down=[[1, 2, 3]])),
        ("a down link holds a float", network(down=[[1.0, 2]])),
        ("a down link holds a bool", network(down=[[1, False]])),
        ("a down link holds a string", network(down=[[1, "2"]])),
        ("degraded is a map", network(degraded={"2": [1, 0.5, 0.1]})),
        ("degraded is None", network(degraded=None)),
        ("a degraded link has 3 items", network(degraded=[[2, 1, 0.5]])),
        ("a degraded link has 5 items", network(degraded=[[2, 1, 0.5, 0.1, 0.0]])),
        ("a degraded link is a map", network(degraded=[{"loss": 0.5}])),
        ("a degraded loss is nan", network(degraded=[[2, 1, NAN, 0.1]])),
        ("a degraded loss is inf", network(degraded=[[2, 1, INF, 0.1]])),
        ("a degraded loss is a bool", network(degraded=[[2, 1, True, 0.1]])),
        ("a degraded loss is a string", network(degraded=[[2, 1, "0.5", 0.1]])),
        ("a degraded loss is None", network(degraded=[[2, 1, None, 0.1]])),
        ("a degraded delay is -inf", network(degraded=[[2, 1, 0.5, -INF]])),
        ("a degraded delay is a list", network(degraded=[[2, 1, 0.5, [0.1]]])),
        ("a degraded link's sender is a string", network(degraded=[["x", 1, 0.5, 0.1]])),
        ("a degraded link's sender is nan", network(degraded=[[NAN, 1, 0.5, 0.1]])),
        ("blackout is an int", network(blackout=0)),
        ("blackout is None", network(blackout=None)),
        ("blackout is a string", network(blackout="no")),
        ("silent is a map", network(silent={"3": True})),
        ("silent is a number", network(silent=3)),
        ("silent is None", network(silent=None)),
        ("silent is a string", network(silent="3")),
        # the vehicles alive
        ("alive is a map", with_(VALID_TICK, alive={"1": True})),
        ("alive is a number", with_(VALID_TICK, alive=3)),
        ("alive is a string", with_(VALID_TICK, alive="123")),
        ("alive is a bool", with_(VALID_TICK, alive=True)),
        ("alive holds a float", with_(VALID_TICK, alive=[1, 2.0])),
        ("alive holds a bool", with_(VALID_TICK, alive=[1, True])),
        ("alive holds a string", with_(VALID_TICK, alive=["1"])),
        ("alive holds None", with_(VALID_TICK, alive=[None])),
        ("alive holds a list", with_(VALID_TICK, alive=[[1, 2]])),
    ]
    return cases


def tick_network_bug_cases() -> list[tuple[str, Message]]:
    """Malformed networks comms.records.messages._network gets wrong: an error other than ValueError, or none at all."""
    net = VALID_TICK["network"]

    def network(**changes: Any) -> Message:
        return with_(VALID_TICK, network=with_(net, **changes))

    return [
        ("a degraded link's sender is None", network(degraded=[[None, 1, 0.5, 0.1]])),  # TypeError
        ("a degraded link's receiver is a list", network(degraded=[[2, [1], 0.5, 0.1]])),  # TypeError
        ("a degraded link's sender is inf", network(degraded=[[INF, 1, 0.5, 0.1]])),  # OverflowError
        ("a degraded link's sender is a numeric string", network(degraded=[["2", 1, 0.5, 0.1]])),  # accepted
        ("a degraded link's sender is a float", network(degraded=[[2.5, 1, 0.5, 0.1]])),  # accepted as 2
        ("a degraded link's receiver is a bool", network(degraded=[[2, True, 0.5, 0.1]])),  # accepted as 1
        ("silent holds a string", network(silent=["3"])),  # accepted, entry dropped
        ("silent holds a float", network(silent=[3.0])),  # accepted, entry dropped
        ("silent holds a bool", network(silent=[True])),  # accepted, entry dropped
        ("silent holds None", network(silent=[3, None])),  # accepted, entry dropped
    ]


def event_cases() -> list[tuple[str, Message]]:
    cases = [(f"missing {name}", without(VALID_EVENT, name)) for name in ("t", "sender", "receiver", "seq", "kind")]
    cases += [
        ("kind is unknown", with_(VALID_EVENT, kind="lost")),
        ("kind is None", with_(VALID_EVENT, kind=None)),
        ("kind is a number", with_(VALID_EVENT, kind=1)),
        ("kind is a list", with_(VALID_EVENT, kind=["sent"])),
        ("t is nan", with_(VALID_EVENT, t=NAN)),
        ("t is inf", with_(VALID_EVENT, t=INF)),
        ("t is a bool", with_(VALID_EVENT, t=True)),
        ("t is a string", with_(VALID_EVENT, t="1.25")),
        ("sender is a bool", with_(VALID_EVENT, sender=True)),
        ("sender is a float", with_(VALID_EVENT, sender=1.0)),
        ("receiver is a string", with_(VALID_EVENT, receiver="2")),
        ("receiver is None", with_(VALID_EVENT, receiver=None)),
        ("seq is a float", with_(VALID_EVENT, seq=3.0)),
        ("seq is a bool", with_(VALID_EVENT, seq=False)),
        ("delay is nan", with_(VALID_EVENT, delay=NAN)),
        ("delay is -inf", with_(VALID_EVENT, delay=-INF)),
        ("delay is a string", with_(VALID_EVENT, delay="0.25")),
        ("delay is a bool", with_(VALID_EVENT, delay=True)),
        ("reason is a number", with_(VALID_EVENT, reason=1)),
        ("reason is a bool", with_(VALID_EVENT, reason=False)),
        ("reason is a list", with_(VALID_EVENT, reason=["loss"])),
    ]
    return cases


Parser = Callable[[Message], object]
PARSERS: dict[str, Parser] = {
    "tx": lambda m: parse_tx(m, 2),
    "state": lambda m: parse_state(m, 4),
    "rx": parse_rx,
    "tick": parse_tick,
    "event": parse_event,
}
VALID = {"tx": VALID_TX, "state": VALID_STATE, "rx": VALID_RX, "tick": VALID_TICK, "event": VALID_EVENT}
CASES = [
    pytest.param(kind, message, id=f"{kind}: {name}")
    for kind, cases in (
        ("tx", tx_cases()),
        ("state", state_cases()),
        ("rx", rx_cases()),
        ("tick", tick_cases()),
        ("event", event_cases()),
    )
    for name, message in cases
]
CASES += [pytest.param("tick", message, id=f"tick: {name}") for name, message in tick_network_bug_cases()]


def test_the_valid_baselines_parse():
    for kind, valid in VALID.items():
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
        ("tx", with_(VALID_TX, stamp=10**400)),
        ("tick", with_(VALID_TICK, t=10**400)),
        ("tick", with_(VALID_TICK, vehicles=[with_(VALID_TICK["vehicles"][0], cap=-(10**400))])),
        ("tick", with_(VALID_TICK, vehicles=[with_(VALID_TICK["vehicles"][0], skew=10**400)])),
        ("tick", with_(VALID_TICK, network=with_(VALID_TICK["network"], degraded=[[2, 1, 0.5, 10**400]]))),
        ("state", with_(VALID_STATE, rotation=[10**400] * 9)),
        ("event", with_(VALID_EVENT, delay=10**400)),
    ],
    ids=["tx", "tx stamp", "tick t", "tick cap", "tick skew", "tick degraded delay", "state", "event"],
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


def mutations(valid: Message, deep: bool = True) -> st.SearchStrategy[Message]:
    """The valid message with up to three fields dropped or replaced, and maybe extra fields. A list of maps
    (receptions, disturbed vehicles) or of lists (links) gets mutated items too; with deep, a map (the network) gets
    mutated fields."""
    replacement: dict[str, st.SearchStrategy[Any]] = {name: NEAR_MISSES | st.just(DROP) for name in valid}
    for name, value in valid.items():
        if isinstance(value, list) and value and isinstance(value[0], dict):
            maps = st.lists(mutations(value[0], deep) | JSON_VALUES, min_size=1, max_size=3)
            replacement[name] = maps | replacement[name]
        elif isinstance(value, list) and value and isinstance(value[0], list):
            width = len(value[0])
            items = st.lists(NUMBERISH, min_size=width - 1, max_size=width + 1) | JSON_VALUES
            replacement[name] = st.lists(items, min_size=1, max_size=3) | replacement[name]
        elif isinstance(value, dict) and deep:
            replacement[name] = mutations(value, deep) | replacement[name]
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


def assert_value_error_only(kind: str, message: Message) -> None:
    accepted = succeeds_or_value_error(PARSERS[kind], message)
    assert succeeds_or_value_error(PARSERS[kind], wire(message)) == accepted
    event("accepted" if accepted else "rejected")


@pytest.mark.parametrize("kind", sorted(VALID))
@settings(max_examples=150, deadline=None, database=None)
@given(data=st.data())
def test_parsers_succeed_or_raise_value_error_only(kind, data):
    # the tick's network is replaced whole here; its fields are mutated by the next test
    shapes = mutations(VALID[kind], deep=kind != "tick")
    message = data.draw(shapes | st.dictionaries(st.text(max_size=8), JSON_VALUES, max_size=6))
    assert_value_error_only(kind, message)


@settings(max_examples=150, deadline=None, database=None)
@given(network=mutations(VALID_TICK["network"]))
@example(
    network=with_(VALID_TICK["network"], degraded=[[None, 1, 0.5, 0.1]])
)  # a degraded link whose sender is not an id
def test_parse_tick_of_any_network_succeeds_or_raises_value_error_only(network):
    assert_value_error_only("tick", with_(VALID_TICK, network=network))


@pytest.mark.parametrize(
    ("name", "value"), [("gamma", 1e39), ("gamma_dot", -1e39), ("t", -1.0)], ids=["gamma", "gamma_dot", "t"]
)
def test_parse_tx_rejects_what_the_wire_frame_cannot_carry(name, value):
    message = with_(VALID_TX, **{name: value})
    with pytest.raises(ValueError):
        parse_tx(message, 2)


def test_a_vehicle_reads_only_its_own_packed_batch_and_refuses_garbage():
    tick = tick_message(3, 0.3, False)
    mine = Reception(2, 1, 5, 0.2, 0.25, 10.5, 0.99)
    message = wire(batches_message(tick, {2: [mine], 3: []}))
    assert parse_batches(message, 2) == (parse_tick(tick), rx_message(2, 3, 0.3, [mine]))
    assert parse_batches(message, 3)[1] == rx_message(3, 3, 0.3, [])
    assert parse_batches(message, 9)[1] == rx_message(9, 3, 0.3, [])  # nothing for a vehicle it does not name
    assert parse_batches(wire(batches_message(tick, None)), 2)[1] is None  # the broker is down
    for rx in ([[2, []]], {2: b"\xc1garbage"}, {2: encode({"not": "a list"})}, {2: "text"}):
        with pytest.raises(ValueError):
            parse_batches(message | {"rx": rx}, 2)
