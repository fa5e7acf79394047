"""The Foxglove channels of a log: their topics and Foxglove's well-known schemas for them (JSON encoding), and the
one of cpf's own schema, for plots.

Foxglove recognises a channel by its schema's name (`foxglove.SceneUpdate`, ...) and its encoding (`jsonschema`
schema, `json` messages). The schemas are vendored from the foxglove-sdk repository (schemas/SOURCE.md names the
commit): a run has no network. Topics are outside cpf/: they are the log's view of the run, never bus keys.
"""

from __future__ import annotations

import json
from functools import cache
from importlib import resources
from typing import Any

PREFIX = "foxglove"
TRANSFORMS_TOPIC = f"{PREFIX}/transforms"  # world -> vehicle_<id>, every published instant
SCENE_TOPIC = f"{PREFIX}/scene"  # vehicles, virtual targets, links, faults, every published instant
PATHS_TOPIC = f"{PREFIX}/paths"  # the desired paths, once (its own topic: a seek shows the topic's last message)
TRAIL_PREFIX = f"{PREFIX}/trail"  # foxglove/trail/<id>: each vehicle's recent poses
FLEET_FRAME = "fleet"  # a frame at the fleet's centroid (in foxglove/transforms): what a 3-D panel's camera follows
COORDINATION_PREFIX = f"{PREFIX}/coordination"  # foxglove/coordination/<id>: what the plots show of each vehicle

FRAME_TRANSFORMS = "foxglove.FrameTransforms"
SCENE_UPDATE = "foxglove.SceneUpdate"
POSES_IN_FRAME = "foxglove.PosesInFrame"
COORDINATION = "cpf.Coordination"  # cpf's own (schemas/Coordination.json): Foxglove has none for it
SCHEMA_ENCODING = "jsonschema"
MESSAGE_ENCODING = "json"


def trail_topic(vehicle: int) -> str:
    return f"{TRAIL_PREFIX}/{vehicle}"


def coordination_topic(vehicle: int) -> str:
    return f"{COORDINATION_PREFIX}/{vehicle}"


def is_scene_topic(topic: str) -> bool:
    """Whether a log's topic is one of the Foxglove channels (what a reader of cpf records skips)."""
    return topic.startswith(PREFIX + "/")


def schema_name(topic: str) -> str | None:
    """The Foxglove schema name of a Foxglove topic; None for any other topic."""
    if topic == TRANSFORMS_TOPIC:
        return FRAME_TRANSFORMS
    if topic in (SCENE_TOPIC, PATHS_TOPIC):
        return SCENE_UPDATE
    if topic.startswith(TRAIL_PREFIX + "/"):
        return POSES_IN_FRAME
    if topic.startswith(COORDINATION_PREFIX + "/"):
        return COORDINATION
    return None


@cache
def schema_data(name: str) -> bytes:
    """The JSON schema of a schema name of schema_name (e.g. foxglove.SceneUpdate: vendored), its bytes as shipped."""
    file = name.split(".", 1)[1] + ".json"
    return resources.files(__package__).joinpath("schemas", file).read_bytes()


def schema(name: str) -> dict[str, Any]:
    """The vendored JSON schema as a dict (for validation)."""
    loaded: dict[str, Any] = json.loads(schema_data(name))
    return loaded
