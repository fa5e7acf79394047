"""The live view's front door: a WebSocket relay on the view's port, in front of foxglove-sdk's server (which listens
on a free port of the same host), for what that server does not do and Foxglove's clients need:

- the subprotocol: Foxglove's WebSocket protocol (github.com/foxglove/ws-protocol, docs/spec.md) is
  `foxglove.websocket.v1`, the only name Foxglove's own client library (@foxglove/ws-protocol) and older Foxglove and
  Lichtblick versions offer; foxglove-sdk's server (0.30, its rust/foxglove/src/websocket/handshake.rs, no option)
  answers only to `foxglove.sdk.v1`, with HTTP 400 otherwise. The relay accepts either (the client's own answered)
  and speaks `foxglove.sdk.v1` to the server: the same protocol under its new name.
- the close (RFC 6455, 5.5.1 and 7.4): the server drops the connection on a client's close frame without answering
  (the client sees 1006, abnormal closure) and stops with a close frame without a code (1005). The relay answers a
  client's close with its code (the websockets package's closing handshake), and once the server has stopped and
  everything it sent is passed on, closes each connection with the code `stop` is given.

A byte splice that rewrote the handshake's header would do the first, not the second: the close is a frame. Frames
pass as they are (text as text, binary as binary, in order, uncompressed); the relay runs an asyncio loop on its own
thread, from construction to `stop`, in a process of its own (supervisor.record.relay_process: `main`): in the
supervisor's process that thread waited for the interpreter lock the engine holds (benchmarks/bench_live.py).

`python -m supervisor.record.live_relay BACKEND_URL`: the relay process. It serves on the listening socket it
inherits (its descriptor in RELAY_SOCKET_ENV) and takes its orders, a line each, on the control pipe it inherits
(RELAY_CONTROL_ENV): `closing CODE REASON`, then `stop`; the pipe's end (the supervisor gone) stops it too."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import socket
import sys
import threading
from collections.abc import Coroutine
from typing import Any

from websockets.asyncio.client import ClientConnection, connect
from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed, InvalidHandshake
from websockets.frames import CloseCode
from websockets.typing import Subprotocol

from comms.bus import lifeline

log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)
SDK_SUBPROTOCOL = Subprotocol("foxglove.sdk.v1")  # what foxglove-sdk's server answers to
SUBPROTOCOLS = [SDK_SUBPROTOCOL, Subprotocol("foxglove.websocket.v1")]  # what the relay answers to, in preference
DRAIN_WAIT = 5.0  # s for the connections to pass on what the stopped server sent, and close
BACKEND_WAIT = 10.0  # s to connect to the server on the same host (a loaded machine), or to close a connection to it
# s a client may take nothing before it is let go: the relay's reading of the server waited on it, and the server's
# stop at the run's end waited on the relay (a viewer that stopped reading held `cpf run --live` ~50 s; a new user)
STALLED = 5.0
CLOSE_WAIT = 2.0  # s for a client to answer a close (one that reads answers in ms)
RELAY_SOCKET_ENV = "CPF_RELAY_SOCKET"  # the relay process's listening socket: its inherited descriptor
RELAY_CONTROL_ENV = "CPF_RELAY_CONTROL"  # the relay process's control pipe: its inherited read end


class Relay:
    """Serving on the listening socket sock and relaying each connection to the server at backend (a ws:// URL)."""

    def __init__(self, sock: socket.socket, backend: str) -> None:
        self._backend = backend
        self._closing: tuple[int, str] = (CloseCode.GOING_AWAY, "cpf stopped")  # see `closing`
        # Set once the code is known (`closing` or `stop`). The order comes on the control pipe, read by another thread
        # than the loop's, and the server's stop right after it can reach a connection first: without the wait, that
        # connection closed with the default code (seen in CI: 1001 after `finish`).
        self._told = asyncio.Event()
        self._handlers: set[asyncio.Task[None]] = set()
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, name="cpf-live-relay", daemon=True)
        self._thread.start()
        try:
            self._server: Server = self._run(self._listen(sock))
        except BaseException:
            self._end_loop()
            raise

    def closing(self, code: int, reason: str) -> None:
        """The close code and reason each connection gets once the server is gone (before stopping the server)."""
        self._closing = (code, reason)
        self._loop.call_soon_threadsafe(self._told.set)

    def stop(self) -> None:
        """No more connections; those open pass on what the server sent (it has stopped) and close with the code of
        `closing`, within DRAIN_WAIT (then closed with it); the loop ended. Again: nothing."""
        if not self._thread.is_alive():
            return
        try:
            self._run(self._shutdown())
        finally:
            self._end_loop()

    def _run(self, coroutine: Coroutine[Any, Any, Any]) -> Any:
        return asyncio.run_coroutine_threadsafe(coroutine, self._loop).result()

    def _end_loop(self) -> None:
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join()
        self._loop.close()

    async def _listen(self, sock: socket.socket) -> Server:
        return await serve(self._relay, sock=sock, subprotocols=SUBPROTOCOLS, compression=None, max_size=None,
                           ping_interval=None)  # fmt: skip

    async def _shutdown(self) -> None:
        self._told.set()  # no `closing`: the default code
        self._server.close(close_connections=False)  # the listening socket: no new connection
        if self._handlers:
            await asyncio.wait(set(self._handlers), timeout=DRAIN_WAIT)
        for connection in self._server.connections:  # any left
            await _closed(connection, self._closing)
        await self._server.wait_closed()

    async def _relay(self, client: ServerConnection) -> None:
        """One client's connection: frames both ways until either side closes; then the client's closed."""
        task = asyncio.current_task()
        assert task is not None
        self._handlers.add(task)
        try:
            async with connect(self._backend, subprotocols=[SDK_SUBPROTOCOL], compression=None, max_size=None,
                               ping_interval=None, open_timeout=BACKEND_WAIT, close_timeout=BACKEND_WAIT,
                               proxy=None) as server:  # fmt: skip
                await _both_ways(client, server)
        except (OSError, InvalidHandshake, TimeoutError) as exc:  # the server is gone, or going
            log.info("live view: no server for %s (%s)", client.remote_address, exc)
        finally:
            if client.close_code is None:  # the server's side ended first: its code is the one stop will be given
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._told.wait(), DRAIN_WAIT)
            await _closed(client, self._closing)  # nothing if the client closed: its close was answered
            self._handlers.discard(task)


async def _closed(client: ServerConnection, code: tuple[int, str]) -> None:
    """client closed with code; one that does not answer within CLOSE_WAIT (it reads nothing) let go at once: the
    close handshake waited for it the server's close_timeout (10 s), twice at a stop."""
    try:
        await asyncio.wait_for(client.close(*code), CLOSE_WAIT)
    except TimeoutError:
        client.transport.abort()


async def _both_ways(client: ServerConnection, server: ClientConnection) -> None:
    pumps = [asyncio.create_task(_pump(client, server)), asyncio.create_task(_pump(server, client, STALLED))]
    try:
        done, _ = await asyncio.wait(pumps, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for pump in pumps:
            pump.cancel()
    if any(not p.cancelled() and p.exception() is None and p.result() for p in done):  # a client let go: its server
        server.transport.abort()  # side too, at once (a close handshake reads the frames queued for it: nobody takes)


async def _pump(
    source: ServerConnection | ClientConnection, sink: ServerConnection | ClientConnection, limit: float | None = None
) -> bool:
    """Each frame from source to sink, until either closes (False), or until a frame waits longer than limit s to be
    taken (True: a sink that does not read, let go)."""
    try:
        async for frame in source:
            async with asyncio.timeout(limit):  # a timer, not wait_for's task per frame (every message of the view)
                await sink.send(frame)
    except ConnectionClosed:
        return False
    except TimeoutError:  # no close handshake with a peer that reads nothing: it would wait for it too
        log.info("live view: %s took nothing for %g s, let go", sink.remote_address, limit)
        sink.transport.abort()
        return True
    return False


def main(backend: str) -> None:
    """The relay process: serve until told to stop, or until the supervisor is gone."""
    logging.basicConfig(level=logging.WARNING, format="cpf live relay: %(message)s")
    lifeline.watch("live relay")
    sock = socket.socket(fileno=int(os.environ.pop(RELAY_SOCKET_ENV)))
    relay = Relay(sock, backend)
    try:
        with os.fdopen(int(os.environ.pop(RELAY_CONTROL_ENV)), encoding="utf-8") as control:
            for line in control:  # until `stop` or the pipe's end
                order, _, rest = line.rstrip("\n").partition(" ")
                if order == "stop":
                    break
                if order == "closing":
                    code, _, reason = rest.partition(" ")
                    relay.closing(int(code), reason)
    finally:
        relay.stop()


if __name__ == "__main__":
    main(sys.argv[1])
