"""The relay's close code when the server's side ends before the order naming the code arrives (supervisor.record.
live_relay): the order comes on a pipe read by another thread than the connections' loop, so either can come first."""

from __future__ import annotations

import asyncio
import socket
import threading
from collections.abc import Iterator

import pytest
from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from supervisor.record.live_relay import SDK_SUBPROTOCOL, Relay

HOST = "127.0.0.1"


class Backend:
    """A WebSocket server standing for foxglove-sdk's that drops each connection when told (as its stop does)."""

    def __init__(self) -> None:
        self.connected = threading.Event()
        self._loop = asyncio.new_event_loop()
        self._drop: asyncio.Event | None = None
        ready = threading.Event()
        self._thread = threading.Thread(target=self._serve, args=(ready,), daemon=True)
        self._thread.start()
        ready.wait()

    def _serve(self, ready: threading.Event) -> None:
        async def main() -> None:
            self._drop = asyncio.Event()
            async with serve(self._handle, HOST, 0, subprotocols=[SDK_SUBPROTOCOL]) as server:
                self.port = server.sockets[0].getsockname()[1]
                ready.set()
                await self._drop.wait()
                await asyncio.sleep(0.1)  # the handlers' closes out

        self._loop.run_until_complete(main())
        self._loop.close()

    async def _handle(self, connection: ServerConnection) -> None:
        self.connected.set()
        assert self._drop is not None
        await self._drop.wait()
        await connection.close()  # no code, as foxglove-sdk's stop (1005)

    def drop(self) -> None:
        assert self._drop is not None
        self._loop.call_soon_threadsafe(self._drop.set)
        self._thread.join()


@pytest.fixture
def relay_and_backend() -> Iterator[tuple[Relay, Backend, int]]:
    backend = Backend()
    sock = socket.create_server((HOST, 0))
    port = sock.getsockname()[1]
    relay = Relay(sock, f"ws://{HOST}:{backend.port}")
    try:
        yield relay, backend, port
    finally:
        relay.stop()


def test_a_close_order_that_comes_after_the_server_went_still_names_the_code(
    relay_and_backend: tuple[Relay, Backend, int],
) -> None:
    """The supervisor says `closing 1000` and stops the server; the relay's connection sees the server go before
    the order is read: it waits for the order (bounded by DRAIN_WAIT) and closes with 1000, not the default 1001."""
    relay, backend, port = relay_and_backend
    with connect(f"ws://{HOST}:{port}", subprotocols=[SDK_SUBPROTOCOL]) as client:
        assert backend.connected.wait(5)
        backend.drop()  # the server's side ends first ...
        threading.Timer(0.3, relay.closing, args=(1000, "the run is over")).start()  # ... the order comes later
        with pytest.raises(ConnectionClosed):
            client.recv(timeout=5)
        assert client.protocol.close_rcvd is not None
        assert (client.protocol.close_rcvd.code, client.protocol.close_rcvd.reason) == (1000, "the run is over")


def test_a_stop_without_a_close_order_closes_going_away(relay_and_backend: tuple[Relay, Backend, int]) -> None:
    relay, backend, port = relay_and_backend
    with connect(f"ws://{HOST}:{port}", subprotocols=[SDK_SUBPROTOCOL]) as client:
        assert backend.connected.wait(5)
        backend.drop()
        relay.stop()
        with pytest.raises(ConnectionClosed):
            client.recv(timeout=5)
        assert client.protocol.close_rcvd is not None
        assert client.protocol.close_rcvd.code == 1001
