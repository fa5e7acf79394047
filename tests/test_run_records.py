"""The run's records (cpf/run/meta, graph, fault, stop) and the bus's batch of link events: a malformed message of
each is refused with a ValueError naming the field (receivers count and drop it; a log reader says which)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import pytest

from comms.records.events import LinkEvents
from comms.records.reports import MAX_KEYS, CommsDone, CommsStats, VehicleDone
from comms.records.run import FaultEvent, Graph, Stop
from supervisor.config.scenario import load_scenario
from supervisor.record.meta import RunMeta
from tests.conftest import CONFIGS

from .test_state_report import LINK_BOOKS, RUN_META

GRAPH = Graph.of(1.0, ((1, 2),)).to_message()
FAULT = FaultEvent(1.0, "speed_cap", "start", {"vehicle": 2}).to_message()
STOP = Stop(1.0, "end of run").to_message()
EVENTS: dict[str, Any] = {"t": 0.2, "k": 2, "events": [{"t": 0.1, "sender": 1, "receiver": 2, "seq": 3, "kind": "sent",
                                        "delay": None, "reason": None}]}  # fmt: skip
META = RUN_META.to_message()
STATS = CommsStats(t=10.0, window=10.0, horizon=36.0, lambda2=1.0, links=(LINK_BOOKS,)).to_message()
DONE = CommsDone(400.0, 4000, 12, 0).to_message()
VEHICLE_DONE = VehicleDone(400.0, 4000, 2, {"cpf/clock/tick": 1}).to_message()
BOOKS = STATS["links"][0]


def read_vehicle_done(message: Any) -> VehicleDone:
    return VehicleDone.from_message(message, 2)


# (how to read, a good message, the field, a bad value for it)
MALFORMED: list[tuple[Callable[[Any], Any], dict[str, Any], str, Any]] = [
    (Graph.from_message, GRAPH, "t", "1.0"),
    (Graph.from_message, GRAPH, "edges", [[1, 2, 3]]),
    (Graph.from_message, GRAPH, "edges", [[1, "2"]]),
    (FaultEvent.from_message, FAULT, "phase", "middle"),
    (FaultEvent.from_message, FAULT, "kind", 3),
    (FaultEvent.from_message, FAULT, "detail", [1]),
    (FaultEvent.from_message, FAULT, "detail", {1: 2}),
    (FaultEvent.from_message, FAULT, "t", float("nan")),
    (Stop.from_message, STOP, "reason", None),
    (Stop.from_message, STOP, "t", True),
    (LinkEvents.from_message, EVENTS, "k", 2.5),
    (LinkEvents.from_message, EVENTS, "events", [{"t": 0.1}]),
    (LinkEvents.from_message, EVENTS, "events", [3]),
    (RunMeta.from_message, META, "seed", "7"),
    (RunMeta.from_message, META, "step", 0.0),
    (RunMeta.from_message, META, "vehicles", [1, "2"]),
    (RunMeta.from_message, META, "edges", [[1]]),
    (RunMeta.from_message, META, "faults", [{"vehicle": 2}]),
    (RunMeta.from_message, META, "versions", {"numpy": 2}),
    (RunMeta.from_message, META, "scenario", "paper"),
    (RunMeta.from_message, META, "clock", None),
    (CommsStats.from_message, STATS, "t", -1.0),
    (CommsStats.from_message, STATS, "window", "10"),
    (CommsStats.from_message, STATS, "horizon", math.inf),
    (CommsStats.from_message, STATS, "lambda2", math.nan),
    (CommsStats.from_message, STATS, "links", [{**BOOKS, "sent": -1}]),
    (CommsStats.from_message, STATS, "links", [{**BOOKS, "dropped": {"loss": 1.5}}]),
    (CommsStats.from_message, STATS, "links", [{**BOOKS, "dropped": {str(n): 1 for n in range(MAX_KEYS + 1)}}]),
    (CommsStats.from_message, STATS, "links", [{**BOOKS, "mean_delay": -0.1}]),
    (CommsStats.from_message, STATS, "links", [{k: v for k, v in BOOKS.items() if k != "receiver"}]),
    (CommsDone.from_message, DONE, "k", -1),
    (CommsDone.from_message, DONE, "events", True),
    (CommsDone.from_message, DONE, "malformed", 1.0),
    (CommsDone.from_message, DONE, "t", math.nan),
    (read_vehicle_done, VEHICLE_DONE, "vehicle", 3),  # not the key's
    (read_vehicle_done, VEHICLE_DONE, "malformed", {"x": -1}),
    (read_vehicle_done, VEHICLE_DONE, "malformed", [1]),
    (read_vehicle_done, VEHICLE_DONE, "k", "4000"),
]


@pytest.mark.parametrize(("read", "good", "name", "bad"), MALFORMED, ids=lambda x: getattr(x, "__qualname__", None))
def test_a_malformed_field_is_refused_by_name(read: Callable[[Any], Any], good: dict[str, Any], name: str, bad: Any):
    read(good)  # the message is good but for the field
    with pytest.raises(ValueError, match=f"'{name}'"):
        read({**good, name: bad})


def test_a_batch_keeps_the_events_that_read_when_asked_to():
    """The supervisor counts the events the broker announced: one that does not read is left out and told, the rest
    of the batch still counts."""
    unread: list[ValueError] = []
    batch = LinkEvents.from_message({**EVENTS, "events": [*EVENTS["events"], {"t": 0.1}]}, unread)
    assert len(batch.events) == 1 and len(unread) == 1 and "missing required field" in str(unread[0])


def test_the_run_meta_of_a_scenario_reads_back():
    scenario = load_scenario(CONFIGS / "paper.toml")
    meta = RunMeta.of(scenario, "configs/paper.toml", "", 7, "inprocess", "lockstep")
    assert RunMeta.from_message(meta.to_message()) == meta
    assert meta.to_message()["edges"] == [{"sender": i, "receiver": j} for i, j in scenario.graph.edges]


def test_links_of_older_logs_read_as_today():
    """Logs before the viewers' schemas (issue 25) have links as [sender, receiver] pairs: they read the same."""
    assert Graph.from_message({"t": 1.0, "edges": [[1, 2], [2, 1]]}) == Graph.of(1.0, ((1, 2), (2, 1)))
    older = {**META, "edges": [list(edge) for edge in RUN_META.edges]}
    assert RunMeta.from_message(older) == RUN_META
    for bad in ([[1, 2, 3]], [[1, "2"]], [[1, 2], {"sender": 1}]):  # not the older form either: the reason stands
        with pytest.raises(ValueError, match=r"\$\.edges"):
            Graph.from_message({"t": 1.0, "edges": bad})
