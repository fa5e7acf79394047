"""The broker over a lockstep span (no Zenoh, comms.broker.span): one grant of steps a .. c-1 and the broker issues each
step's tick itself, handing out exactly what the supervisor's ticks one step at a time did (the same batches
messages, ticks in them included, and the same link events); its windows come from the vehicles' fresh reports."""

from __future__ import annotations

import msgspec
import pytest

from comms.records.messages import (
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    COMMS_STEP_KEY,
    TICK_KEY,
    encode,
    parse_window,
    state_key,
    step_message,
    tick_message,
    window_message,
)
from comms.records.messages import tx_message as tx_wire
from tests.test_broker_integration import DT, IDS, Fleet, fleet, pure_broker, state_message  # noqa: F401

STEPS = 12


def report(broker, fleet: Fleet, k: int, next_tx: int | None, seq: int | None, since: int | None = None) -> None:  # noqa: F811
    """Every vehicle's step message of step k (a transmission numbered seq, unless None), saying next_tx; since: the
    first step of the window k ends (its earlier steps' states carried as a vehicle carries them), else k alone."""
    for vid in IDS:
        telemetry, model, sent = fleet[vid]
        tx = tx_wire(msgspec.structs.replace(sent, seq=seq, t=k * DT, stamp=k * DT)) if seq is not None else None
        earlier = [
            step_message(state_message(telemetry, model, j, 0), None, None)
            for j in range(k if since is None else since, k)
        ]
        message = step_message(state_message(telemetry, model, k, seq or 0), tx, None, next_tx, earlier)
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
    report(broker, fleet, 5, 50, seq=2, since=1)  # then nothing before the span's end (the run's change at step 12)
    ticks = [m["tick"] for m in published(pubs, COMMS_STEP_KEY)]
    assert [(t["k"], t.get("until")) for t in ticks] == [(0, None), (1, 6), (6, STEPS)]
    assert [t["hold"] for t in ticks] == [False, False, True]  # the span's last step holds its packets
    assert all("span" not in t and "longest" not in t for t in ticks)
    assert broker.next_k == STEPS  # and waits for the supervisor's next grant
    report(broker, fleet, STEPS - 1, 50, seq=None, since=6)
    assert broker.next_k == STEPS


# A slow link: 15-byte packets at 60 bit/s take 2 s (20 steps) on the air; the ideal modem's, neither half duplex
# nor collisions unless said. (The scenario's policy only passes validation: the test's vehicles send every step.)
SLOW = ("comms.bitrate=60",)
COLLIDING = (*SLOW, "comms.collisions=true", "comms.transmit.policy=event")
# Delay only: the ideal modem (no airtime), every link its own extra delay, the least 1.5 s (15 steps).
DELAYED = (
    "comms.links=[{sender=1,receiver=2,extra_delay=1.5},{sender=2,receiver=1,extra_delay=1.5},"
    "{sender=1,receiver=3,extra_delay=2.5},{sender=3,receiver=1,extra_delay=1.7}]",
)
LONG = 45


def received(pubs, vehicles=IDS) -> dict[tuple[int, int], dict]:
    """Every step's reception batch handed out, by (step, vehicle), whatever the windows."""
    out = {}
    for message in published(pubs, COMMS_STEP_KEY):
        for vid in vehicles:
            for batch in parse_window(message, vid, DT)[1] or []:
                out[batch["k"], vid] = batch
    return out


def stepped(fleet: Fleet, overrides: tuple[str, ...]):  # noqa: F811
    """The supervisor's ticks one step at a time, every vehicle transmitting at every step."""
    broker, pubs = pure_broker(overrides=overrides)
    for k in range(LONG):
        broker.take(TICK_KEY, encode(tick_message(k, k * DT, False)))
        broker.advance()
        report(broker, fleet, k, k + 1, seq=k + 1)
    return pubs


def spanned(fleet: Fleet, overrides: tuple[str, ...], forged: int | None = None):  # noqa: F811
    """One span the broker runs, its windows run past the transmissions as far as the channel allows; the vehicles
    answer each window with one message of its steps, transmitting at every step. forged: the step at which vehicle
    2 says its transmission went into the water 3 s earlier."""
    broker, pubs = pure_broker(overrides=overrides)
    broker.take(TICK_KEY, encode(tick_message(0, 0.0, False, span=LONG, longest=100)))
    broker.advance()
    windows: list[tuple[int, int]] = []
    while broker.next_k < LONG or len(windows) < len(published(pubs, COMMS_STEP_KEY)):
        tick = published(pubs, COMMS_STEP_KEY)[len(windows)]["tick"]
        a, b = tick["k"], tick.get("until") or tick["k"] + 1
        windows.append((a, b))
        for vid in IDS:
            telemetry, model, sent = fleet[vid]
            steps = []
            for k in range(a, b):
                t = k * DT - (3.0 if (vid, k) == (2, forged) else 0.0)
                tx = tx_wire(msgspec.structs.replace(sent, seq=k + 1, t=t, stamp=k * DT))
                steps.append(step_message(state_message(telemetry, model, k, k + 1), tx, None))
            broker.take(state_key(vid), encode(window_message(steps, b)))
        broker.advance()
    return pubs, windows, broker


@pytest.mark.parametrize(
    ("overrides", "expected"),
    [
        (SLOW, [(0, 20), (20, 40), (40, 45)]),  # nothing sent arrives within 2 s, nothing can be spoiled
        # collisions: from step 20 on a packet arrives at every step, and one sent then could spoil
        # it: windows of one step, as without lookahead
        (COLLIDING, [(0, 20), *((k, k + 1) for k in range(20, LONG))]),
        (DELAYED, [(0, 15), (15, 30), (30, 45)]),  # the least extra delay of the links in force
    ],
    ids=["delay only", "collisions", "extra delays"],
)
def test_windows_run_past_transmissions_and_hand_out_what_stepping_does(fleet: Fleet, overrides, expected) -> None:  # noqa: F811
    """Channel lookahead (comms.broker.lookahead): the same receptions at every step, the same link events and link
    statistics, as the supervisor's ticks one step at a time."""
    one_by_one = stepped(fleet, overrides)
    pubs, windows, _ = spanned(fleet, overrides)
    assert windows == expected
    assert received(pubs) == received(one_by_one)
    assert any(batch["receptions"] for batch in received(pubs).values()) == (overrides != COLLIDING)
    for key in (COMMS_EVENTS_KEY, COMMS_STATS_KEY):
        assert published(pubs, key) == published(one_by_one, key)
    assert published(pubs, COMMS_EVENTS_KEY)


def test_a_transmission_not_at_its_step_s_time_is_dropped(fleet: Fleet) -> None:  # noqa: F811
    """A forged transmission time would have its packet arrive before the window's receptions were handed out (a
    packet sent 3 s before a 2 s airtime): the broker drops it (counted), the state still counts, nothing else
    changes."""
    pubs, windows, broker = spanned(fleet, SLOW, forged=35)
    assert windows == [(0, 20), (20, 40), (40, 45)]
    assert broker.books.drops.by_cause == {"malformed": 1}
    sent = [e for m in published(pubs, COMMS_EVENTS_KEY) for e in m["events"] if e["kind"] == "sent"]
    # four links (2 - 1 - 3, both ways), every step's but the last's in the water (at the next tick), one dropped
    assert not any(e["sender"] == 2 and e["seq"] == 36 for e in sent) and len(sent) == 4 * (LONG - 1) - 1


@pytest.mark.parametrize("spanned_run", [False, True], ids=["ticked", "in a span"])
def test_a_step_message_with_a_malformed_next_tx_is_dropped_whole(fleet: Fleet, spanned_run: bool) -> None:  # noqa: F811
    """A forged next_tx (not a step) drops the whole message, counted, as the supervisor's intake drops it (read_window
    refuses it, split_window names it): the broker kept the state and ignored next_tx when not in a lookahead window,
    so its channel saw a state the log never had."""
    broker, _ = pure_broker()
    if spanned_run:
        broker.take(TICK_KEY, encode(tick_message(0, 0.0, False, span=STEPS, longest=100)))
    else:
        broker.take(TICK_KEY, encode(tick_message(0, 0.0, False)))
    broker.advance()
    telemetry, model, _ = fleet[IDS[0]]
    message = step_message(state_message(telemetry, model, 0, 0), None, None, 1)
    broker.take(state_key(IDS[0]), encode({**message, "next_tx": "soon"}))
    assert broker.books.drops.by_cause == {"malformed": 1}
    assert broker.books.taken[IDS[0]] == -1  # still the seed (its step 0 next): nothing taken from it
