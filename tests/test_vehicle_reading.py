"""The vehicle's reading of the broker's batches message (comms.records.bus_records.read_batches, the slow way only
where msgspec refuses): what it files is what the slow reading alone files, on any message (but for what msgspec skips
unchecked with an unknown field: comms.records.bus_records); nothing of a message it drops is filed; a good one never
takes the slow way."""

from __future__ import annotations

import copy
from typing import Any
from unittest.mock import patch

import msgpack
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from comms.records.messages import COMMS_STEP_KEY, batches_message, encode, encode_list, state_key, tick_message
from comms.records.receptions import Delivery
from tests.test_bus_records import VALUES, altered
from tests.test_vehicle_node import DT, VID, serve_one, vehicle
from vehicles import node as node_module

DELIVERY = Delivery(1, 4, 0.1, 0.15, 5.0, 1.0).to_message()
TICK = tick_message(2, 2 * DT, False)
WINDOW_TICK = tick_message(2, 2 * DT, False, until=5)


def batches(tick: dict[str, Any], mine: list[Any]) -> dict[str, Any]:
    """A batches message whose receptions for VID are mine (packed as the broker packs them), vehicle 3's one."""
    other = [DELIVERY] if "until" not in tick else [[DELIVERY], [], []]
    return {"t": tick["t"], "k": tick["k"], "tick": tick, "rx": {VID: encode_list(mine), 3: encode_list(other)}}


ONE = batches(TICK, [DELIVERY, {**DELIVERY, "sender": 3, "seq": 5}])
WINDOW = batches(WINDOW_TICK, [[DELIVERY], [], [DELIVERY, {**DELIVERY, "seq": 5}]])


def packed(value: object) -> bytes:
    """Any value packed as the broker packs a vehicle's receptions (comms.records.messages.encode_list)."""
    data: bytes = msgpack.packb(value, use_bin_type=True)
    return data


@st.composite
def packed_altered(draw: st.DrawFn, message: dict[str, Any]) -> dict[str, Any]:
    """message with VID's packed receptions altered anywhere (altered, on the unpacked list), or the message itself."""
    out = copy.deepcopy(message)
    mine = msgpack.unpackb(out["rx"][VID], raw=False)
    if mine and draw(st.booleans()):
        out["rx"][VID] = packed(draw(altered({"r": mine})).get("r"))  # (the list itself may go: then None)
    elif draw(st.booleans()):
        out["rx"][VID] = draw(st.sampled_from([b"\xc1", packed(draw(VALUES)), b""]))
    return out


def filed(payload: bytes, typed: bool) -> str:
    """What a vehicle holds after payload on the batches key, and what it dropped (repr: NaN is not NaN)."""
    node, _ = vehicle()
    with patch.object(node_module, "read_batches", node_module.read_batches if typed else lambda *_: None):
        node(COMMS_STEP_KEY, payload)
    p = node.pending
    return repr((p.ticks, p.start_at, p.batches, p.drops.by_key, p.drops.by_cause, p.drops.last))


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(altered(ONE) | altered(WINDOW) | packed_altered(ONE) | packed_altered(WINDOW))
@example(ONE)
@example(WINDOW)
@example({**ONE, "rx": None})  # the broker is down
@example({**ONE, "rx": {3: ONE["rx"][3]}})  # nothing for VID
@example({**ONE, "rx": {VID: ONE["rx"][VID], 3: "x"}})  # another vehicle's part malformed: not VID's business
@example({**WINDOW, "rx": {3: WINDOW["rx"][3]}})
@example(batches(WINDOW_TICK, [[DELIVERY], []]))  # a list short of the window
@example(batches(TICK, [{**DELIVERY, "sender": "x"}]))
@example(batches(WINDOW_TICK, [[], [], [{**DELIVERY, "gamma": float("nan")}]]))
@example({**ONE, "tick": {**TICK, "until": 2}})  # a window that ends where it starts
def test_a_batches_message_is_filed_the_same_either_way(message: dict[str, Any]) -> None:
    payload = encode(message)
    assert filed(payload, True) == filed(payload, False)


def test_good_messages_are_read_in_one_pass(monkeypatch: Any) -> None:
    def slow(_: bytes) -> dict[str, Any]:
        raise AssertionError("read the slow way")

    monkeypatch.setattr(node_module, "decode", slow)
    for message in (ONE, WINDOW, {**ONE, "rx": None}):
        node, _ = vehicle()
        node(COMMS_STEP_KEY, encode(message))
        assert node.pending.drops.total == 0 and 2 in node.pending.ticks


def test_a_dropped_batches_message_leaves_nothing_filed() -> None:
    """A tick whose receptions for the vehicle do not read (at any step of its window) is dropped whole: its tick was
    filed without its batch, and the vehicle then stepped on it and found no batch (KeyError: the process ended)."""
    first, window = tick_message(0, 0.0, False), tick_message(0, 0.0, False, until=3)
    for message in (batches(first, [{**DELIVERY, "sender": "x"}]), batches(window, [[DELIVERY], [], [{}]])):
        node, pubs = vehicle()
        serve_one(node, COMMS_STEP_KEY, encode(message))
        assert node.pending.drops.total == 1 and not node.pending.ticks and not node.pending.batches
        assert not [m for key, m in pubs.messages if key == state_key(VID)]  # it did not step
        serve_one(node, COMMS_STEP_KEY, encode(batches_message(first, {VID: []})))
        assert [m["k"] for key, m in pubs.messages if key == state_key(VID)] == [0]  # and steps on a good one
