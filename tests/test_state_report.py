"""Each message described once: a record (frozen dataclass), its wire form, its reading and its JSON schema agree.

Started with comms.records.state.StateReport; the other records of the bus follow the same checks (RECORDS below)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import msgspec
import pytest

from comms.records.bounded import cause_of
from comms.records.events import LinkEvents
from comms.records.messages import Hello, decode, encode, rx_message, state_key, step_message, tick_message
from comms.records.network import Network
from comms.records.receptions import Delivery, RxBatch
from comms.records.records import Disturbances, LinkEvent, Reception, Transmission
from comms.records.reports import CommsDone, CommsStats, LinkCounts, VehicleDone
from comms.records.run import FaultEvent, Graph, Stop, links
from comms.records.schemas import (
    COMMS_DONE,
    COMMS_STATS,
    FAULT,
    GRAPH,
    HELLO,
    LINK_EVENT,
    LINK_EVENTS,
    META,
    RECEPTIONS,
    STATE,
    STOP,
    TICK,
    TRANSMISSION,
    VEHICLE_DONE,
    schema_for,
)
from comms.records.state import NeighbourAge, StateReport
from comms.records.stream import NOT_FINITE
from comms.records.tick import DisturbedVehicle, Tick
from supervisor.record.meta import RunMeta
from vehicles.dynamics import PLANAR, SPATIAL
from vehicles.report import state_message

from .test_messages import turning_telemetry

REPORT = StateReport(
    12.5, 7, 3, 4.25, 0.98, (1.0, -2.0, 3.0), (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (1.2, 0.1, 0.0),
    (0.0, 0.0, 0.3), (0.5, -0.25, 0.0), (10.0, 3.0), -0.02, 0.75, 6, (NeighbourAge(1, 0.5), NeighbourAge(2, 1.25)),
)  # fmt: skip


def test_the_schema_describes_exactly_the_fields_of_the_record():
    names = {f.name for f in msgspec.structs.fields(StateReport)}
    assert set(STATE["properties"]) == names
    optional = {f.name for f in msgspec.structs.fields(StateReport) if f.default is None}
    assert set(STATE["required"]) == names - optional
    assert schema_for(state_key(3)) is STATE


@pytest.mark.parametrize(
    "report",
    [REPORT, msgspec.structs.replace(REPORT, rx_lateness=(-0.004, 0.002), step_lateness=0.0005)],
    ids=["lockstep", "realtime"],
)
def test_reading_is_the_inverse_of_writing(report):
    message = report.to_message()
    assert list(message) == list(STATE["properties"])[: len(message)]  # the schema's order, optional fields last
    assert StateReport.from_message(decode(encode(message)), 3) == report
    assert StateReport.from_message(message, 3).to_message() == message


@pytest.mark.parametrize("model", [SPATIAL, PLANAR], ids=["spatial", "planar"])
def test_a_vehicle_state_message_reads_back_to_the_same_message(model):
    message = state_message(turning_telemetry(model), model, 5, 2, ages=(NeighbourAge(1, 0.25),))
    report = StateReport.from_message(decode(encode(message)), 4)
    assert report.to_message() == message
    assert (report.k, report.tx_seq, report.estimate_age) == (5, 2, (NeighbourAge(1, 0.25),))
    # a step message carries tx and rx around the state: they are not the state's
    assert StateReport.from_message(step_message(message, None, None), 4) == report


@pytest.mark.parametrize(
    "field", ["gamma", "gamma_dot", "lyapunov", "correction", "tau", "error", "estimate_age", "position", "velocity"]
)
@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf], ids=["nan", "inf", "-inf"])
def test_a_state_with_a_non_finite_number_anywhere_is_dropped_as_not_finite(field: str, value: float) -> None:
    """A NaN or an infinity, in a diagnostic as in the kinematics, is dropped with its cause (issue 31): the log
    could only write it as null, and no neighbour or figure could use it."""
    message = REPORT.to_message()
    held = message[field]
    message[field] = (
        [{**held[0], "age": value}]
        if field == "estimate_age"
        else [value, *held[1:]]
        if isinstance(held, list)
        else value
    )
    with pytest.raises(ValueError, match=field) as refused:
        StateReport.from_message(message, 3)
    assert cause_of(refused.value) == NOT_FINITE


def test_the_transmission_schema_describes_exactly_the_fields_of_the_record():
    assert set(TRANSMISSION["properties"]) == {f.name for f in msgspec.structs.fields(Transmission)}
    assert set(TRANSMISSION["required"]) == set(TRANSMISSION["properties"])  # stamp is always written


@pytest.mark.parametrize("stamp", [msgspec.UNSET, 12.75], ids=["own clock", "skewed clock"])
def test_reading_a_transmission_is_the_inverse_of_writing_it(stamp):
    tx = Transmission(3, 9, 12.5, 4.25, 0.98, (1.0, -2.0, 3.0), (1.2, 0.1, 0.0), stamp)
    message = tx.to_message()
    assert Transmission.from_message(decode(encode(message)), 3) == tx
    assert Transmission.from_message(message, 3).to_message() == message


RUN_META = RunMeta("paper", "configs/paper.toml", "[scenario]\n", {"scenario": {"name": "paper"}}, 7, "zenoh",
                   "lockstep", 0.1, 400.0, (1, 2, 3), links(((1, 2), (2, 1))), ({"kind": "speed_cap", "vehicle": 2},),
                   1.2, {"cpf-cosim": "0.1"})  # fmt: skip
NETWORK = Network.of(((1, 2), (2, 3)), frozenset({(2, 1)}), {(1, 3): (0.25, 0.5)}, False, frozenset({3}))
DELIVERY = Delivery(1, 4, 0.3, 0.31, 5.0, 1.0)
LINK_BOOKS = LinkCounts(1, 2, 30, 27, {"collision": 1, "loss": 2}, 0.25, 0.5)
# record -> (its schema, an example with every optional field set, one with none set, how to read a message)
RECORDS: dict[str, tuple[dict[str, Any], Any, Any, Callable[[Any], Any]]] = {
    "rx batch": (RECEPTIONS, RxBatch(0.4, 4, 2, (msgspec.structs.replace(DELIVERY, due=100.31),)),
                 RxBatch(0.4, 4, 2, ()), RxBatch.from_message),
    "reception": (RECEPTIONS["properties"]["receptions"]["items"], msgspec.structs.replace(DELIVERY, due=100.31),
                  DELIVERY, Delivery.from_message),
    "tick": (TICK, Tick.of(4, 0.4, True, {2: Disturbances(0.5, True, 0.1, 0.2)}, NETWORK, [1, 2], False, 99.5, 4.0,
                        True, 9, 20, 100), Tick.of(4, 0.4, False, {}, None, None, True), Tick.from_message),
    "disturbed vehicle": (TICK["properties"]["vehicles"]["items"],
                          DisturbedVehicle.of(2, Disturbances(0.5, True, 0.1, 0.2)),
                          DisturbedVehicle.of(2, Disturbances()), DisturbedVehicle.from_message),
    "network": (TICK["properties"]["network"], NETWORK, Network.of(()), Network.from_message),
    "link event": (LINK_EVENT, LinkEvent(1.25, 1, 2, 3, "dropped", 0.25, "collision"),
                   LinkEvent(1.25, 1, 2, 3, "sent"), LinkEvent.from_message),
    "hello": (HELLO, Hello("comms", "ab" * 32, {"comms": "cd" * 32}), Hello("comms", "ab" * 32, {}),
              Hello.from_message),
    "graph": (GRAPH, Graph.of(150.0, ((1, 2), (2, 1))), Graph(0.0, ()), Graph.from_message),
    "fault event": (FAULT, FaultEvent(150.0, "speed_cap", "start", {"vehicle": 2, "start": 150.0, "end": None}),
                    FaultEvent(250.0, "blackout", "end", {}), FaultEvent.from_message),
    "stop": (STOP, Stop(12.5, "end of run"), Stop(0.0, ""), Stop.from_message),
    "link events": (LINK_EVENTS, LinkEvents(0.2, 2, (LinkEvent(0.1, 1, 2, 3, "sent"),)), LinkEvents(0.2, 2, ()),
                    LinkEvents.from_message),
    "comms stats": (COMMS_STATS, CommsStats(t=10.0, window=10.0, horizon=36.0, lambda2=1.0, links=(LINK_BOOKS,)),
                    CommsStats(t=10.0, window=10.0, lambda2=0.0, links=()), CommsStats.from_message),
    "link books": (COMMS_STATS["properties"]["links"]["items"], LINK_BOOKS, LinkCounts(1, 2, 0, 0, {}),
                   LinkCounts.from_message),
    "comms done": (COMMS_DONE, CommsDone(400.0, 4000, 123, 2, {"replayed step": 2}, {"cpf/vehicle/2/state": 2}),
                   CommsDone(0.0, 0, 0, 0), CommsDone.from_message),
    "vehicle done": (VEHICLE_DONE, VehicleDone(400.0, 4000, 2, {"cpf/clock/tick": 1}, {"undecodable": 1}),
                     VehicleDone(0.0, 0, 2, {}), lambda m: VehicleDone.from_message(m, 2)),
    "run meta": (META, RUN_META, msgspec.structs.replace(RUN_META, vehicles=(), links=(), faults=(), versions={}),
                 RunMeta.from_message),
}  # fmt: skip


# Fields the message always carries that older logs lack: required in the schema, read as their default without.
OLDER_LOGS_LACK = {"tick": {"speed", "hold"}}  # from before realtime delivery: lockstep


def wire_names(record: Any) -> set[str]:
    renamed = getattr(record, "WIRE_NAMES", {})
    if issubclass(record, msgspec.Struct):  # a struct's fields as its message names them
        return {f.encode_name for f in msgspec.structs.fields(record)}
    names = [f.name for f in dataclasses.fields(record)]
    return {renamed.get(name, name) for name in names}


@pytest.mark.parametrize("name", list(RECORDS))
def test_each_schema_describes_exactly_the_fields_of_its_record(name):
    """Properties: the record's fields, all written when set, the required ones always; required: what the reader
    refuses a message without (the optional ones it reads as their default)."""
    schema, full, bare, read = RECORDS[name]
    assert set(schema["properties"]) == wire_names(type(full))
    assert set(full.to_message()) == set(schema["properties"])
    assert set(bare.to_message()) >= set(schema["required"])
    message = full.to_message()
    for field in schema["properties"]:
        without = {k: v for k, v in message.items() if k != field}
        if field in schema["required"] and field not in OLDER_LOGS_LACK.get(name, set()):
            with pytest.raises(ValueError, match=field):
                read(without)
        else:
            read(without)


@pytest.mark.parametrize("name", list(RECORDS))
@pytest.mark.parametrize("which", ["full", "bare"])
def test_reading_each_record_is_the_inverse_of_writing_it(name, which):
    _, full, bare, read = RECORDS[name]
    record = full if which == "full" else bare
    message = record.to_message()
    assert read(decode(encode(message))) == record
    assert read(message).to_message() == message


# messages as the builders the engines call write them
RECORDED: dict[str, tuple[dict[str, Any], Callable[[Any], Any]]] = {
    "rx": (rx_message(2, 5, 0.5, [Reception(2, 1, 5, 0.4, 0.42, 10.5, 0.99)]), RxBatch.from_message),
    "realtime rx": (rx_message(2, 5, 0.42, [Reception(2, 1, 5, 0.4, 0.42, 10.5, 0.99)], lambda t: 100.0 + t),
                    RxBatch.from_message),
    "tick": (tick_message(3, 0.3, False, {1: Disturbances(0.5)}, NETWORK, [1, 2], comms=False), Tick.from_message),
    "realtime tick": (tick_message(30, 3.0, False, wall=1_000_000.0, speed=4.0, hold=True), Tick.from_message),
}  # fmt: skip


@pytest.mark.parametrize("name", list(RECORDED))
def test_a_recorded_message_reads_back_to_the_same_message(name):
    message, read = RECORDED[name]
    assert read(decode(encode(message))).to_message() == message
    assert encode(read(decode(encode(message))).to_message()) == encode(message)  # the same bytes


def test_a_tick_from_before_realtime_delivery_reads_as_lockstep():
    old = {k: v for k, v in tick_message(3, 0.3, False).items() if k not in ("wall", "speed", "hold")}
    assert Tick.from_message(old) == Tick.of(3, 0.3, False, {}, None, None, True)


@pytest.mark.parametrize(("field", "value"), [("arrival", math.nan), ("arrival", "0.3"), ("seq", 1.5), ("due", "x")])
def test_a_reception_is_checked_whole(field, value):
    """Every field of a reception is checked, not only what the vehicle computes with (arrival and seq were not)."""
    message = rx_message(2, 5, 0.42, [Reception(2, 1, 5, 0.4, 0.42, 10.5, 0.99)], lambda t: 100.0 + t)
    message["receptions"][0][field] = value
    with pytest.raises(ValueError, match=field):
        RxBatch.from_message(message)


def test_a_tick_of_an_older_log_reads_as_today():
    """Logs before the viewers' schemas (issue 25) have nulls for what says nothing, links as [sender, receiver]
    pairs and degraded links as [sender, receiver, loss, delay]."""
    today = Tick.of(3, 0.3, False, {1: Disturbances(0.5), 2: Disturbances(None, True)}, NETWORK, None, True)
    older = {**today.to_message(), "alive": None, "wall": None, "until": None,
             "vehicles": [{**entry, "cap": entry.get("cap")} for entry in today.to_message()["vehicles"]],
             "network": {"edges": [[1, 2], [2, 3]], "down": [[2, 1]], "degraded": [[1, 3, 0.25, 0.5]],
                         "blackout": False, "silent": [3]}}  # fmt: skip
    assert Tick.from_message(older) == today
    assert Tick.from_message({**older, "network": None}) == msgspec.structs.replace(today, network=None)
    with pytest.raises(ValueError, match="'network'"):  # not even the older form
        Tick.from_message({**older, "network": {**older["network"], "degraded": [[1, 3, 0.25]]}})
