"""The Foxglove scene of a log already written: what a log recorded before the scene existed (or with it turned
off) needs to open in Foxglove's 3-D panel. The same builder as a run's (record.scene), fed from the log's records.
"""

from __future__ import annotations

from pathlib import Path

from supervisor.record import logfile
from supervisor.record.recorder import Recorder
from supervisor.record.scene.foxglove_schemas import is_scene_topic
from supervisor.record.scene.scene import FleetScene, SceneMessage


def scene_of_log(path: Path) -> list[SceneMessage]:
    """The Foxglove messages of a log's cpf records (any Foxglove channels it has are ignored); LogError for a log
    that is missing, cut short or damaged (logfile.messages)."""
    scene = FleetScene()
    for message in logfile.messages(path, lambda topic: not is_scene_topic(topic)):
        scene.take(message.topic, message.message)
    return list(scene.messages())


def add_scene(source: Path, out: Path) -> int:
    """Copy a log's cpf records to out, with the scene built from them; the messages written."""
    with Recorder(out) as rec:
        for message in logfile.messages(source, lambda topic: not is_scene_topic(topic)):
            if message.message is not None:  # a channel that is not JSON is not ours
                rec.write(message.topic, message.log_time / 1e9, message.message)
    return rec.count
