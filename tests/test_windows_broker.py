"""The broker over a time window (no Zenoh): one tick of steps a .. b-1 hands out, step by step, exactly what ticks
of one step each would (receptions of every step, link events, statistics snapshots at their own times), in one
batches message; and it then waits for the window's last states, not for those inside it."""

from __future__ import annotations

from comms.records.messages import (
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    COMMS_STEP_KEY,
    TICK_KEY,
    encode,
    parse_batches,
    parse_window,
    tick_message,
)
from tests.test_broker_integration import DT, IDS, Fleet, fleet, pure_broker, report, tick  # noqa: F401

SLOW = ("comms.packet_bytes=32", "comms.bitrate=256", "comms.stats_window=0.5")  # 1 s on air: arrives 10 steps later
END = 14  # the window: steps 1 .. 13 (the packets of step 0 arrive at about 1.0 s, inside it)


def stepwise(fleet: Fleet) -> tuple[dict[int, dict[int, list]], list, list]:  # noqa: F811
    """Steps 1 .. END-1 one tick each: (step -> vehicle -> receptions, link events, statistics snapshots)."""
    broker, pubs = pure_broker(overrides=SLOW)
    tick(broker, 0)
    report(broker, fleet, 0, seq=1)
    per_step = {}
    for k in range(1, END):
        tick(broker, k)
        message = next(m for key, m in pubs.messages if key == COMMS_STEP_KEY and m["k"] == k)
        per_step[k] = {v: parse_batches(message, v)[1]["receptions"] for v in IDS}  # type: ignore[index]
        report(broker, fleet, k)
    return per_step, published(pubs, COMMS_EVENTS_KEY), published(pubs, COMMS_STATS_KEY)


def published(pubs, key: str) -> list:
    return [m for k, m in pubs.messages if k == key]


def test_a_window_hands_out_what_single_steps_do(fleet: Fleet) -> None:  # noqa: F811
    expected, events, stats = stepwise(fleet)
    assert any(expected[k][1] for k in range(2, END))  # a reception arrives inside the window, not at its start
    broker, pubs = pure_broker(overrides=SLOW)
    tick(broker, 0)
    report(broker, fleet, 0, seq=1)
    broker.take(TICK_KEY, encode(tick_message(1, DT, False, until=END)))
    assert broker.advance() is False
    assert broker.next_k == END
    [message] = [m for key, m in pubs.messages if key == COMMS_STEP_KEY and m["k"] == 1]
    for v in IDS:
        tick_, batches = parse_window(message, v, DT)
        assert tick_.end == END and batches is not None
        assert {b["k"]: b["receptions"] for b in batches} == {k: expected[k][v] for k in range(1, END)}
        assert [b["t"] for b in batches] == [k * DT for k in range(1, END)]
    assert published(pubs, COMMS_EVENTS_KEY) == events and len(events) >= 2  # step by step, as the log keeps them
    assert published(pubs, COMMS_STATS_KEY) == stats and len(stats) >= 2  # snapshots at their own steps
    report(broker, fleet, END - 1, since=1)  # the window's (its last states: all the next tick needs)
    assert tick(broker, END) is False and broker.next_k == END + 1
