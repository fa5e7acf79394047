"""Key expressions and message schemas: the one place that says what travels on the bus and lands in the log.

Every message is a flat dict of JSON-compatible values. On Zenoh it travels as msgpack; in MCAP it is stored as JSON
with a JSON-Schema (what Foxglove and `mcap cat --json` read). Simulation time: float seconds in messages (`t`),
integer nanoseconds as MCAP log time. Vectors are lists; `rotation` is R row-major (9 numbers). `k` is the sync-step
index. Parsers (`parse_*`) raise ValueError for anything malformed: receivers count and drop such messages.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import msgpack
import msgspec

from comms.records.bounded import MALFORMED, brief, dropped, read_bytes
from comms.records.fields import Message, as_message, is_int, read_as
from comms.records.fields import get as _get
from comms.records.network import Network
from comms.records.receptions import Delivery, RxBatch
from comms.records.records import Disturbances, Heard, LinkEvent, Reception, Transmission
from comms.records.state import StateReport
from comms.records.tick import Tick

ROOT = "cpf"
META_KEY = f"{ROOT}/run/meta"
FAULT_KEY = f"{ROOT}/run/fault"
GRAPH_KEY = f"{ROOT}/run/graph"
STOP_KEY = f"{ROOT}/run/stop"
RUN_DONE_KEY = f"{ROOT}/run/done"  # the log only: the supervisor's end-of-run report (comms.records.reports)
LOG_ONLY = frozenset({RUN_DONE_KEY})  # keys a log has and the bus never carries (a replay leaves them out)
FLUSH_KEY = f"{ROOT}/run/flush"  # queryable: a client's last messages are in before it closes (comms.bus.bus.flush)
TICK_KEY = f"{ROOT}/clock/tick"
COMMS_EVENT_KEY = f"{ROOT}/comms/event"  # logs of earlier versions: one record per link event (still read)
COMMS_EVENTS_KEY = f"{ROOT}/comms/events"  # bus and log: the link events of one step (comms.records.events.LinkEvents)
COMMS_STEP_KEY = f"{ROOT}/comms/step"  # the bus: tick k and every vehicle's reception batch, in one message
COMMS_DONE_KEY = f"{ROOT}/comms/done"
COMMS_STATS_KEY = f"{ROOT}/comms/stats"
ALIVE_PREFIX = f"{ROOT}/alive"
SUPERVISOR_ALIVE = f"{ALIVE_PREFIX}/supervisor"
COMMS_ALIVE = f"{ALIVE_PREFIX}/comms"
HELLO_PREFIX = f"{ROOT}/hello"  # queryables: each process says which scenario it runs (Hello)
STOP_END = "end of run"  # the stop message's reason (comms.records.run.Stop) when the run finished
ANOTHER_SCENARIO = "runs another scenario than the supervisor"  # a stop's reason for a process it refused


def state_key(vehicle_id: int) -> str:
    """Per-vehicle state telemetry, one message per sync step."""
    return f"{ROOT}/vehicle/{vehicle_id}/state"


def tx_key(vehicle_id: int) -> str:
    """A vehicle's transmissions (what its modem sends)."""
    return f"{ROOT}/vehicle/{vehicle_id}/tx"


def rx_key(vehicle_id: int) -> str:
    """A vehicle's receptions: one batch per sync step, possibly empty."""
    return f"{ROOT}/vehicle/{vehicle_id}/rx"


def vehicle_done_key(vehicle_id: int) -> str:
    """A vehicle's end-of-run report (comms.records.reports.VehicleDone): what it dropped as malformed."""
    return f"{ROOT}/vehicle/{vehicle_id}/done"


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


def decode(data: bytes) -> Message:
    """Inverse of encode, through the one bounded reader (comms.records.bounded.read_bytes); raises ValueError (a
    dropped: naming its cause) for anything that is not a msgpack map of bounded size and depth."""
    message = read_bytes(data, "message")
    if not isinstance(message, dict):
        raise dropped(MALFORMED, f"message is a {type(message).__name__}, not a map")
    return message


# --- building messages ----------------------------------------------------------------------------------------


def tx_message(tx: Transmission) -> Message:
    """A transmission's wire form (Transmission.to_message)."""
    return tx.to_message()


def rx_message(
    vehicle_id: int, k: int, t: float, receptions: list[Reception], wall_of: Callable[[float], float] | None = None
) -> Message:
    """Receptions for step k (RxBatch.to_message). Realtime deliveries also carry `due`: the wall-clock time
    (wall_of(arrival)) at which each should reach the vehicle, so it can measure how late it did."""
    return RxBatch.of(vehicle_id, k, t, receptions, wall_of).to_message()


def batches_message(
    tick: Message, batches: dict[int, list[Reception]] | Sequence[dict[int, list[Reception]]] | None
) -> Message:
    """What every vehicle needs to run step k, in one message the broker publishes for the whole fleet: the tick and
    each vehicle's receptions (batches None: the broker is down, the supervisor says so itself). Each vehicle's
    receptions are packed on their own (vehicle id -> msgpack bytes), so a vehicle unpacks only its own: the whole
    message grows with the fleet, and every vehicle reads it. A tick that grants a time window of several steps
    (its `until`) comes with one batch per step of it (a sequence): each vehicle's are packed as one list per step."""
    if batches is None:
        return {"t": tick["t"], "k": tick["k"], "tick": tick, "rx": None}
    if isinstance(batches, dict):
        packed = {v: encode_list([Delivery.of(r).to_message() for r in rs]) for v, rs in batches.items()}
        return {"t": tick["t"], "k": tick["k"], "tick": tick, "rx": packed}
    if len(batches) != tick.get("until", tick["k"] + 1) - tick["k"]:
        raise ValueError(f"{len(batches)} batches for a window of steps {tick['k']} to {tick.get('until')}")
    vehicles = sorted({v for step in batches for v in step})
    per_step = {v: [[Delivery.of(r).to_message() for r in step.get(v, [])] for step in batches] for v in vehicles}
    return {"t": tick["t"], "k": tick["k"], "tick": tick, "rx": {v: encode_list(b) for v, b in per_step.items()}}


def parse_batches(message: Message, vid: int) -> tuple[Tick, Message | None]:
    """(tick, vid's reception batch as an rx message) of a batches message; the batch is None if the broker is
    down, empty if the broker has nothing for vid. A tick of several steps: the batch of its first step
    (parse_window gives them all)."""
    tick, batches = parse_window(message, vid, 0.0)
    return tick, None if batches is None else batches[0]


def parse_window(message: Message, vid: int, dt: float) -> tuple[Tick, list[Message] | None]:
    """(tick, vid's reception batch of each step of the tick's window, as rx messages: step j's at t = j dt) of a
    batches message; None if the broker is down, empty batches if the broker has nothing for vid."""
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
    steps = tick.end - tick.k
    if steps == 1:
        return tick, [{"t": tick.t, "k": tick.k, "vehicle": vid, "receptions": mine}]
    if packed is None:
        mine = [[] for _ in range(steps)]
    if len(mine) != steps or not all(isinstance(step, list) for step in mine):
        raise ValueError(f"the receptions of vehicle {vid} are not one list per step of the window ({steps})")
    times = [tick.t, *(j * dt for j in range(tick.k + 1, tick.end))]  # the window's first step: the tick's own t
    steps_of = zip(range(tick.k, tick.end), times, mine, strict=True)
    return tick, [{"t": t, "k": j, "vehicle": vid, "receptions": rs} for j, t, rs in steps_of]


encode_list = encode  # a vehicle's receptions, packed on their own inside the batches message


def decode_list(data: bytes) -> list[Any]:
    """Inverse of encode_list; ValueError for anything that is not a msgpack array."""
    items = read_bytes(data, "packed receptions")
    if not isinstance(items, list):
        raise dropped(MALFORMED, "packed receptions are not a list")
    return items


def step_message(
    state: Message,
    tx: Message | None,
    rx: Message | None,
    next_tx: int | None = None,
    earlier: list[Message] | None = None,
) -> Message:
    """What a vehicle publishes once per step on its state key: its state, with the transmission it made and the
    reception batch it took in (one bus message instead of three; the log splits it back with split_step).
    Lockstep vehicles also say the first step at which they may transmit next (next_tx), and at the end of a time
    window of several steps carry the step messages of its earlier steps (earlier, in order): the message's own
    state is the window's last, what the broker needs."""
    message = {**state, "tx": tx, "rx": rx}
    if next_tx is not None:
        message["next_tx"] = next_tx
    if earlier:
        message["earlier"] = earlier
    return message


def window_message(steps: list[Message], next_tx: int) -> Message:
    """A vehicle's step messages of one time window (in order) as one message: the last, with next_tx and the
    earlier ones (step_message)."""
    last = steps[-1]  # the vehicle's own fresh dict: no copy on the path of every step
    last["next_tx"] = next_tx
    if len(steps) > 1:
        last["earlier"] = steps[:-1]
    return last


def split_step(message: Message) -> tuple[Message, Message | None, Message | None]:
    """(state, tx, rx) records of a vehicle's step message, as the log keeps them (the window's earlier steps and
    next_tx are not records: split_window reads them)."""
    state = dict(message)
    tx, rx = state.pop("tx", None), state.pop("rx", None)
    state.pop("next_tx", None)
    state.pop("earlier", None)
    return state, tx if isinstance(tx, dict) else None, rx if isinstance(rx, dict) else None


def split_window(message: Message) -> tuple[list[Message], int | None]:
    """(the step messages of a vehicle's window, in order, the last one being message itself; the first step at
    which it may transmit next, None if it does not say) of a vehicle's step message."""
    earlier = message.get("earlier")
    if earlier is not None and not (isinstance(earlier, list) and all(isinstance(m, dict) for m in earlier)):
        raise ValueError("field 'earlier' is not a list of step messages")
    next_tx = message.get("next_tx")
    if next_tx is not None and not is_int(next_tx):
        raise ValueError(f"field 'next_tx' is not a step, got {brief(next_tx)}")
    return [*(earlier or []), message], next_tx


def event_message(event: LinkEvent) -> Message:
    """A link event's wire form (LinkEvent.to_message)."""
    return event.to_message()


def tick_message(
    k: int,
    t: float,
    final: bool,
    disturbed: dict[int, Disturbances] | None = None,
    network: Network | None = None,
    alive: list[int] | tuple[int, ...] | None = None,
    comms: bool = True,
    wall: float | None = None,
    speed: float = 1.0,
    hold: bool = False,
    until: int | None = None,
    span: int | None = None,
    longest: int | None = None,
) -> Message:
    """The supervisor's clock (Tick.to_message; disturbed: only the vehicles with any fault acting)."""
    return Tick.of(k, t, final, disturbed, network, alive, comms, wall, speed, hold, until, span, longest).to_message()


class Hello(msgspec.Struct, frozen=True):
    """A process's answer on its hello key: the sha256 (hex) of the scenario it runs, as validated (and of the run's
    seed where it uses it), as a whole and per top-level section, so a supervisor can say what differs. It is a
    query's reply, never published or logged. The struct is its message's only description (message, checks and
    schema comms.records.schemas.HELLO)."""

    process: str
    digest: str
    sections: dict[str, str]  # section name -> its digest

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object) -> Hello:
        return read_as(message, cls)


# --- parsing what arrives -------------------------------------------------------------------------------------


def parse_tx(message: Message, key_vehicle: int) -> Transmission:
    """A transmission, checked (Transmission.from_message)."""
    return Transmission.from_message(message, key_vehicle)


def parse_rx(message: Message) -> tuple[int, list[Heard]]:
    """(k, receptions as heard) of a reception batch (RxBatch.from_message)."""
    batch = RxBatch.from_message(message)
    return batch.k, batch.heard


def parse_state(message: Message, key_vehicle: int) -> StateReport:
    """A state report, checked (StateReport.from_message)."""
    return StateReport.from_message(message, key_vehicle)


MAX_TICK_LEAD = 0.02  # s of wall clock


def tick_lead(dt: float, speed: float) -> float:
    """How long (wall clock) before its time a realtime tick goes out: processes act on it at its time by their own
    clocks, so the bus's latency is not in the step's. At most a quarter step, and MAX_TICK_LEAD."""
    return min(MAX_TICK_LEAD, 0.25 * dt / speed)


def parse_tick(message: Message) -> Tick:
    """A tick, checked (Tick.from_message)."""
    return Tick.from_message(message)


def parse_event(message: Message) -> LinkEvent:
    """A link event, checked (LinkEvent.from_message)."""
    return LinkEvent.from_message(message)
