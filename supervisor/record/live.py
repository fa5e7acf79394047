"""The live view: a run's (or a replay's) Foxglove scene and cpf records served over Foxglove's WebSocket protocol (`cpf
run --live`, `cpf replay --live`), by the foxglove-sdk's server (Rust, on its own threads).

What it serves: the foxglove/* channels with Foxglove's schemas (record.scene.foxglove_schemas), built by the log's
own builder as the records come in (record.scene.live.LiveScene), or taken from a log that has them (a replay); and
every cpf record on its topic with its cpf JSON schema, in the log's form, so a layout made for a log works live.
Times are simulation times (ns, as the log's), and the server announces the simulation time (Foxglove's Time
capability, as foxglove_bridge does with a simulated clock), so Foxglove's clock follows the run, not the wall.

While nobody is connected, a record costs a dictionary look-up and the server's check that no client subscribes to
its channel: nothing is encoded, and no scene is built (it was ~0.2 s of CPU in a paper run, 10 % of an in-process
run): the scene takes only the run's meta, graphs and faults until a client subscribes to one of its channels. The
foxglove package is imported here only: `cpf` without --live and the vehicle processes never load it."""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Callable
from types import TracebackType
from typing import TYPE_CHECKING, Any

import orjson

from comms.records.messages import FAULT_KEY, GRAPH_KEY, META_KEY
from comms.records.schemas import schema_for
from supervisor.errors import ScenarioError
from supervisor.record.relay_process import RelayProcess
from supervisor.record.scene.foxglove_schemas import (
    MESSAGE_ENCODING,
    PATHS_TOPIC,
    SCENE_TOPIC,
    SCHEMA_ENCODING,
    TRANSFORMS_TOPIC,
    is_scene_topic,
    schema_data,
)
from supervisor.record.scene.foxglove_schemas import schema_name as foxglove_schema
from supervisor.record.scene.live import LiveScene

if TYPE_CHECKING:
    import foxglove

log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)
HOST = "127.0.0.1"  # localhost only: the protocol has no authentication
DEFAULT_PORT = 8765  # Foxglove's default for a WebSocket connection
CLOCK_PERIOD = 0.1  # s of simulated time between the server's time announcements
WATCH_PERIOD = 0.5  # s of simulated time between looks at whether a client watches the scene (an instant's worth)
ALWAYS = (META_KEY, GRAPH_KEY, FAULT_KEY)  # what the scene takes even while nobody watches: few, and needed later
JSON_OPTIONS = orjson.OPT_NON_STR_KEYS | orjson.OPT_SERIALIZE_NUMPY  # as the recorder: NaN and inf as null
# What a new subscriber needs at once (as a ROS latched topic): the latest message of each is sent to whoever
# subscribes, whenever that is (the run's meta and graph come once, at the start; the paths once, redrawn rarely).
LATCHED = frozenset((META_KEY, GRAPH_KEY, PATHS_TOPIC))
NORMAL = (1000, "the run is over")  # close codes (RFC 6455, 7.4.1): normal closure
GOING_AWAY = (1001, "cpf stopped")  # the server going down before the run's end (Ctrl-C, an error)


class _Latching:
    """The server's listener (foxglove.websocket.ServerListener): a subscription to a latched topic gets its latest."""

    def __init__(self, view: LiveView) -> None:
        self._view = view

    def on_subscribe(self, client: Any, channel: Any) -> None:  # foxglove.websocket.Client, ChannelView
        self._view.subscribed(channel.topic)

    def on_unsubscribe(self, client: Any, channel: Any) -> None:  # called too (a missing method: an error logged)
        return None


class LiveView:
    """A Foxglove WebSocket server on HOST:port (0: a free port; `port` is the one it got) for one run or replay.
    `take` each record as it is made; `finish` when the run is over; `stop` (or leave the `with`) in every case.
    build_scene: build the foxglove/* channels from the records (False: they come from a log, through `take`).
    on_subscribe: told each topic a client subscribes to (on the server's thread), say to tell the user.
    ScenarioError if the port cannot be had."""

    def __init__(self, port: int, build_scene: bool = True, on_subscribe: Callable[[str], None] | None = None) -> None:
        import foxglove

        self._foxglove = foxglove
        self._context = foxglove.Context()  # its own channels and server: nothing shared with another view
        self._server, self._relay = self._serve(port)
        self.port: int = self._relay.port
        self.scene: LiveScene | None = LiveScene() if build_scene else None
        self._build = build_scene
        self._on_subscribe = on_subscribe
        self._latched: dict[str, tuple[bytes, int]] = {}  # topic of LATCHED -> its latest message, its log time (ns)
        self._latch = threading.Lock()  # a latched message and its sending, against a subscriber's copy of it
        self._finished = False
        # The scene's fixed channels advertised at once: a client can subscribe before the first message (a trail's
        # channel, per vehicle, comes with its first message, as a cpf record's).
        self._channels: dict[str, foxglove.Channel] = {t: self._channel(t) for t in (TRANSFORMS_TOPIC, SCENE_TOPIC,
                                                                                     PATHS_TOPIC)}  # fmt: skip
        self._clock = -1.0  # s: the simulation time last announced
        self._watched = False  # whether a client subscribes to a scene channel (looked at every WATCH_PERIOD)
        self._look_again = 0.0  # s of simulated time
        self.served = 0  # messages handed to the server with a client subscribed

    def _serve(self, port: int) -> tuple[foxglove.websocket.WebSocketServer, RelayProcess]:
        """foxglove-sdk's server on a free port, the relay on `port` in front of it (ScenarioError if not to be had)."""
        fox = self._foxglove
        try:
            server = fox.start_server(name="cpf", host=HOST, port=0, context=self._context,
                                      capabilities=[fox.Capability.Time], server_listener=_Latching(self))  # fmt: skip
        except RuntimeError as exc:  # FoxgloveError: no port to be had
            raise ScenarioError(f"--live: cannot serve on {HOST} ({exc})") from None
        try:
            return server, RelayProcess(HOST, port, server.port)
        except OSError as exc:  # the port is taken, or not ours to bind
            server.stop()
            raise ScenarioError(f"--live: cannot serve on {HOST}:{port} ({exc.strerror or exc})") from None

    @property
    def url(self) -> str:
        return f"ws://{HOST}:{self.port}"

    def take(self, topic: str, t: float, message: Any) -> None:
        """A record at simulation time t (s): served on its topic, and into the scene (a foxglove/* message of a
        log is served as it is). While no client watches the scene, only the run's meta, graphs and faults go into
        it (the scene's cost, most of the view's, is then not paid): a client that comes later sees trails and link
        colours from when it came."""
        self.publish(topic, t, message)
        if self.scene is None or is_scene_topic(topic):
            return
        if t >= self._look_again:
            self._look_again = t + WATCH_PERIOD
            self._watched = any(c.has_sinks() for name, c in self._channels.items() if is_scene_topic(name))
        if self._watched or topic in ALWAYS:
            for scene_topic, at, scene_message in self.scene.take(topic, message):
                self.publish(scene_topic, at, scene_message)

    def publish(self, topic: str, t: float, message: Any) -> None:
        """One message on its channel at simulation time t (s), encoded only if a client subscribes to it (or it is
        latched: kept for whoever subscribes later)."""
        channel = self._channels.get(topic)
        if channel is None:
            channel = self._channels[topic] = self._channel(topic)
        if topic in LATCHED:
            self._publish_latched(channel, topic, orjson.dumps(message, option=JSON_OPTIONS), round(t * 1e9))
        elif channel.has_sinks():
            channel.log(orjson.dumps(message, option=JSON_OPTIONS), log_time=round(t * 1e9))
            self.served += 1
        if t >= self._clock + CLOCK_PERIOD:
            self._clock = t
            self._server.broadcast_time(round(t * 1e9))

    def _publish_latched(self, channel: foxglove.Channel, topic: str, data: bytes, ns: int) -> None:
        with self._latch:
            self._latched[topic] = (data, ns)
            if channel.has_sinks():
                channel.log(data, log_time=ns)
                self.served += 1

    def subscribed(self, topic: str) -> None:
        """A client has subscribed to topic (the server's thread): a latched topic's latest message sent again. To
        every subscriber of the topic: the Python API does not name the new one's sink; the others get a copy of a
        message they have (meta, a graph, the paths: a few, and a copy changes nothing they show)."""
        channel = self._channels.get(topic)
        with self._latch:
            latest = self._latched.get(topic)
            if latest is not None and channel is not None:
                channel.log(latest[0], log_time=latest[1])
        if self._on_subscribe is not None:
            self._on_subscribe(topic)

    def finish(self) -> None:
        """The run is over: the scene's last instants out (and the clients' connections will close with 1000,
        normal closure, rather than 1001, going away)."""
        self._finished = True
        if self.scene is not None:
            for topic, t, message in self.scene.finish():
                self.publish(topic, t, message)

    def use_log_scene(self) -> None:
        """The foxglove/* messages come from a log (through `take`, a replay's): none is built."""
        self._build = False
        self.scene = None

    def restart(self) -> None:
        """What follows starts again at another time (a replay's seek): a new scene, the clock free to go back."""
        self.scene = LiveScene() if self._build else None
        self._clock = -1.0
        self._look_again = 0.0

    def stop(self) -> None:
        """The server stopped, each client's connection closed (after what was sent to it: with 1000 after `finish`,
        else 1001) and the channels closed; again: nothing."""
        try:
            self._relay.closing(*(NORMAL if self._finished else GOING_AWAY))
            self._server.stop()
        finally:
            self._relay.stop()
            for channel in self._channels.values():
                channel.close()
            self._channels.clear()

    def _channel(self, topic: str) -> foxglove.Channel:
        """A topic's channel: Foxglove's schema for a foxglove/* topic, the cpf schema of a cpf key (none for a key
        cpf does not know: any JSON)."""
        fox = self._foxglove
        name = foxglove_schema(topic)
        if name is not None:
            schema = fox.Schema(name=name, encoding=SCHEMA_ENCODING, data=schema_data(name))
            return fox.Channel(topic, schema=schema, message_encoding=MESSAGE_ENCODING, context=self._context)
        cpf = schema_for(topic)
        if cpf is None:
            return fox.Channel(topic, message_encoding=MESSAGE_ENCODING, context=self._context)
        schema = fox.Schema(name=str(cpf["title"]), encoding=SCHEMA_ENCODING, data=json.dumps(cpf).encode())
        return fox.Channel(topic, schema=schema, message_encoding=MESSAGE_ENCODING, context=self._context)

    def __enter__(self) -> LiveView:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.stop()
