"""Eclipse Zenoh plumbing shared by every process: sessions, publishers, and an inbox fed by subscriptions.

Sessions use explicit TCP endpoints with multicast scouting off, so runs never find each other by accident. The
supervisor's session is a router that the vehicle and broker processes connect to as clients. Publishers block
rather than drop under congestion (lockstep needs every message) and are express (no batching delay).
"""

from __future__ import annotations

import json
import logging
import queue
import socket
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import zenoh

from comms.bus.lifeline import watch
from comms.records.messages import (
    ANOTHER_SCENARIO,
    FLUSH_KEY,
    STOP_END,
    STOP_KEY,
    SUPERVISOR_ALIVE,
    Message,
    decode,
    encode,
    hello_key,
)
from comms.records.run import Stop

log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)
REFUSED = 2  # a refused process's exit code: bad input, as cpf's (supervisor.errors.EXIT_INPUT)
POLL = 0.5  # s between checks while nothing arrives
Handler = Callable[[str, bytes], None]


@runtime_checkable
class Timed(Protocol):
    """A handler that also has work due at given wall-clock times (time.time()), e.g. a realtime vehicle's steps."""

    def __call__(self, key: str, payload: bytes) -> None: ...

    def due(self) -> float | None:
        """When the next timed work is due, or None."""
        ...

    def on_time(self) -> None:
        """Do whatever work is due by now (called after every message and on every wake-up)."""
        ...


@runtime_checkable
class Reporting(Protocol):
    """A handler with something to say at the end of the run (e.g. how many malformed messages it dropped)."""

    def __call__(self, key: str, payload: bytes) -> None: ...

    def final_report(self) -> tuple[str, Message]:
        """(key, message) to publish when the supervisor's stop message comes."""
        ...


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


CONNECT_TIMEOUT_MS = 30_000  # a process started by hand may come up before the supervisor's router does


@dataclass(frozen=True, slots=True)
class Extras:
    """What a session adds to cpf's own settings: a site's Zenoh config file (JSON5) under them, for everything a
    site needs that cpf does not set, and entries over them: credentials, TLS, access control (comms.bus.access)."""

    site: Path | None = None
    entries: Mapping[str, object] = field(default_factory=dict)
    credentials: bool = False  # whether the entries authenticate this session (for a clearer error if refused)


def site_config(path: Path) -> zenoh.Config:
    """The site's Zenoh config file; ValueError saying why if it cannot be read or Zenoh refuses it."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot read it ({getattr(exc, 'strerror', None) or exc})") from None
    try:
        return zenoh.Config.from_json5(text)
    except zenoh.ZError as exc:
        raise ValueError(f"not a Zenoh config ({_reason(exc)})") from None


def config(
    mode: str, listen: Sequence[str] = (), connect: Sequence[str] = (), extras: Extras | None = None
) -> zenoh.Config:
    extras = extras or Extras()
    conf = site_config(extras.site) if extras.site is not None else zenoh.Config()
    if extras.site is None:
        # Zenoh's shared memory maps a 16 MiB pool into every session that sends a message over 3 KiB (a time
        # window's report): 25 hosted vehicles held 440 MB of it, for messages a copy moves in microseconds.
        conf.insert_json5("transport/shared_memory/enabled", "false")
    conf.insert_json5("mode", json.dumps(mode))
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/delay", "0")  # nothing to scout with explicit endpoints: a router opened in 0.5 s
    if mode == "client":
        conf.insert_json5("connect/timeout_ms", str(CONNECT_TIMEOUT_MS))
    if listen:
        conf.insert_json5("listen/endpoints", json.dumps(list(listen)))
    if connect:
        conf.insert_json5("connect/endpoints", json.dumps(list(connect)))
    for key, value in extras.entries.items():
        conf.insert_json5(key, json.dumps(value))
    return conf


def open_session(
    mode: str, listen: Sequence[str] = (), connect: Sequence[str] = (), extras: Extras | None = None
) -> zenoh.Session:
    """A session; ConnectionError with a one-line reason if the endpoints cannot be reached or bound (ValueError if
    the site's config file is not one)."""
    zenoh.try_init_log_from_env()
    conf = config(mode, listen, connect, extras)
    try:
        return zenoh.open(conf)
    except zenoh.ZError as exc:
        where = ", ".join([*listen, *connect]) or "no endpoint"
        hint = ""
        if mode == "client" and not (extras and extras.credentials):
            hint = " (a cpf run's router admits only the processes it gave credentials: --credentials FILE)"
        raise ConnectionError(f"Zenoh {mode} session on {where}: {_reason(exc)}{hint}") from None


def _reason(exc: Exception) -> str:
    return str(exc).split(" at /")[0]  # drop the Rust source location


@dataclass(frozen=True, slots=True)
class Received:
    key: str
    payload: bytes


class Inbox:
    """Everything this process subscribed to, in arrival order, for one thread to consume."""

    def __init__(self) -> None:
        self._queue: queue.SimpleQueue[Received | str] = queue.SimpleQueue()  # C-implemented: cheaper per message
        # Waited on instead of SimpleQueue.get(timeout): in CPython 3.11 that call blocks for ever when a signal
        # interrupts its wait and the handler outlasts the timeout (it retries with a negative timeout, which means
        # none): a realtime run's supervisor hung so for 50 min. Event.wait recomputes its timeout correctly.
        self._arrived = threading.Event()
        self._keep: list[Any] = []  # subscribers live as long as the inbox

    def subscribe(self, session: zenoh.Session, key: str) -> None:
        def on_sample(sample: zenoh.Sample) -> None:
            self._put(Received(str(sample.key_expr), sample.payload.to_bytes()))

        self._keep.append(session.declare_subscriber(key, on_sample))

    def watch_liveliness(self, session: zenoh.Session, key: str) -> None:
        """Liveliness changes arrive as strings '+<key>' (appeared) and '-<key>' (gone)."""

        def on_token(sample: zenoh.Sample) -> None:
            sign = "+" if sample.kind == zenoh.SampleKind.PUT else "-"
            self._put(sign + str(sample.key_expr))

        self._keep.append(session.liveliness().declare_subscriber(key, on_token, history=True))

    def nudge(self) -> None:
        """Wake the consumer (an empty change it ignores), e.g. to have it check whether it was ended."""
        self._put("")

    def _put(self, item: Received | str) -> None:
        self._queue.put(item)
        self._arrived.set()

    def get(self, timeout: float) -> Received | str | None:
        """The next item, or None if none comes within timeout s (whatever signals come meanwhile)."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                return self._queue.get_nowait()
            except queue.Empty:
                pass
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            self._arrived.clear()
            if self._queue.empty():  # else one came between the look and the clear: take it
                self._arrived.wait(left)


class Publishers:
    """One declared publisher per key, reliable and express."""

    def __init__(self, session: zenoh.Session) -> None:
        self._session = session
        self._publishers: dict[str, zenoh.Publisher] = {}

    def put(self, key: str, message: Message) -> None:
        publisher = self._publishers.get(key)
        if publisher is None:
            publisher = self._session.declare_publisher(
                key, congestion_control=zenoh.CongestionControl.BLOCK, express=True
            )
            self._publishers[key] = publisher
        publisher.put(encode(message))


FLUSH_TIMEOUT = 5.0  # s: an answerer replies at once; more means it is gone, and then nothing is left to wait for


def answer_flushes(session: zenoh.Session) -> zenoh.Queryable[None]:
    """Answer flush queries (see flush): the supervisor's session does, for the vehicles' and the broker's last
    messages; so does a test's router for a replay's. Keep the queryable as long as the session."""
    return session.declare_queryable(FLUSH_KEY, lambda query: query.reply(FLUSH_KEY, b""))


def flush(session: zenoh.Session) -> int:
    """Return once every session that answers flushes (answer_flushes) has read what this session put before, so
    that closing this session cannot lose it.

    Closing a client session right after its last puts lost some of them for good: in 1,500 trials of 50 puts then
    close on Zenoh 1.10, 40 lost their tail (measured without flush; tests/test_bus_flush.py holds it with). The
    query goes the way the puts went, on their priority and behind them, so an answer means they were read first.
    Read, not yet handed over: zenoh-python runs each subscriber's Python callback on a thread of its own, so they
    may still be on their way to it. Without an answerer (a router not of ours) the query has nowhere to go and this
    returns at once: no guarantee there.
    Returns how many answered."""
    replies = session.get(FLUSH_KEY, target=zenoh.QueryTarget.ALL, express=True, timeout=FLUSH_TIMEOUT)
    return sum(1 for reply in replies if reply.ok is not None)


def decode_or_none(payload: bytes) -> Message | None:
    """A decoded message, or None for one that does not decode (the caller counts it)."""
    try:
        return decode(payload)
    except ValueError:
        return None


class Ending:
    """Ends one serve() from another thread, as a cut lifeline does (no final report, token undeclared, session
    closed): a vehicle host's way to stop serving one of its vehicles (killed, or the host's lifeline cut)."""

    def __init__(self) -> None:
        self.cut = threading.Event()
        self._inbox: Inbox | None = None

    def attach(self, inbox: Inbox) -> None:
        self._inbox = inbox
        if self.cut.is_set():
            inbox.nudge()

    def set(self) -> None:
        self.cut.set()
        if self._inbox is not None:
            self._inbox.nudge()  # at once, not at the loop's next poll


def serve(
    name: str,
    connect: Sequence[str],
    keys: Sequence[str],
    token: str,
    make_handler: Callable[[Publishers], Handler | Timed | Reporting],
    hello: Message | None = None,
    extras: Extras | None = None,
    ending: Ending | None = None,
) -> int:
    """A child process's life: join the run, answer on its hello key which scenario it runs (hello, before its token
    appears), subscribe to keys, declare its token, hand every message to the handler (a Timed one: wake it when its
    work is due), until the stop message or the supervisor's disappearance, or its lifeline is cut (no orphans).
    ending: given by a process serving several (a vehicle host, which watches the lifeline itself)."""
    lifeline = watch(name) if ending is None else None
    cut = ending.cut if ending is not None else lifeline.cut if lifeline is not None else None
    with open_session("client", connect=connect, extras=extras) as session:
        inbox = Inbox()
        if ending is not None:
            ending.attach(inbox)
        for key in (*keys, STOP_KEY):
            inbox.subscribe(session, key)
        inbox.watch_liveliness(session, SUPERVISOR_ALIVE)
        answer = _answer(session, hello_key(token), hello) if hello is not None else None
        alive = session.liveliness().declare_token(token)
        publishers = Publishers(session)
        reason = _loop(name, inbox, make_handler(publishers), publishers, cut)
        flush(session)  # the final report (bus._stopped) is on its way before the token goes
        alive.undeclare()
        if answer is not None:
            answer.undeclare()
    # refused (it runs another scenario): exit 2, bad input, as cpf's, so that a script starting it can tell
    return REFUSED if reason is not None and reason.startswith(f"{name} {ANOTHER_SCENARIO}") else 0


def _loop(
    name: str, inbox: Inbox, handle: Handler | Timed, publishers: Publishers, cut: threading.Event | None
) -> str | None:
    """Every message to the handler (a Timed one also woken when its work is due) until the stop message (its reason
    returned), the supervisor's disappearance or the end of the lifeline (cut)."""
    timed = handle if isinstance(handle, Timed) else None
    while True:
        item = inbox.get(_timeout(timed))
        if isinstance(item, Received):
            if item.key == STOP_KEY:
                return _stopped(name, item.payload, handle, publishers)
            handle(item.key, item.payload)
        elif item == f"-{SUPERVISOR_ALIVE}":
            log.warning("%s: the supervisor is gone, stopping", name)
            return None
        if cut is not None and cut.is_set():
            return None  # the lifeline (or the host) said why
        if timed is not None:
            timed.on_time()  # it checks what is due


def _answer(session: zenoh.Session, key: str, hello: Message) -> zenoh.Queryable[None]:
    """A queryable that answers every query on key with hello."""
    payload = encode(hello)
    return session.declare_queryable(key, lambda query: query.reply(key, payload))


def _stopped(name: str, payload: bytes, handle: Handler | Timed | Reporting, publishers: Publishers) -> str:
    """The supervisor's stop message, its reason returned: a Reporting handler's final report goes out (before the
    process's token goes: the supervisor waits for that); the end of the run says nothing more; any other reason
    (e.g. this process was refused) is told."""
    if isinstance(handle, Reporting):
        publishers.put(*handle.final_report())
    try:
        reason = Stop.from_message(decode(payload)).reason
    except ValueError as exc:  # a stop all the same: the process stops, and says what it could not read
        reason = f"a stop message that does not read ({exc})"
    if reason != STOP_END:
        log.warning("%s: stopped by the supervisor: %s", name, reason)
    return reason


def _timeout(timed: Timed | None) -> float:
    due = timed.due() if timed is not None else None
    return POLL if due is None else min(POLL, max(0.0, due - time.time()))
