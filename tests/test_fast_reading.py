"""msgspec reads the records of the bus (comms.records.fields.read_as): whatever a decoder gives, a record reads
whole, writing back what it read, or is refused with a reason. Each message here is a valid one with a field
replaced (by any value a decoder could give: null, bools, integers of any size, floats with NaN and infinities,
strings, lists, maps), a list item replaced or a field removed."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from comms.records.fields import MAX_FLOAT32, MAX_TIME
from comms.records.messages import step_message
from comms.records.receptions import Delivery, RxBatch
from comms.records.records import Transmission
from comms.records.state import StateReport

from .test_state_report import REPORT

BOUNDARIES = [0.0, -0.0, 1, -1, 2**63, -(2**63), 2**63 - 1, 2**64, 10**400, MAX_TIME, MAX_TIME * 1.0001, MAX_FLOAT32,
              MAX_FLOAT32 * 1.0001, sys.float_info.max, math.inf, -math.inf, math.nan, 1e-300, 150.0]  # fmt: skip
SCALARS = st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=2) | st.sampled_from(BOUNDARIES)
NUMBERS = st.floats() | st.integers(-(2**70), 2**70) | st.sampled_from(BOUNDARIES)
VALUES = st.recursive(
    SCALARS | st.lists(NUMBERS, min_size=2, max_size=10),
    lambda inner: st.lists(inner, max_size=10) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)
TX = Transmission(3, 9, 12.5, 4.25, 0.98, (1.0, -2.0, 3.0), (1.2, 0.1, 0.0), 12.75).to_message()
RX = RxBatch(0.4, 4, 2, (Delivery(1, 4, 0.3, 0.31, 5.0, 1.0, 100.31), Delivery(3, 2, 0.2, 0.3, 4.0, 0.9))).to_message()
REALTIME = {**REPORT.to_message(), "rx_lateness": [-0.004, 0.002], "step_lateness": 0.0005}


def outcome(read: Callable[[Any], Any], message: Any) -> str:
    """What a reading gives, comparable: the record's type and the JSON it writes (1 and 1.0 differ), or refusal."""
    try:
        record = read(message)
    except ValueError:
        return "refused"
    return f"{type(record).__name__} {json.dumps(record.to_message())}"


@st.composite
def altered(draw: st.DrawFn, message: dict[str, Any]) -> dict[str, Any]:
    """message with one field replaced or removed, or an item of one of its lists (or of a map in it) replaced."""
    out = json.loads(json.dumps(message))
    name = draw(st.sampled_from([*out, "tx", "extra"]))
    how = draw(st.sampled_from(["replace", "remove", "item"]))
    if how == "remove":
        out.pop(name, None)
    elif how == "item" and isinstance(out.get(name), list) and out[name]:
        items = out[name]
        i = draw(st.integers(0, len(items) - 1))
        if isinstance(items[i], dict | list) and draw(st.booleans()):
            j = draw(st.sampled_from(list(items[i]) if isinstance(items[i], dict) else list(range(len(items[i])))))
            items[i][j] = draw(VALUES)
        else:
            items[i] = draw(VALUES)
    else:
        out[name] = draw(VALUES)
    return out


@settings(max_examples=400, deadline=None)
@given(altered(REPORT.to_message()) | altered(REALTIME) | altered(step_message(REPORT.to_message(), TX, RX)))
def test_a_state_is_read_whole_or_refused_with_a_reason(message):
    """The state has one description (comms.records.state.StateReport, msgspec reads it): whatever a decoder gives, it
    reads as a report that writes back what it read, or is refused with a ValueError that says why."""
    try:
        report = StateReport.from_message(message, 3)
    except ValueError as exc:
        assert str(exc)
        return
    again = StateReport.from_message(report.to_message(), 3)
    assert json.dumps(again.to_message()) == json.dumps(report.to_message())  # NaN is not NaN: compared as written


def test_an_older_logs_state_reads_as_today():
    """Logs before the viewers' schemas (issue 25) have estimate ages as [vehicle, age] pairs."""
    older = {**REPORT.to_message(), "estimate_age": [[1, 0.5], [2, 1.25]]}
    assert StateReport.from_message(older, 3) == REPORT


@pytest.mark.parametrize(
    "change",
    [
        {"gamma": 2**63},  # beyond int64
        {"rotation": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.1]},
        {"velocity": [150.0, 0.0, 0.0]},
        {"vehicle": 4},  # not the key's
        {"t": math.nan},
        {"estimate_age": [[1, 0.5], [2, 0.25, 3]]},  # not even the form of older logs (pairs)
    ],
)
def test_what_a_state_may_not_say_is_refused(change):
    with pytest.raises(ValueError, match=next(iter(change)) if "vehicle" not in change else "vehicle 4"):
        StateReport.from_message({**REPORT.to_message(), **change}, 3)


@settings(max_examples=300, deadline=None)
@given(altered(TX) | altered({k: v for k, v in TX.items() if k != "stamp"}))
@example({**TX, "stamp": TX["t"]})
def test_a_transmission_is_read_whole_or_refused_with_a_reason(message):
    """The transmission has one description (comms.records.records.Transmission, msgspec reads it): read, it writes
    back what it read, a stamp always (t where the message had none), or is refused with a ValueError that says why."""
    try:
        tx = Transmission.from_message(message, 3)
    except ValueError as exc:
        assert str(exc)
        return
    again = Transmission.from_message(tx.to_message(), 3)
    assert json.dumps(again.to_message()) == json.dumps(tx.to_message()) and "stamp" in tx.to_message()


@pytest.mark.parametrize(
    ("change", "field"),
    [({"stamp": None}, "stamp"), ({"seq": -1}, "seq"), ({"t": MAX_TIME * 1.0001}, "t"), ({"sender": 4}, "sender"),
     ({"gamma": MAX_FLOAT32 * 1.0001}, "gamma"), ({"velocity": [150.0, 0.0, 0.0]}, "velocity"), ({"t": True}, "t")],
)  # fmt: skip
def test_what_a_transmission_may_not_say_is_refused(change, field):
    """null is not a missing stamp; the modem frame carries no negative sequence number, no time past its clock, no
    gamma beyond float32; the sender owns its key; no vehicle is that fast."""
    with pytest.raises(ValueError, match=f"'{field}'"):
        Transmission.from_message({**TX, **change}, 3)


@settings(max_examples=300, deadline=None)
@given(altered(RX) | altered(RX["receptions"][0]) | altered(RX["receptions"][1]))
@example({**RX, "receptions": [{**RX["receptions"][0], "due": None}]})
def test_a_reception_batch_is_read_whole_or_refused_with_a_reason(message):
    """The batch and its receptions have one description each (msgspec Structs): read, they write back what they
    read, or are refused with a ValueError that says why."""
    kind: Any = Delivery if "sender" in message else RxBatch
    try:
        record = kind.from_message(message)
    except ValueError as exc:
        assert str(exc)
        return
    again = kind.from_message(record.to_message())
    assert json.dumps(again.to_message()) == json.dumps(record.to_message())


@pytest.mark.parametrize(
    "change",
    [{"t": "0.4"}, {"k": 1.5}, {"vehicle": True}, {"receptions": [{"sender": 1}]},
     {"receptions": [{"sender": 1, "seq": 4, "stamp": 0.3, "arrival": math.inf, "gamma": 5.0, "gamma_dot": 1.0}]}],
)  # fmt: skip
def test_what_a_reception_batch_may_not_say_is_refused(change):
    with pytest.raises(ValueError, match=r"\$\."):
        RxBatch.from_message({**RX, **change})
