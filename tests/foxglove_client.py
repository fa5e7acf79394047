"""A Foxglove WebSocket client for the tests (the `websockets` package, synchronous), speaking Foxglove's WebSocket
protocol (github.com/foxglove/ws-protocol, v1) as Foxglove does. Its subprotocol is `foxglove.websocket.v1`, and
`foxglove.sdk.v1` its new name: the client offers both, as Foxglove does, or those it is given. The protocol: the
server sends serverInfo and advertise (JSON text), the client subscribes to channel ids, the server sends binary
messageData frames (opcode 1: subscription id u32, log time u64 ns, then the message, here JSON) and time frames
(opcode 2: u64 ns)."""

from __future__ import annotations

import contextlib
import json
import struct
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Subprotocol

SUBPROTOCOLS = [Subprotocol("foxglove.sdk.v1"), Subprotocol("foxglove.websocket.v1")]
MESSAGE_DATA, TIME = 1, 2
WAIT = 20.0  # s: a frame not here by then is a failure (a hung server), not a timing assertion
CLOSE_WAIT = 60.0  # s: the close comes after the run has shut down (processes stopped, log finished): slow under load


@dataclass
class Received:
    topic: str
    log_time: int  # ns
    message: Any
    at: float  # time.monotonic() when it arrived


@dataclass
class FoxgloveClient:
    ws: ClientConnection
    server_info: dict[str, Any] = field(default_factory=dict)
    channels: dict[str, dict[str, Any]] = field(default_factory=dict)  # topic -> advertised channel
    subscribed: dict[int, str] = field(default_factory=dict)  # subscription id -> topic
    times: list[int] = field(default_factory=list)  # the server's time frames (ns)

    @classmethod
    @contextlib.contextmanager
    def open(
        cls, port: int, wanted: set[str], subprotocols: list[Subprotocol] = SUBPROTOCOLS
    ) -> Iterator[FoxgloveClient]:
        """Connected, serverInfo read, and advertisements read until every wanted topic is advertised; closed on
        the way out."""
        with connect(f"ws://127.0.0.1:{port}", subprotocols=subprotocols, open_timeout=WAIT, proxy=None) as ws:
            client = cls(ws)
            assert ws.subprotocol in subprotocols
            while not client.server_info or not wanted <= set(client.channels):
                client._take(ws.recv(timeout=WAIT))
            yield client

    def subscribe(self, topics: list[str]) -> None:
        subscriptions = []
        for topic in topics:
            sid = len(self.subscribed) + 1
            self.subscribed[sid] = topic
            subscriptions.append({"id": sid, "channelId": self.channels[topic]["id"]})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    def receive(self, wait: float = WAIT) -> Received | None:
        """The next message of a subscribed channel within `wait` s (else TimeoutError); None when the server has
        closed the connection."""
        while True:
            try:
                frame = self.ws.recv(timeout=wait)
            except ConnectionClosed:
                return None
            got = self._take(frame)
            if got is not None:
                return got

    def _take(self, frame: str | bytes) -> Received | None:
        if isinstance(frame, str):
            op = json.loads(frame)
            if op["op"] == "serverInfo":
                self.server_info = op
            elif op["op"] == "advertise":
                self.channels.update({channel["topic"]: channel for channel in op["channels"]})
            return None
        if frame[0] == TIME:
            self.times.append(struct.unpack_from("<Q", frame, 1)[0])
            return None
        assert frame[0] == MESSAGE_DATA, f"unexpected binary opcode {frame[0]}"
        sid, stamp = struct.unpack_from("<IQ", frame, 1)
        return Received(self.subscribed[sid], stamp, json.loads(frame[13:]), time.monotonic())

    def close(self) -> None:
        self.ws.close()

    @property
    def close_code(self) -> int | None:
        """The code of the server's close frame (None: none came, 1005 its code if it had none: RFC 6455, 7.4.1)."""
        received = self.ws.protocol.close_rcvd
        return None if received is None else received.code
