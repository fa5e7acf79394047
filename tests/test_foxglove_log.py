"""Every log carries the run's Foxglove scene: channels with Foxglove's well-known schemas (JSON), every message
valid against its schema, the same on both engines, and the same as the scene of an older log built afterwards.

    vehicle 2 ---- vehicle 1 ---- vehicle 3        (paper graph, 60 s, one fault of every kind: tests/test_faults_e2e)
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from mcap.reader import make_reader

from supervisor.record import logfile
from supervisor.record.recorder import Recorder
from supervisor.record.scene.foxglove_schemas import is_scene_topic, schema, schema_name
from supervisor.record.scene_log import add_scene, scene_of_log
from tests.conftest import ROOT
from tests.procs import cpf
from tests.viewer_rules import TopicSpan, high_frequency_topics, viewer_problems

pytestmark = pytest.mark.e2e
DURATION = 60.0
NAMES = {"foxglove.FrameTransforms", "foxglove.SceneUpdate", "foxglove.PosesInFrame", "cpf.Coordination"}


@pytest.fixture(scope="module")
def logs(every_kind_runs: dict[str, Any]) -> dict[str, Path]:
    """name -> the log of the paper scenario, 60 s, one fault of every kind, run by `cpf run` on the engine of that
    name (tests/conftest.py every_kind_runs, which test_faults_e2e reads too), and `bare`: the same in-process run
    with --no-foxglove."""
    out = {}
    for engine in ("inprocess", "zenoh"):
        log, done = every_kind_runs[engine]
        assert done.returncode == 0, done.stderr
        out[engine] = log
    scenario = every_kind_runs["scenario"]
    args = ["run", str(scenario), "--engine", "inprocess", "--quiet", *every_kind_runs["args"], "--no-foxglove"]
    done = cpf(*args, "--out", "bare.mcap", cwd=scenario.parent)
    assert done.returncode == 0, done.stderr
    out["bare"] = scenario.parent / "bare.mcap"
    return out


def scene_records(path: Path) -> list[tuple[str, int, bytes]]:
    """(topic, log time, data) of every Foxglove message of a log, in log-time order (the writer's own bytes)."""
    with path.open("rb") as stream:
        return [(ch.topic, m.log_time, m.data) for _, ch, m in make_reader(stream).iter_messages(log_time_order=True)
                if is_scene_topic(ch.topic)]  # fmt: skip


def topic_spans(path: Path) -> dict[str, TopicSpan]:
    """Each topic's span as the log's summary and index give it to a viewer: its message count (the statistics),
    its first and last log times, whether its channel has a schema."""
    with path.open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        times: dict[int, list[int]] = {}
        for _, channel, message in reader.iter_messages(log_time_order=False):
            seen = times.setdefault(channel.id, [message.log_time, message.log_time])
            seen[0], seen[1] = min(seen[0], message.log_time), max(seen[1], message.log_time)
    counts = summary.statistics.channel_message_counts
    return {
        channel.topic: TopicSpan(counts[c], times[c][0], times[c][1], channel.schema_id != 0)
        for c, channel in summary.channels.items()
        if counts.get(c)
    }


def closed(node: Any) -> Any:
    """A JSON schema that also refuses keys it does not name (Foxglove's allow them): a misspelt field, which
    Foxglove would silently ignore, fails validation."""
    if isinstance(node, dict):
        node = {key: closed(value) for key, value in node.items()}
        if node.get("properties"):  # an object without properties is a free map (cpf's FREE)
            node["additionalProperties"] = False
    elif isinstance(node, list):
        node = [closed(item) for item in node]
    return node


def test_the_log_has_foxglove_channels_with_foxglove_schemas_in_json(logs):
    with logs["inprocess"].open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.statistics is not None
    scene = {ch.topic: ch for ch in summary.channels.values() if is_scene_topic(ch.topic)}
    expected = {"foxglove/transforms", "foxglove/scene", "foxglove/paths"} | {f"foxglove/trail/{v}" for v in (1, 2, 3)}
    expected |= {f"foxglove/coordination/{v}" for v in (1, 2, 3)}
    assert set(scene) == expected
    for topic, channel in scene.items():
        found = summary.schemas[channel.schema_id]
        assert channel.message_encoding == "json" and found.encoding == "jsonschema"
        assert found.name == schema_name(topic) and found.name in NAMES
        assert json.loads(found.data)["title"] == found.name  # Foxglove's schema itself (or cpf's), as shipped
    counts = {summary.channels[c].topic: n for c, n in summary.statistics.channel_message_counts.items()}
    assert counts["foxglove/paths"] == 1
    assert counts["foxglove/scene"] == counts["foxglove/transforms"] == DURATION / 0.5  # published every 0.5 s


@pytest.mark.parametrize("engine", ["inprocess", "zenoh"])
def test_no_topic_is_one_the_viewer_calls_high_frequency(logs, engine):
    """Lichtblick's "High frequency topics detected" alert (tests/viewer_rules.py): the link events, a record each,
    came ~80 a second; a step's batch comes at most once a step (the paper run's 0.1 s)."""
    spans = topic_spans(logs[engine])
    assert high_frequency_topics(spans) == {}
    events = spans["cpf/comms/events"]
    assert events.schema and events.count > DURATION / 0.1 * 0.9  # a batch a step (none where no event)
    assert "cpf/comms/event" not in spans


@pytest.mark.parametrize("engine", ["inprocess", "zenoh"])
def test_every_foxglove_message_validates_against_its_schema(logs, engine):
    validators = {name: jsonschema.Draft202012Validator(closed(schema(name))) for name in NAMES}
    seen: Counter[str] = Counter()
    for topic, _, data in scene_records(logs[engine]):
        name = schema_name(topic)
        assert name is not None
        validators[name].validate(json.loads(data))
        seen[name] += 1
    assert set(seen) == NAMES and sum(seen.values()) > 3 * DURATION


def test_both_engines_write_the_same_scene_byte_for_byte(logs):
    inprocess, zenoh = scene_records(logs["inprocess"]), scene_records(logs["zenoh"])
    assert len(inprocess) > 100
    assert inprocess == zenoh


def test_no_foxglove_leaves_the_scene_out_and_the_cpf_records_as_they_are(logs):
    with logs["bare"].open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None and not any(is_scene_topic(ch.topic) for ch in summary.channels.values())
    with_scene = [m for m in logfile.messages(logs["inprocess"]) if not is_scene_topic(m.topic)]
    assert len(with_scene) > 1000
    assert list(logfile.messages(logs["bare"])) == with_scene


def test_the_scene_shows_the_faults_and_the_links_fates(logs):
    """Vehicle 2 is killed on [41, 44): its label says so; link_down 1-2 (both ways) on [10, 15) and link_degraded
    1-3 on [5, 25): their labels, and the link's fate; a blackout on [20, 22) over the fleet."""
    scenes = {}
    for topic, stamp, data in scene_records(logs["inprocess"]):
        if topic == "foxglove/scene":
            scenes[stamp / 1e9] = {e["id"]: e for e in json.loads(data)["entities"]}
    down = scenes[42.0]["vehicle_2"]
    assert down["texts"][0]["text"].startswith("AUV 2: no state") and "vehicle_kill" in down["texts"][0]["text"]
    assert scenes[40.0]["vehicle_2"]["texts"][0]["text"].startswith("AUV 2\nγ = ")
    cut = scenes[12.0]["links"]
    fates = {pair["key"]: pair["value"] for pair in cut["metadata"]}
    assert fates["1->2"] == fates["2->1"] == "link_down"
    assert sorted(text["text"] for text in cut["texts"]) == ["link_degraded"] * 2 + ["link_down"] * 2
    red = {"r": 1.0, "g": 0.1, "b": 0.1, "a": 1.0}
    assert red in cut["lines"][0]["colors"]
    assert {pair["key"]: pair["value"] for pair in scenes[9.0]["links"]["metadata"]}["1->2"] == "delivered"
    assert "blackout" in scenes[21.0]["fleet"]["texts"][0]["text"]
    assert scenes[23.0]["fleet"]["texts"] == []


def test_a_log_without_a_scene_gets_the_same_one_afterwards(logs, tmp_path):
    """An older log (here: the run's cpf records copied without a scene) is given the run's scene by add_scene."""
    old = tmp_path / "old.mcap"
    with Recorder(old, scene=False) as rec:
        for message in logfile.messages(logs["zenoh"], lambda topic: not is_scene_topic(topic)):
            rec.write(message.topic, message.log_time / 1e9, message.message)
    assert scene_records(old) == []
    assert [(topic, round(t * 1e9)) for topic, t, _ in scene_of_log(old)] == [
        (topic, stamp) for topic, stamp, _ in scene_records(logs["zenoh"])
    ]
    add_scene(old, tmp_path / "new.mcap")
    assert scene_records(tmp_path / "new.mcap") == scene_records(logs["zenoh"])


def test_readers_of_cpf_records_still_read_the_log(logs, tmp_path):
    """cpf info, cpf report and the strict reader take the log with its Foxglove channels."""
    info = cpf("info", str(logs["zenoh"]), cwd=tmp_path)
    assert info.returncode == 0 and "foxglove/scene" in info.stdout, info.stderr
    report = cpf("report", str(logs["inprocess"]), "--out", "figs", cwd=tmp_path)
    assert report.returncode == 0, report.stderr
    assert (tmp_path / "figs" / "metrics.json").exists()


def test_the_shipped_layout_names_only_topics_and_fields_the_log_has(logs):
    """docs/foxglove/cpf-layout.json (Foxglove's layout format, as in foxglove-sdk's examples): its 3-D panel's
    topics and its plots' message paths (topic.field) are in a log of the paper fleet."""
    layout = json.loads((ROOT / "docs" / "foxglove" / "cpf-layout.json").read_text())
    panels = layout["configById"]
    assert {layout["layout"]["first"], *json.dumps(layout["layout"]).split('"')} >= set(panels)
    with logs["inprocess"].open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    topics = {ch.topic for ch in summary.channels.values()}
    last = {m.topic: m.message for m in logfile.messages(logs["inprocess"])}
    three_d = next(config for name, config in panels.items() if name.startswith("3D!"))
    assert three_d["followTf"] == "fleet" and set(three_d["topics"]) <= topics  # the camera follows the fleet
    frames = {tf["child_frame_id"] for tf in last["foxglove/transforms"]["transforms"]}
    assert three_d["followTf"] in frames
    # Every frame's axes, label and line to its parent hidden at once (Lichtblick's scene.transforms), not only the
    # frames the layout names: a fleet of 10 showed vehicle_4's and the next's over their arrows.
    assert (
        three_d["scene"]["transforms"] | {"showLabel": False, "axisScale": 0, "lineWidth": 0}
        == three_d["scene"]["transforms"]
    )
    plotted = [p["value"] for name, config in panels.items() if name.startswith("Plot!") for p in config["paths"]]
    assert len(plotted) >= 6
    for path in plotted:
        topic, field = path.split(".")
        assert topic in topics and isinstance(last[topic][field], float), path


@pytest.mark.parametrize("engine", ["inprocess", "zenoh"])
def test_every_cpf_record_validates_against_its_channels_schema_which_the_viewers_read(logs, engine):
    """Issue 25: each cpf channel's schema, as the log carries it, is one Lichtblick reads (tests/viewer_rules.py),
    and every record of a run with a fault of every kind validates against it (closed: a field the schema does not
    name fails too)."""
    with logs[engine].open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None
        validators = {}
        for channel in summary.channels.values():
            if not is_scene_topic(channel.topic) and channel.schema_id:
                found = json.loads(summary.schemas[channel.schema_id].data)
                assert viewer_problems(found) == [], channel.topic
                validators[channel.topic] = jsonschema.Draft7Validator(closed(found))
        seen: Counter[str] = Counter()
        for _, channel, message in reader.iter_messages():
            if channel.topic in validators:
                validators[channel.topic].validate(json.loads(message.data))
                seen[channel.topic.rsplit("/", 1)[-1]] += 1
    assert {"meta", "graph", "fault", "state", "tx", "rx", "events", "stats"} <= set(seen), seen  # zenoh: tick, stop
