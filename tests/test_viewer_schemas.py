"""Every cpf channel's schema is one the viewers read (tests/viewer_rules.py): Lichtblick refused 9 of them (issue
25), and a refused schema leaves every plot of its channel empty."""

from __future__ import annotations

import math

import pytest

from comms.records.messages import (
    COMMS_EVENT_KEY,
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    FAULT_KEY,
    GRAPH_KEY,
    META_KEY,
    STOP_KEY,
    TICK_KEY,
)
from comms.records.schemas import schema_for
from tests.viewer_rules import TopicSpan, high_frequency_topics, viewer_problems

KEYS = [META_KEY, FAULT_KEY, GRAPH_KEY, STOP_KEY, TICK_KEY, COMMS_EVENT_KEY, COMMS_EVENTS_KEY, COMMS_STATS_KEY,
        "cpf/comms/done", "cpf/vehicle/2/state", "cpf/vehicle/2/tx", "cpf/vehicle/2/rx",
        "cpf/vehicle/2/done"]  # fmt: skip


@pytest.mark.parametrize("key", KEYS)
def test_a_channels_schema_is_one_the_viewers_read(key: str) -> None:
    schema = schema_for(key)
    assert schema is not None
    assert viewer_problems(schema) == []


def test_the_rules_refuse_what_lichtblick_refused() -> None:
    """The forms Lichtblick's alerts named (issue 25): an array of arrays, a type list, an untyped enum."""
    for field in ({"type": "array", "items": {"type": "array", "items": {"type": "number"}}},
                  {"type": ["number", "null"]}, {"enum": ["start", "end"]}):  # fmt: skip
        assert viewer_problems({"type": "object", "properties": {"x": field}}) != []


def test_the_scenes_own_schema_is_one_the_viewers_read() -> None:
    """foxglove/coordination/<id> (cpf.Coordination, cpf's own; the foxglove.* schemas are Foxglove's, which the
    viewers know by name)."""
    from supervisor.record.scene.foxglove_schemas import schema

    assert viewer_problems(schema("cpf.Coordination")) == []


def test_the_high_frequency_rule_is_lichtblicks():
    """Over 60 messages a second of a topic's own span, and only for a topic with a schema (tests/viewer_rules.py)."""
    second = 10**9
    spans = {
        "at": TopicSpan(601, 0, 10 * second, True),  # 60 Hz: not above
        "above": TopicSpan(602, 0, 10 * second, True),
        "late": TopicSpan(602, 390 * second, 400 * second, True),  # its own span, not the log's
        "bare": TopicSpan(10_000, 0, second, False),  # no schema: never
        "instant": TopicSpan(2, 5 * second, 5 * second, True),
        "once": TopicSpan(1, 0, 0, True),
    }
    assert high_frequency_topics(spans) == {"above": 60.1, "late": 60.1, "instant": math.inf}
