"""A log keeps a step's link events as one cpf/comms/events record (one record per event, in logs of earlier versions,
made ~80 records a second: over the rate Lichtblick warns of). Every reader goes through
comms.records.events.logged_events, so a log of either form reads, reports and draws the same."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from comms.records.events import logged_events
from comms.records.messages import COMMS_EVENT_KEY, COMMS_EVENTS_KEY
from supervisor.analysis.rundata import load_run
from supervisor.analysis.tables import read_run
from supervisor.analysis.tx_books import transmission_books
from supervisor.config.scenario import load_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from supervisor.record.recorder import Recorder, read_messages
from supervisor.record.scene.foxglove_schemas import is_scene_topic
from supervisor.record.scene_log import scene_of_log
from tests.conftest import CONFIGS, shortened

FAULT = "kind=link_down,sender=1,receiver=2,start=2,end=4"  # dropped events too, not only sent and delivered


@pytest.fixture(scope="module")
def forms(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A 6 s paper run with a link fault, in process, as this version logs it ("new") and as earlier versions did
    ("old": each link event its own cpf/comms/event record at its own time); the other records alike in both."""
    where = tmp_path_factory.mktemp("forms")
    text = shortened((CONFIGS / "paper.toml").read_text(), 6.0)
    scenario_file = where / "s.toml"
    scenario_file.write_text(text)
    scenario = load_scenario(scenario_file, [], [FAULT])
    new = where / "new.mcap"
    run_inprocess(scenario, str(scenario_file), text, new, 0, Progress(6.0, io.StringIO(), enabled=False))
    old = where / "old.mcap"
    with Recorder(old, scene=False) as rec:
        for topic, stamp, message in read_messages(new):
            if is_scene_topic(topic):
                continue
            if topic != COMMS_EVENTS_KEY:
                rec.write(topic, stamp / 1e9, message)
            for event in logged_events(topic, message):
                rec.write(COMMS_EVENT_KEY, float(event["t"]), event)
    return {"new": new, "old": old}


def events_of(path: Path) -> list[Any]:
    return [event for topic, _, message in read_messages(path) for event in logged_events(topic, message)]


def test_the_log_keeps_one_record_per_step_and_both_forms_give_the_same_events(forms):
    logged = read_messages(forms["new"])
    batches = [message for topic, _, message in logged if topic == COMMS_EVENTS_KEY]
    assert not [topic for topic, _, _ in logged if topic == COMMS_EVENT_KEY]
    assert len(batches) == 60 and all(batch["events"] for batch in batches)  # one a step, 0.1 .. 6.0 s
    assert [batch["k"] for batch in batches] == list(range(1, 61))
    assert all(event["t"] <= batch["t"] for batch in batches for event in batch["events"])
    new, old = events_of(forms["new"]), events_of(forms["old"])
    kinds = {event["kind"] for event in new}
    assert kinds == {"sent", "delivered", "dropped"} and len(new) == sum(len(batch["events"]) for batch in batches)
    assert sorted(new, key=str) == sorted(old, key=str)


def test_both_forms_read_report_and_draw_the_same(forms):
    new, old = load_run(forms["new"]), load_run(forms["old"])
    assert sorted(new.links) == sorted(old.links) == [(1, 2), (1, 3), (2, 1), (3, 1)]
    for link, log in new.links.items():
        np.testing.assert_array_equal(log.t, old.links[link].t)
        np.testing.assert_array_equal(log.kind, old.links[link].kind)
    tables = read_run(forms["new"])[0]["link_events"], read_run(forms["old"])[0]["link_events"]
    assert len(tables[0]) == len(events_of(forms["new"])) and tables[0].equals(tables[1])
    assert transmission_books(forms["new"]) == transmission_books(forms["old"])
    assert scene_of_log(forms["new"]) == scene_of_log(forms["old"])


def test_a_batch_whose_events_are_no_list_is_named_and_other_records_hold_none():
    with pytest.raises(ValueError, match="events"):
        logged_events(COMMS_EVENTS_KEY, {"t": 0.1, "k": 1, "events": 3})
    assert logged_events("cpf/run/meta", {"t": 0.0}) == []
    assert logged_events(COMMS_EVENT_KEY, {"t": 0.1}) == [{"t": 0.1}]
