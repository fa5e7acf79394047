"""`--live` for the commands that run or replay a run: a Foxglove WebSocket server whose address, and the topics
clients subscribe to, the command line tells the user (supervisor.record.live serves; library code does not print)."""

from __future__ import annotations

import contextlib
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Iterator

    from supervisor.record.live import LiveView


TOLD = 10  # subscriptions told one line each (a new user's replay printed 508 lines for one viewer)


@contextlib.contextmanager
def live_view(port: int | None, command: str, tell_subscriptions: bool = False) -> Iterator[LiveView | None]:
    """With --live: a Foxglove WebSocket server, its address on stderr, stopped on the way out whatever happens
    (the end, an error, Ctrl-C); ScenarioError if the port cannot be had. Without: None, and foxglove not imported.
    tell_subscriptions: each topic a client subscribes to, a line on stderr (a replay waiting for Enter: the user
    sees the viewer is in before starting it)."""
    if port is None:
        yield None
        return
    from supervisor.record.live import LiveView

    told_so_far = [0]

    def told(topic: str) -> None:  # the first TOLD, then one line: a viewer of 100 vehicles subscribes to ~500 topics
        told_so_far[0] += 1
        if told_so_far[0] <= TOLD:
            print(f"{command}: a client subscribed to {topic}", file=sys.stderr, flush=True)
        elif told_so_far[0] == TOLD + 1:
            print(f"{command}: (more subscriptions, not shown)", file=sys.stderr, flush=True)

    with LiveView(port, on_subscribe=told if tell_subscriptions else None) as live:
        print(f"{command}: live view on {live.url} (Foxglove: Open connection -> Foxglove WebSocket)", file=sys.stderr)
        yield live
