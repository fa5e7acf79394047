"""The broker over a lockstep span (no Zenoh, comms.broker.span): one grant of steps a .. c-1 and the broker issues each
step's tick itself, handing out exactly what the supervisor's ticks one step at a time did (the same batches
messages, ticks in them included, and the same link events); its windows come from the vehicles' fresh reports."""

from __future__ import annotations

import msgspec

from comms.records.messages import (
    COMMS_EVENTS_KEY,
    COMMS_STEP_KEY,
    TICK_KEY,
    encode,
    state_key,
    step_message,
    tick_message,
)
from comms.records.messages import tx_message as tx_wire
from tests.test_broker_integration import DT, IDS, Fleet, fleet, pure_broker, state_message  # noqa: F401

STEPS = 12


def report(broker, fleet: Fleet, k: int, next_tx: int | None, seq: int | None) -> None:  # noqa: F811
    """Every vehicle's step message of step k (a transmission numbered seq, unless None), saying next_tx."""
    for vid in IDS:
        telemetry, model, sent = fleet[vid]
        tx = tx_wire(msgspec.structs.replace(sent, seq=seq, t=k * DT, stamp=k * DT)) if seq is not None else None
        message = step_message(state_message(telemetry, model, k, seq or 0), tx, None, next_tx)
        broker.take(state_key(vid), encode(message))
    broker.advance()


def published(pubs, key: str) -> list:
    return [m for k, m in pubs.messages if k == key]


def test_a_span_hands_out_what_the_supervisor_s_ticks_one_by_one_did(fleet: Fleet) -> None:  # noqa: F811
    runs = []
    for granted in (False, True):
        broker, pubs = pure_broker()
        if granted:
            broker.take(TICK_KEY, encode(tick_message(0, 0.0, False, span=STEPS, longest=100)))
        for k in range(STEPS):
            if not granted:
                broker.take(TICK_KEY, encode(tick_message(k, k * DT, False)))
            broker.advance()
            report(broker, fleet, k, k + 1, seq=k + 1)  # transmitting at every step: windows of one step
        runs.append((published(pubs, COMMS_STEP_KEY), published(pubs, COMMS_EVENTS_KEY)))
        assert broker.next_k == STEPS
    (steps, events), (spanned, spanned_events) = runs
    assert len(steps) == STEPS and spanned == steps and spanned_events == events and events


def test_inside_a_span_the_broker_grants_windows_up_to_the_next_transmission(fleet: Fleet) -> None:  # noqa: F811
    broker, pubs = pure_broker()
    broker.take(TICK_KEY, encode(tick_message(0, 0.0, False, span=STEPS, longest=100, hold=True)))
    broker.advance()
    report(broker, fleet, 0, 5, seq=1)  # nobody may transmit before step 5: steps 1 .. 5 in one window
    report(broker, fleet, 5, 50, seq=2)  # then nothing before the span's end (the run's change at step 12)
    ticks = [m["tick"] for m in published(pubs, COMMS_STEP_KEY)]
    assert [(t["k"], t.get("until")) for t in ticks] == [(0, None), (1, 6), (6, STEPS)]
    assert [t["hold"] for t in ticks] == [False, False, True]  # the span's last step holds its packets
    assert all("span" not in t and "longest" not in t for t in ticks)
    assert broker.next_k == STEPS  # and waits for the supervisor's next grant
    report(broker, fleet, STEPS - 1, 50, seq=None)
    assert broker.next_k == STEPS
