"""Replay of a recorded run: every message of an MCAP log published again on Zenoh with its original timing.

`cpf replay RUN.mcap` reads the log in log-time order (streamed, chunk by chunk: a long log is never held in memory),
turns its records back into the messages a live run puts on the bus (tools.replay_bus: the same keys and forms)
and puts each, encoded as msgpack (the live wire format, comms.records.messages.encode), on its key, so a subscriber
written against a live run sees the run again, and the reverse. A window that starts late begins with the latest meta
and graph and the faults in force. The message logged at simulation time t
goes out at wall time t0 + (t - t_first) / speed; speed 0 means as fast as possible (publishers block rather than
drop, so nothing is lost either way). `start` and `end` (simulation seconds, both inclusive) select a window;
`loop` replays it again and again until interrupted. Liveliness keys (cpf/alive/...), the log-only cpf/run/done,
channels that are not JSON and topics that are no valid key expression to publish on are skipped.

Without `connect` the replayer runs its own Zenoh router (on `listen`, default a free localhost port) for
subscribers to connect to; with `connect` it joins that router as a client. `on_ready` is called with one line
saying where ("Zenoh router listening on tcp/127.0.0.1:7447") once the session is open and before the first message:
the command line prints it and waits for Enter or --delay seconds, so subscribers have time to connect.

While it plays it can be steered: paused, resumed, sought to a log time and sped up or slowed down, by queries on
cpf/replay/control (supervisor.tools.replay_control) and, in a terminal, the keyboard (supervisor.cli.replay_keys).
The player (supervisor.tools.replay_player) decides what goes out when; a seek publishes a mark on cpf/replay/seek
and replays from its target, beginning, as a late window does, with the meta, graph and faults in force there.

With a live view (`cpf replay --live`, record.live.LiveView), the records also go to Foxglove, in the log's form, each
as its bus form goes out: the log's own Foxglove scene (never put on the bus), or, for a log without one, a scene built
from the records as they are replayed (started again at a seek).
"""

from __future__ import annotations

import contextlib
import math
import time
from collections import Counter, deque
from collections.abc import Callable, Generator, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import zenoh

from comms.bus.bus import Extras, Publishers, flush, free_port, open_session, site_config
from comms.records.messages import ALIVE_PREFIX, FAULT_KEY, GRAPH_KEY, LOG_ONLY, META_KEY, Message
from supervisor.errors import ScenarioError
from supervisor.record.logfile import LogMessage, messages, open_log, reader_of, verify
from supervisor.record.recorder import seconds_to_ns
from supervisor.record.scene.foxglove_schemas import PATHS_TOPIC, is_scene_topic
from supervisor.tools.replay_bus import bus_form, latched
from supervisor.tools.replay_control import Control, declare_control
from supervisor.tools.replay_player import Player, Publish

if TYPE_CHECKING:
    from supervisor.record.live import LiveView

# (topic, log time ns, message); message None: not to be published (skipped)
Record = tuple[str, int, Message | None]
NS_PER_S = 1e9
LATCHED = (
    META_KEY,
    GRAPH_KEY,
    FAULT_KEY,
)  # state a subscriber joining late needs (supervisor.tools.replay_bus.latched)


@dataclass(slots=True)
class ReplayReport:
    """What a replay published: per topic (over every pass), the window replayed, how long it took."""

    endpoint: str  # where the session was: "Zenoh router listening on ..." or "Zenoh client connected to ..."
    published: Counter[str] = field(default_factory=Counter)
    skipped: int = 0  # liveliness keys, non-JSON channels, topics no key expression can name
    passes: int = 0  # complete passes over the window
    first: float | None = None  # log time (s) of the first message published
    last: float | None = None  # log time (s) of the last message published in the first pass
    wall_time: float = 0.0  # s from the first message published to the end
    interrupted: bool = False  # Ctrl-C
    stopped: bool = False  # the user quit (the keyboard's q)
    seeks: int = 0  # seek marks published (cpf/replay/seek)
    rejected: int = 0  # control commands that did not parse

    @property
    def messages(self) -> int:
        return sum(self.published.values())

    @property
    def span(self) -> float:
        """Simulated seconds from the first to the last message of the window (one pass)."""
        return 0.0 if self.first is None or self.last is None else self.last - self.first

    def describe(self) -> str:
        rate = self.messages / max(self.wall_time, 1e-9)
        window = "nothing" if self.first is None else f"t = {self.first:g}-{self.last:g} s"
        passes = f", {self.passes} complete passes" if self.passes != 1 else ""
        seeks = f", {self.seeks} seek{'s' if self.seeks > 1 else ''}" if self.seeks else ""
        stopped = " (interrupted)" if self.interrupted else " (stopped)" if self.stopped else ""
        plural = "s" if self.rejected > 1 else ""
        rejected = f"; {self.rejected} control command{plural} rejected" if self.rejected else ""
        return (
            f"replayed {self.messages} messages on {len(self.published)} topics ({window}{passes}{seeks}) "
            f"in {self.wall_time:.2f} s, {rate:.0f} messages/s{stopped}{rejected}"
        )


Steer = Callable[[Control], contextlib.AbstractContextManager[object]]  # e.g. the keyboard, while the replay plays


def replay(
    path: Path,
    speed: float = 1.0,
    start: float | None = None,
    end: float | None = None,
    loop: bool = False,
    connect: str | None = None,
    listen: str | None = None,
    on_ready: Callable[[str], None] | None = None,
    progress: Callable[[float], None] | None = None,
    steer: Steer | None = None,
    zenoh_config: Path | None = None,
    live: LiveView | None = None,
) -> ReplayReport:
    """Publish the log's messages with start <= t <= end (s) on Zenoh, paced at speed (0: as fast as possible).

    ScenarioError (nothing opened yet) for a file that is missing, no MCAP, cut short or damaged (LogError), a window
    that selects nothing, or bad arguments; ConnectionError if the session cannot be opened. Ctrl-C
    (KeyboardInterrupt) ends the replay cleanly: the session is closed and the report, marked interrupted, returned.
    progress, if given, is called with the log time (s) of every message published. While it plays, the replay
    answers commands on cpf/replay/control (supervisor.tools.replay_control) and steer(control), if given, is
    entered (after on_ready) to steer it too. zenoh_config: a site's Zenoh config under cpf's settings (its
    credentials to join a router, or its own router's authentication and access control). live: where the records
    and the Foxglove scene go too, paced as the bus messages.
    """
    _check(path, speed, start, end, connect, listen, zenoh_config)
    verify(path)  # a log cut short or damaged is refused before anything is published
    window = (start, end)
    if _first(path, window) is None:
        raise ScenarioError(f"{path}: no message to replay in {_describe_window(window)}")
    report = ReplayReport("")
    feed = _LiveFeed(live, path) if live is not None else None
    player = Player(lambda t: _bus_records(path, (start if t is None else t, end), report, feed), speed,
                    _bounds(path, window), loop)  # fmt: skip
    control = Control(player)
    session, report.endpoint = _open(connect, listen, zenoh_config)
    _serve(session, control, report, (on_ready, progress, steer), feed)
    return report


class _LiveFeed:
    """The records (log form) on their way to a live view, held until the bus message of their time goes out: the
    player reads a little ahead of what it publishes."""

    def __init__(self, live: LiveView, path: Path) -> None:
        self.live = live
        self.scene = _has_scene(path)  # the log's own scene is served; else the view builds one
        if self.scene:
            live.use_log_scene()
        self.held: deque[tuple[str, int, Message]] = deque()
        self.last = -1  # log time (ns) of the last record released

    def hold(self, record: tuple[str, int, Message]) -> None:
        self.held.append(record)

    def release(self, stamp: int | None) -> None:
        """Every record held up to log time stamp (ns; None: all) to the view."""
        while self.held and (stamp is None or self.held[0][1] <= stamp):
            topic, at, message = self.held.popleft()
            if at < self.last:  # a looping replay's next pass: the view starts again
                self.live.restart()
            self.last = at
            self.live.take(topic, at / NS_PER_S, message)

    def restart(self) -> None:
        """A seek: what was read ahead is not published, and the view starts again."""
        self.held.clear()
        self.last = -1
        self.live.restart()


def _serve(
    session: zenoh.Session,
    control: Control,
    report: ReplayReport,
    hooks: tuple[Callable[[str], None] | None, Callable[[float], None] | None, Steer | None],
    feed: _LiveFeed | None,
) -> None:
    """The replay on its session, steerable, until it ends; the session is closed however it ends. hooks: on_ready,
    progress, steer."""
    on_ready, progress, steer = hooks
    began = time.perf_counter()
    try:
        with session, contextlib.ExitStack() as steering:
            queryable = declare_control(session, control)
            if on_ready is not None:
                on_ready(report.endpoint)
            began = time.perf_counter()
            if steer is not None:
                steering.enter_context(steer(control))
            _play(control, Publishers(session), report, progress, feed)
            flush(session)  # read by whoever answers flushes before the session closes (comms.bus.bus.flush)
            queryable.undeclare()
    except KeyboardInterrupt:
        report.interrupted = True
    finally:
        report.passes, report.rejected = control.passes, control.rejected
    report.wall_time = time.perf_counter() - began


def _check(
    path: Path,
    speed: float,
    start: float | None,
    end: float | None,
    connect: str | None,
    listen: str | None,
    zenoh_config: Path | None,
) -> None:
    if math.isnan(speed) or speed < 0:
        raise ScenarioError(f"{path}: --speed: must be >= 0 (0: as fast as possible), got {speed:g}")
    for name, value in (("--start", start), ("--end", end)):
        if value is not None and not (math.isfinite(value) and value >= 0):
            raise ScenarioError(f"{path}: {name}: must be a simulation time >= 0 in s, got {value:g}")
    if start is not None and end is not None and start > end:
        raise ScenarioError(f"{path}: --start ({start:g} s) is after --end ({end:g} s)")
    if connect is not None and listen is not None:
        raise ScenarioError(f"{path}: --listen and --connect exclude each other")
    if zenoh_config is not None:
        try:
            site_config(zenoh_config)
        except ValueError as exc:
            raise ScenarioError(f"--zenoh-config: {exc}, got {zenoh_config}") from None


def _describe_window(window: tuple[float | None, float | None]) -> str:
    start, end = window
    if start is None and end is None:
        return "the whole log"
    return f"t = {'the start' if start is None else f'{start:g} s'} to {'the end' if end is None else f'{end:g} s'}"


def _open(connect: str | None, listen: str | None, zenoh_config: Path | None) -> tuple[zenoh.Session, str]:
    extras = Extras(zenoh_config)
    if connect is not None:
        return open_session("client", connect=[connect], extras=extras), f"Zenoh client connected to {connect}"
    endpoint = listen or f"tcp/127.0.0.1:{free_port()}"
    return open_session("router", listen=[endpoint], extras=extras), f"Zenoh router listening on {endpoint}"


def _bounds(path: Path, window: tuple[float | None, float | None]) -> tuple[float, float | None]:
    """The log times (s) a seek is held within: the window, closed by the log's last message where it is open."""
    start, end = window
    if end is None:
        with open_log(path) as stream:
            summary = reader_of(stream).get_summary()
        statistics = None if summary is None else summary.statistics
        end = None if statistics is None else statistics.message_end_time / NS_PER_S
    return (start or 0.0), end


# --- reading the log ------------------------------------------------------------------------------------------


def _first(path: Path, window: tuple[float | None, float | None]) -> Record | None:
    """The first record of the window that would be published, if any."""
    with contextlib.closing(_records(path, window)) as records:
        return next((record for record in records if record[2] is not None), None)


def _records(
    path: Path, window: tuple[float | None, float | None], scene: bool = False
) -> Generator[Record, None, None]:
    """The log's records of the window in log-time order, read chunk by chunk (scene: its Foxglove scene too);
    LogError (record.logfile) for a log that is missing, not an MCAP, cut short or damaged."""
    start, end = window
    playable: dict[str, bool] = {}
    begin, until = None if start is None else seconds_to_ns(start), None if end is None else seconds_to_ns(end)
    # The log's Foxglove scene (record.scene) is its view of the run: no run publishes it on the bus.
    for topic, stamp, message in messages(
        path, lambda topic: scene or not is_scene_topic(topic), begin, until, verified=True
    ):
        if topic not in playable:
            playable[topic] = _playable(topic)
        yield topic, stamp, message if playable[topic] and isinstance(message, dict) else None


def _bus_records(
    path: Path, window: tuple[float | None, float | None], report: ReplayReport, feed: _LiveFeed | None = None
) -> Generator[tuple[str, int, Message], None, None]:
    """The window's records in the form a live run publishes them (supervisor.tools.replay_bus), after what a subscriber
    needs first when the window starts late (latest meta and graph, faults in force), stamped at its start. Records
    not to be published are counted as skipped. feed: where each record goes, in its log form (and the log's scene)."""
    meta = next((m for _, _, m in messages(path, lambda topic: topic == META_KEY, verified=True)), None)
    start = window[0]
    if start is not None and start > 0:
        begin = seconds_to_ns(start)
        before = messages(path, lambda topic: topic in LATCHED or topic == PATHS_TOPIC, None, begin - 1, verified=True)
        for topic, _, message in _latched(before, feed):
            if feed is not None:
                feed.hold((topic, begin, message))
            if not is_scene_topic(topic):
                yield topic, begin, message

    def playable() -> Generator[Record, None, None]:
        with contextlib.closing(_records(path, window, feed is not None and feed.scene)) as records:
            for topic, stamp, message in records:
                if message is None:
                    report.skipped += 1
                    continue
                if feed is not None:
                    feed.hold((topic, stamp, message))
                if not is_scene_topic(topic):  # the log's scene goes to the live view only
                    yield topic, stamp, message

    with contextlib.closing(playable()) as records:
        yield from bus_form(records, meta if isinstance(meta, dict) else {})


def _latched(before: Iterator[LogMessage], feed: _LiveFeed | None) -> list[tuple[str, int, Message]]:
    """What a subscriber joining late needs first (replay_bus.latched), and the log's last desired paths before then
    for a live view of its scene (it publishes them once, at t = 0)."""
    records = [(m.topic, m.log_time, m.message) for m in before]
    paths = [r for r in records if r[0] == PATHS_TOPIC] if feed is not None and feed.scene else []
    return latched(r for r in records if r[0] != PATHS_TOPIC) + paths[-1:]


def _has_scene(path: Path) -> bool:
    """Whether the log has its Foxglove scene (record.scene) among its channels."""
    with open_log(path) as stream:
        summary = reader_of(stream).get_summary()
    return summary is not None and any(is_scene_topic(c.topic) for c in summary.channels.values())


def _playable(topic: str) -> bool:
    """Whether a topic's messages can go back on the bus: not a liveliness key nor one the live run never put on it
    (LOG_ONLY), a key one can put on."""
    if topic.startswith(f"{ALIVE_PREFIX}/") or topic == ALIVE_PREFIX or topic in LOG_ONLY:
        return False
    if "*" in topic or "$" in topic:
        return False
    try:
        zenoh.KeyExpr(topic)
    except zenoh.ZError:
        return False
    return True


# --- publishing -----------------------------------------------------------------------------------------------


def _play(
    control: Control,
    publishers: Publishers,
    report: ReplayReport,
    progress: Callable[[float], None] | None,
    feed: _LiveFeed | None,
) -> None:
    """Publish what the player gives, when it is due, until the window is over (not looping) or the user quits."""
    while isinstance(action := control.next_action(), Publish):
        publishers.put(action.topic, action.message)
        if action.mark:
            report.seeks += 1
            if feed is not None:
                feed.restart()
            continue
        if feed is not None:
            feed.release(action.stamp)
        _count(report, action.topic, action.stamp, control.passes)
        if progress is not None:
            progress(action.stamp / NS_PER_S)
    if feed is not None and not action.quit:
        feed.release(None)
        feed.live.finish()
    report.stopped = action.quit


def wait_until(deadline: float) -> None:
    """Pacing (not synchronisation): sleep until the monotonic clock reaches deadline."""
    while (delay := deadline - time.monotonic()) > 0:
        time.sleep(delay)


def _count(report: ReplayReport, topic: str, stamp: int, passes: int) -> None:
    report.published[topic] += 1
    if report.first is None:
        report.first = stamp / NS_PER_S
    if passes == 0:
        report.last = stamp / NS_PER_S
