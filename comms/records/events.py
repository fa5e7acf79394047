"""The broker's link events of one step as the bus carries them and the log keeps them (cpf/comms/events): one
message a step. A msgspec Struct, the message's only description: its message, its checked reading and its schema
(comms.records.schemas.LINK_EVENTS) come from it. Logs written by earlier versions kept one cpf/comms/event record per
event (comms.records.records.LinkEvent): `logged_events` reads both forms, for every reader of a log.
"""

from __future__ import annotations

from typing import Any

import msgspec

from comms.records.fields import Finite, Message, as_message, read_as
from comms.records.messages import COMMS_EVENT_KEY, COMMS_EVENTS_KEY
from comms.records.records import LinkEvent

# The log's topics that hold link events: a step's batch, and an older log's single event (one record per event made
# ~80 records a second in the paper run, over the 60 Hz above which Lichtblick warns of "high frequency topics").
EVENT_TOPICS = frozenset({COMMS_EVENTS_KEY, COMMS_EVENT_KEY})


def logged_events(topic: str, message: object) -> list[Any]:
    """The link events a log record holds, each in its message form (LinkEvent.to_message, its own t), in the order
    written: a cpf/comms/events batch's events, an older log's cpf/comms/event record itself, nothing for any other
    topic. Each reader reads them its way (LinkEvent.from_message, or by hand where every event counts for time).
    ValueError for a batch whose events are no list."""
    if topic == COMMS_EVENTS_KEY:
        events = message.get("events") if isinstance(message, dict) else None
        if not isinstance(events, list):
            raise ValueError("field 'events' is not a list of link events")
        return events
    return [message] if topic == COMMS_EVENT_KEY else []


class LinkEvents(msgspec.Struct, frozen=True):
    """The link events the broker publishes with the tick of step k (t: that tick's time)."""

    t: Finite
    k: int
    events: tuple[LinkEvent, ...]

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object, malformed: list[ValueError] | None = None) -> LinkEvents:
        """The batch, checked: ValueError naming the field for anything malformed. With a malformed list, an event
        that does not read is left out and its error appended there instead (the rest of the batch still counts:
        a reader that counts the events the broker announced counts it too)."""
        try:
            return read_as(message, cls)
        except ValueError:
            items = message.get("events") if malformed is not None and isinstance(message, dict) else None
            if malformed is None or not isinstance(items, list) or not all(isinstance(item, dict) for item in items):
                raise
        assert isinstance(message, dict)
        frame = read_as({**message, "events": []}, cls)  # the batch but its events
        events = []
        for item in items:
            try:
                events.append(LinkEvent.from_message(item))
            except ValueError as exc:
                malformed.append(exc)
        return msgspec.structs.replace(frame, events=tuple(events))
