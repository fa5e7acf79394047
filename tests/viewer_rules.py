"""The JSON Schema subset the viewers read: a channel whose schema breaks a rule is refused whole (an alert, and every
plot of it empty). Written after Lichtblick's parser (packages/mcap-support/src/parseJsonSchema.ts, the open-source
Foxglove Studio's, which Foxglove shares): the root an object; each field of one type among boolean, string, number,
integer, object (with properties, recursively) and array; an array's items of one type among boolean, string,
number, integer and object (no arrays of arrays); no type lists, no null, no untyped enum, no references. And its rule
for a topic's rate (high_frequency_topics)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

SCALARS = ("boolean", "string", "number", "integer")


def viewer_problems(schema: dict[str, Any], where: str = "$") -> list[str]:
    """What a viewer would refuse in a message schema (empty: it reads it)."""
    if schema.get("type") != "object" or not isinstance(schema.get("properties"), dict):
        return [f"{where}: not an object with properties ({schema.get('type')!r})"]
    problems = []
    for name, field in schema["properties"].items():
        problems += _field(field, f"{where}.{name}")
    return problems


def _field(field: dict[str, Any], where: str) -> list[str]:
    if "$ref" in field or "anyOf" in field or "oneOf" in field:
        return [f"{where}: a reference or union"]
    kind = field.get("type")
    if kind in SCALARS:
        return []
    if kind == "object":
        return viewer_problems(field, where)
    if kind == "array":
        items = field.get("items")
        if not isinstance(items, dict) or items.get("type") not in (*SCALARS, "object"):
            return [f"{where}: array items of type {None if not isinstance(items, dict) else items.get('type')!r}"]
        return viewer_problems(items, f"{where}[]") if items["type"] == "object" else []
    return [f"{where}: type {kind!r}"]


# Lichtblick's rule for its "High frequency topics detected" alert: a topic with a schema whose messages come, on
# average over its own span of log time, more often than this.
HIGH_FREQUENCY_HZ = 60.0


@dataclass(frozen=True)
class TopicSpan:
    """What a log's summary says of one topic: its messages, its first and last log times (ns), whether its channel
    has a schema."""

    count: int
    first: int
    last: int
    schema: bool


def high_frequency_topics(topics: Mapping[str, TopicSpan]) -> dict[str, float]:
    """topic -> its rate (Hz: (count - 1) / (last - first)) of every topic with a schema above HIGH_FREQUENCY_HZ (more
    than one message at one instant: an infinite rate)."""
    out = {}
    for topic, span in topics.items():
        if not span.schema or span.count < 2:
            continue
        seconds = (span.last - span.first) / 1e9
        rate = (span.count - 1) / seconds if seconds > 0 else math.inf
        if rate > HIGH_FREQUENCY_HZ:
            out[topic] = rate
    return out
