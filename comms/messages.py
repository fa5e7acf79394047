"""Key expressions and message schemas: the one place that says what travels on the bus and lands in the log.

Every message is a flat dict of JSON-compatible values. On Zenoh it travels as msgpack; in MCAP it is stored as JSON
with a JSON-Schema (what Foxglove and `mcap cat --json` read). Simulation time: float seconds in messages (`t`),
integer nanoseconds as MCAP log time. Vectors are lists; `rotation` is R row-major (9 numbers). `k` is the sync-step
index. Parsers (`parse_*`) raise ValueError for anything malformed: receivers count and drop such messages.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import msgpack

from comms.channel import LinkEvent, Reception
from comms.fields import Message
from comms.fields import get as _get
from comms.fields import is_int as _is_int
from comms.fields import number as _number
from comms.network import Network
from comms.records import Disturbances, Heard, Transmission
from comms.state import StateReport

ROOT = "cpf"
META_KEY = f"{ROOT}/run/meta"
FAULT_KEY = f"{ROOT}/run/fault"
GRAPH_KEY = f"{ROOT}/run/graph"
STOP_KEY = f"{ROOT}/run/stop"
TICK_KEY = f"{ROOT}/clock/tick"
COMMS_EVENT_KEY = f"{ROOT}/comms/event"  # the log: one record per link event
COMMS_EVENTS_KEY = f"{ROOT}/comms/events"  # the bus: the link events of one step, in one message
COMMS_STEP_KEY = f"{ROOT}/comms/step"  # the bus: tick k and every vehicle's reception batch, in one message
COMMS_DONE_KEY = f"{ROOT}/comms/done"
COMMS_STATS_KEY = f"{ROOT}/comms/stats"
ALIVE_PREFIX = f"{ROOT}/alive"
SUPERVISOR_ALIVE = f"{ALIVE_PREFIX}/supervisor"
COMMS_ALIVE = f"{ALIVE_PREFIX}/comms"
HELLO_PREFIX = f"{ROOT}/hello"  # queryables: each process says which scenario it runs (hello_message)
STOP_END = "end of run"  # the stop message's reason when the run finished


def state_key(vehicle_id: int) -> str:
    """Per-vehicle state telemetry, one message per sync step."""
    return f"{ROOT}/vehicle/{vehicle_id}/state"


def tx_key(vehicle_id: int) -> str:
    """A vehicle's transmissions (what its modem sends)."""
    return f"{ROOT}/vehicle/{vehicle_id}/tx"


def rx_key(vehicle_id: int) -> str:
    """A vehicle's receptions: one batch per sync step, possibly empty."""
    return f"{ROOT}/vehicle/{vehicle_id}/rx"


def vehicle_alive_key(vehicle_id: int) -> str:
    return f"{ALIVE_PREFIX}/vehicle/{vehicle_id}"


def hello_key(alive_key: str) -> str:
    """Where the process holding a liveliness token answers which scenario it runs: cpf/hello/<what follows
    cpf/alive/>. It declares the queryable before its token, so whoever sees the token can ask at once."""
    return HELLO_PREFIX + alive_key.removeprefix(ALIVE_PREFIX)


def vehicle_of_key(key: str) -> tuple[int, str] | None:
    """(vehicle id, leaf) for cpf/vehicle/<id>/<leaf> keys; None for any other key."""
    parts = key.split("/")
    if len(parts) == 4 and parts[0] == ROOT and parts[1] == "vehicle" and parts[2].isascii() and parts[2].isdigit():
        return int(parts[2]), parts[3]
    return None


# --- wire format --------------------------------------------------------------------------------------------


def encode(message: Message | list[Any]) -> bytes:
    """Wire format (msgpack): a message, or a list packed on its own inside one (encode_list)."""
    data: bytes = msgpack.packb(message, use_bin_type=True)
    return data


def _unpack(data: bytes, what: str) -> Any:
    try:
        return msgpack.unpackb(data, raw=False, strict_map_key=False)
    except Exception as exc:  # msgpack raises several unrelated types for garbage
        raise ValueError(f"undecodable {what}: {exc}") from exc


def decode(data: bytes) -> Message:
    """Inverse of encode; raises ValueError for anything that is not a msgpack map."""
    message = _unpack(data, "message")
    if not isinstance(message, dict):
        raise ValueError(f"message is a {type(message).__name__}, not a map")
    return message


# --- building messages ----------------------------------------------------------------------------------------


def tx_message(tx: Transmission) -> Message:
    """A transmission's wire form (Transmission.to_message)."""
    return tx.to_message()


def rx_message(
    vehicle_id: int, k: int, t: float, receptions: list[Reception], wall_of: Callable[[float], float] | None = None
) -> Message:
    """Receptions for step k. Realtime deliveries also carry `due`: the wall-clock time (wall_of(arrival)) at
    which each should reach the vehicle, so it can measure how late it did."""
    return {"t": t, "k": k, "vehicle": vehicle_id, "receptions": [_reception(r, wall_of) for r in receptions]}


def _reception(r: Reception, wall_of: Callable[[float], float] | None) -> Message:
    item = {"sender": r.sender, "seq": r.seq, "stamp": r.stamp, "arrival": r.arrival, "gamma": r.gamma,
            "gamma_dot": r.gamma_dot}  # fmt: skip
    if wall_of is not None:
        item["due"] = wall_of(r.arrival)
    return item


def batches_message(tick: Message, batches: dict[int, list[Reception]] | None) -> Message:
    """What every vehicle needs to run step k, in one message the broker publishes for the whole fleet: the tick and
    each vehicle's receptions (batches None: the broker is down, the supervisor says so itself). Each vehicle's
    receptions are packed on their own (vehicle id -> msgpack bytes), so a vehicle unpacks only its own: the whole
    message grows with the fleet, and every vehicle reads it."""
    rx = None if batches is None else {v: encode_list([_reception(r, None) for r in batches[v]]) for v in batches}
    return {"t": tick["t"], "k": tick["k"], "tick": tick, "rx": rx}


def parse_batches(message: Message, vid: int) -> tuple[Tick, Message | None]:
    """(tick, vid's reception batch as an rx message) of a batches message; the batch is None if the broker is
    down, empty if the broker has nothing for vid."""
    tick = parse_tick(_get(message, "tick", dict))
    batches = message.get("rx")
    if batches is None:
        return tick, None
    if not isinstance(batches, dict):
        raise ValueError("field 'rx' is not a map of vehicle id to packed receptions")
    packed = batches.get(vid)
    if packed is not None and not isinstance(packed, bytes):
        raise ValueError(f"the receptions of vehicle {vid} are not packed bytes")
    mine = decode_list(packed) if packed is not None else []
    return tick, {"t": tick.t, "k": tick.k, "vehicle": vid, "receptions": mine}


encode_list = encode  # a vehicle's receptions, packed on their own inside the batches message


def decode_list(data: bytes) -> list[Any]:
    """Inverse of encode_list; ValueError for anything that is not a msgpack array."""
    items = _unpack(data, "receptions")
    if not isinstance(items, list):
        raise ValueError("packed receptions are not a list")
    return items


def step_message(state: Message, tx: Message | None, rx: Message | None) -> Message:
    """What a vehicle publishes once per step on its state key: its state, with the transmission it made and the
    reception batch it took in (one bus message instead of three; the log splits it back with split_step)."""
    return {**state, "tx": tx, "rx": rx}


def split_step(message: Message) -> tuple[Message, Message | None, Message | None]:
    """(state, tx, rx) records of a vehicle's step message, as the log keeps them."""
    state = dict(message)
    tx, rx = state.pop("tx", None), state.pop("rx", None)
    return state, tx if isinstance(tx, dict) else None, rx if isinstance(rx, dict) else None


def event_message(event: LinkEvent) -> Message:
    return {
        "t": event.t,
        "sender": event.sender,
        "receiver": event.receiver,
        "seq": event.seq,
        "kind": event.kind,
        "delay": event.delay,
        "reason": event.reason,
    }


def events_message(t: float, k: int, events: list[LinkEvent]) -> Message:
    """The bus form of one step's link events (the log keeps one cpf/comms/event record per event)."""
    return {"t": t, "k": k, "events": [event_message(event) for event in events]}


def tick_message(
    k: int,
    t: float,
    final: bool,
    disturbed: dict[int, Disturbances] | None = None,
    network: Network | None = None,
    alive: list[int] | None = None,
    comms: bool = True,
    wall: float | None = None,
    speed: float = 1.0,
    hold: bool = False,
) -> Message:
    """The supervisor's clock: step k starts at t. With it, what acts over the step: faults on vehicles (only those
    with any), the network (graph and link faults), the vehicles alive, whether the broker is up. Realtime runs
    also say when t is on the wall clock (time.time()) and how fast simulation time runs: wall + (t' - t) / speed.
    hold: a process is killed or restarted at the next tick, so this step's transmissions wait for it (realtime
    brokers otherwise send them before the next tick, which alone says who survived the step)."""
    return {
        "t": t,
        "k": k,
        "final": final,
        "vehicles": [_disturbed(vid, d) for vid, d in sorted((disturbed or {}).items())],
        "network": network.message() if network is not None else None,
        "alive": alive,
        "comms": comms,
        "wall": wall,
        "speed": speed,
        "hold": hold,
    }


def _disturbed(vid: int, d: Disturbances) -> Message:
    return {"vehicle": vid, "cap": d.gamma_dot_cap, "freeze": d.gamma_freeze, "offset": d.gamma_offset,
            "skew": d.clock_offset}  # fmt: skip


def hello_message(process: str, digest: str, sections: dict[str, str]) -> Message:
    """A process's answer on its hello key: the sha256 (hex) of the scenario it runs, as validated (and of the
    run's seed where it uses it), as a whole and per top-level section, so a supervisor can say what differs."""
    return {"process": process, "digest": digest, "sections": dict(sections)}


@dataclass(frozen=True, slots=True)
class Hello:
    process: str
    digest: str
    sections: dict[str, str]


def parse_hello(message: Message) -> Hello:
    sections = _get(message, "sections", dict)
    if not all(isinstance(k, str) and isinstance(v, str) for k, v in sections.items()):
        raise ValueError("field 'sections' is not a map of section name to digest")
    return Hello(_get(message, "process", str), _get(message, "digest", str), sections)


# --- parsing what arrives -------------------------------------------------------------------------------------


def parse_tx(message: Message, key_vehicle: int) -> Transmission:
    """A transmission, checked (Transmission.from_message)."""
    return Transmission.from_message(message, key_vehicle)


def parse_rx(message: Message) -> tuple[int, list[Heard]]:
    """(k, receptions as heard) of a reception batch."""
    k = _get(message, "k", int)
    heard = []
    for item in _get(message, "receptions", list):
        if not isinstance(item, dict):
            raise ValueError("a reception is not a map")
        heard.append(
            Heard(_get(item, "sender", int), _number(item, "stamp"), _number(item, "gamma"), _number(item, "gamma_dot"))
        )
    return k, heard


def parse_timed_rx(message: Message) -> tuple[int, list[tuple[Heard, float, float, Message]]]:
    """(k, (heard, arrival, due, item) of each realtime delivery) of a reception batch; all checked before any is
    used."""
    k, heard = parse_rx(message)
    items = message["receptions"]
    return k, [(h, _number(i, "arrival"), _number(i, "due"), i) for h, i in zip(heard, items, strict=True)]


def parse_state(message: Message, key_vehicle: int) -> StateReport:
    """A state report, checked (StateReport.from_message)."""
    return StateReport.from_message(message, key_vehicle)


MAX_TICK_LEAD = 0.02  # s of wall clock


def tick_lead(dt: float, speed: float) -> float:
    """How long (wall clock) before its time a realtime tick goes out: processes act on it at its time by their own
    clocks, so the bus's latency is not in the step's. At most a quarter step, and MAX_TICK_LEAD."""
    return min(MAX_TICK_LEAD, 0.25 * dt / speed)


@dataclass(frozen=True, slots=True)
class Tick:
    k: int
    t: float
    final: bool
    disturbed: dict[int, Disturbances]
    network: Network | None  # None: the scenario's graph, no link faults
    alive: list[int] | None  # None: every vehicle
    comms: bool
    wall: float | None = None  # realtime: the wall-clock time (time.time()) of t; None: lockstep
    speed: float = 1.0  # realtime: simulated seconds per wall-clock second
    hold: bool = False  # a process is killed or restarted at the next tick: this step's packets wait for it

    def wall_of(self, t: float) -> float:
        """The wall-clock time of simulation time t (realtime runs only)."""
        assert self.wall is not None
        return self.wall + (t - self.t) / self.speed


def parse_tick(message: Message) -> Tick:
    disturbed: dict[int, Disturbances] = {}
    for item in _get(message, "vehicles", list):
        if not isinstance(item, dict):
            raise ValueError("a vehicle entry is not a map")
        cap = None if item.get("cap") is None else _number(item, "cap")
        disturbed[_get(item, "vehicle", int)] = Disturbances(
            cap, _get(item, "freeze", bool), _number(item, "offset"), _number(item, "skew")
        )
    for required in ("network", "alive"):
        if required not in message:  # null is meaningful (no faults, everyone alive); absent is not
            raise ValueError(f"missing field {required!r}")
    net = message.get("network")
    alive = message.get("alive")
    if alive is not None and not (isinstance(alive, list) and all(_is_int(v) for v in alive)):
        raise ValueError("field 'alive' is not a list of vehicle ids")
    return Tick(
        _get(message, "k", int), _number(message, "t"), _get(message, "final", bool), disturbed,
        None if net is None else _network(net), alive, _get(message, "comms", bool), *_realtime(message),
        _get(message, "hold", bool) if "hold" in message else False,
    )  # fmt: skip


def _realtime(message: Message) -> tuple[float | None, float]:
    """(wall, speed) of a tick; absent in lockstep ticks and in logs older than realtime delivery."""
    wall = None if message.get("wall") is None else _number(message, "wall")
    speed = _number(message, "speed") if "speed" in message else 1.0
    if speed <= 0.0:
        raise ValueError("field 'speed' is not positive")
    return wall, speed


def _pairs(items: object, width: int, name: str) -> list[list[Any]]:
    if not isinstance(items, list) or not all(isinstance(i, list) and len(i) == width for i in items):
        raise ValueError(f"field {name!r} is not a list of {width}-item lists")
    return items


def _network(net: object) -> Network:
    if not isinstance(net, dict):
        raise ValueError("field 'network' is not a map")
    edges = _pairs(net.get("edges"), 2, "edges")
    down = _pairs(net.get("down"), 2, "down")
    degraded = _pairs(net.get("degraded"), 4, "degraded")
    silent = net.get("silent")
    links = [pair[:2] for pair in edges + down + degraded]
    if not all(_is_int(v) for pair in links for v in pair):
        raise ValueError("field 'network' has a link whose ends are not vehicle ids")
    if not isinstance(silent, list) or not all(_is_int(v) for v in silent):
        raise ValueError("field 'silent' is not a list of vehicle ids")
    return Network(
        tuple((a, b) for a, b in edges),
        frozenset((a, b) for a, b in down),
        {(s, r): (_number({"l": loss}, "l"), _number({"d": delay}, "d")) for s, r, loss, delay in degraded},
        _get(net, "blackout", bool),
        frozenset(silent),
    )


def parse_events(message: Message) -> list[Message]:
    """The event messages of a cpf/comms/events batch (each still to be checked with parse_event)."""
    events = _get(message, "events", list)
    if not all(isinstance(event, dict) for event in events):
        raise ValueError("an event is not a map")
    return events


def parse_event(message: Message) -> LinkEvent:
    kind = _get(message, "kind", str)
    if kind not in ("sent", "delivered", "dropped"):
        raise ValueError(f"unknown event kind {kind!r}")
    delay = None if message.get("delay") is None else _number(message, "delay")
    reason = message.get("reason")
    if reason is not None and not isinstance(reason, str):
        raise ValueError("field 'reason' is not a string")
    return LinkEvent(
        _number(message, "t"), _get(message, "sender", int), _get(message, "receiver", int),
        _get(message, "seq", int), kind, delay, reason,
    )  # fmt: skip
