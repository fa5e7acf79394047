"""The state report described once: comms.state.StateReport, its wire form, its reading and its JSON schema agree."""

from __future__ import annotations

import dataclasses
import math

import pytest

from comms.messages import decode, encode, state_key, step_message
from comms.records import Transmission
from comms.schemas import STATE, TRANSMISSION, schema_for
from comms.state import StateReport
from vehicles.dynamics import PLANAR, SPATIAL
from vehicles.report import state_message

from .test_messages import turning_telemetry

REPORT = StateReport(
    12.5, 7, 3, 4.25, 0.98, (1.0, -2.0, 3.0), (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (1.2, 0.1, 0.0),
    (0.0, 0.0, 0.3), (0.5, -0.25, 0.0), (10.0, 3.0), -0.02, 0.75, 6, ((1, 0.5), (2, 1.25)),
)  # fmt: skip


def test_the_schema_describes_exactly_the_fields_of_the_record():
    names = {f.name for f in dataclasses.fields(StateReport)}
    assert set(STATE["properties"]) == names
    optional = {f.name for f in dataclasses.fields(StateReport) if f.default is None}
    assert set(STATE["required"]) == names - optional
    assert schema_for(state_key(3)) is STATE


@pytest.mark.parametrize(
    "report",
    [REPORT, dataclasses.replace(REPORT, rx_lateness=(-0.004, 0.002), step_lateness=0.0005)],
    ids=["lockstep", "realtime"],
)
def test_reading_is_the_inverse_of_writing(report):
    message = report.to_message()
    assert list(message) == list(STATE["properties"])[: len(message)]  # the schema's order, optional fields last
    assert StateReport.from_message(decode(encode(message)), 3) == report
    assert StateReport.from_message(message, 3).to_message() == message


@pytest.mark.parametrize("model", [SPATIAL, PLANAR], ids=["spatial", "planar"])
def test_a_vehicle_state_message_reads_back_to_the_same_message(model):
    message = state_message(turning_telemetry(model), model, 5, 2, ages=((1, 0.25),))
    report = StateReport.from_message(decode(encode(message)), 4)
    assert report.to_message() == message
    assert (report.k, report.tx_seq, report.estimate_age) == (5, 2, ((1, 0.25),))
    # a step message carries tx and rx around the state: they are not the state's
    assert StateReport.from_message(step_message(message, None, None), 4) == report


def test_the_diagnostics_need_not_be_finite_but_the_kinematics_must():
    """A diverging controller's Lyapunov value is still reported; a position the channel cannot use is not."""
    diverged = dataclasses.replace(REPORT, lyapunov=math.inf, tau=(math.nan, 0.0)).to_message()
    assert StateReport.from_message(diverged, 3).lyapunov == math.inf
    with pytest.raises(ValueError, match="not finite"):
        StateReport.from_message({**diverged, "position": [math.nan, 0.0, 0.0]}, 3)


def test_the_transmission_schema_describes_exactly_the_fields_of_the_record():
    assert set(TRANSMISSION["properties"]) == {f.name for f in dataclasses.fields(Transmission)}
    assert set(TRANSMISSION["required"]) == set(TRANSMISSION["properties"])  # stamp is always written


@pytest.mark.parametrize("stamp", [None, 12.75], ids=["own clock", "skewed clock"])
def test_reading_a_transmission_is_the_inverse_of_writing_it(stamp):
    tx = Transmission(3, 9, 12.5, 4.25, 0.98, (1.0, -2.0, 3.0), (1.2, 0.1, 0.0), stamp)
    message = tx.to_message()
    assert Transmission.from_message(decode(encode(message)), 3) == tx
    assert Transmission.from_message(message, 3).to_message() == message
