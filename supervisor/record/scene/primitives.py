"""Foxglove messages as plain dicts, in the JSON form of Foxglove's schemas (foxglove_schemas): each function
builds one message or one part of one, with every field the schema requires.

Numbers go in as given: callers round them first, many at once (`rounded`: positions to 0.1 mm, quaternion
components to 1e-6). A view needs no more, the log keeps the exact values on its cpf channels, and the rounding is
what keeps the scene small (it is deterministic: numpy's, on the same numbers).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache, lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

Dict = dict[str, Any]
Colour = tuple[float, float, float, float]
Point = Sequence[float] | NDArray[np.float64]
WORLD = "world"
POSITION_DIGITS = 4
QUATERNION_DIGITS = 6
IDENTITY: Point = (0.0, 0.0, 0.0, 1.0)
LINE_STRIP, LINE_LIST = 0, 2  # foxglove.LineType


def rounded(values: Sequence[Point] | NDArray[np.float64], digits: int = POSITION_DIGITS) -> list[list[float]]:
    """Rows of numbers rounded to `digits` decimals, as Python floats (one numpy call for many points)."""
    out: list[list[float]] = np.round(np.asarray(values, dtype=np.float64), digits).tolist()
    return out


@lru_cache(maxsize=4)  # every entity of an instant has its time: one dict for them all
def timestamp(t: float) -> Dict:
    """Simulation time t (s) as foxglove's time: the log time of the message, in whole ns as the recorder rounds it."""
    ns = round(t * 1e9)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def vector(p: Point) -> Dict:
    """Python floats in (`rounded` gives them): the hot path of the scene, ~30000 points a paper run."""
    return {"x": p[0], "y": p[1], "z": p[2]}


def quaternion(q: Point) -> Dict:
    return {"x": q[0], "y": q[1], "z": q[2], "w": q[3]}


UNROTATED = quaternion(IDENTITY)  # shared by every message that uses it: JSON writes it out each time
ORIGIN = {"position": vector((0.0, 0.0, 0.0)), "orientation": UNROTATED}


def pose(position: Point, orientation: Point | None = None) -> Dict:
    return {"position": vector(position), "orientation": UNROTATED if orientation is None else quaternion(orientation)}


@cache
def colour(c: Colour) -> Dict:
    """A colour's dict, one per colour (a scene has a few dozen): never to be changed by its users."""
    return {"r": c[0], "g": c[1], "b": c[2], "a": c[3]}


def frame_transform(t: float, child: str, position: Point, orientation: Point) -> Dict:
    """The child frame placed in the world frame."""
    return {"timestamp": timestamp(t), "parent_frame_id": WORLD, "child_frame_id": child,
            "translation": vector(position), "rotation": quaternion(orientation)}  # fmt: skip


def frame_transforms(transforms: list[Dict]) -> Dict:
    """A foxglove.FrameTransforms message."""
    return {"transforms": transforms}


def poses_in_frame(t: float, poses: list[Dict]) -> Dict:
    """A foxglove.PosesInFrame message in the world frame."""
    return {"timestamp": timestamp(t), "frame_id": WORLD, "poses": poses}


def scene_update(entities: list[Dict]) -> Dict:
    """A foxglove.SceneUpdate message: entities replace those of the same id on the topic."""
    return {"deletions": [], "entities": entities}


def entity(t: float, name: str, **primitives: list[Dict]) -> Dict:
    """A foxglove.SceneEntity in the world frame that lasts until replaced (lifetime 0), with the given primitive
    lists (arrows, spheres, lines, texts, ...; the others empty) and metadata (a list of key/value pairs)."""
    kinds = ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models")
    unknown = set(primitives) - {*kinds, "metadata"}
    if unknown:
        raise ValueError(f"entity: no primitive kind {sorted(unknown)}")
    out: Dict = {"timestamp": timestamp(t), "frame_id": WORLD, "id": name, "lifetime": {"sec": 0, "nsec": 0},
                 "frame_locked": False, "metadata": primitives.get("metadata", [])}  # fmt: skip
    out.update({kind: primitives.get(kind, []) for kind in kinds})
    return out


def metadata(pairs: dict[str, str]) -> list[Dict]:
    return [{"key": key, "value": value} for key, value in pairs.items()]


def arrow(position: Point, orientation: Point, length: float, c: Colour) -> Dict:
    """An arrow along the pose's x axis (a vehicle's body x, forward), `length` m long in all."""
    return {"pose": pose(position, orientation), "shaft_length": 0.7 * length, "shaft_diameter": 0.12 * length,
            "head_length": 0.3 * length, "head_diameter": 0.3 * length, "color": colour(c)}  # fmt: skip


def sphere(position: Point, diameter: float, c: Colour) -> Dict:
    return {"pose": pose(position), "size": {"x": diameter, "y": diameter, "z": diameter}, "color": colour(c)}


def text(position: Point, words: str, c: Colour, size: float = 14.0) -> Dict:
    """A label that always faces the camera, `size` pixels high whatever the zoom."""
    return {"pose": pose(position), "billboard": True, "font_size": size, "scale_invariant": True,
            "color": colour(c), "text": words}  # fmt: skip


def line(
    kind: int,
    points: Sequence[Point] | NDArray[np.float64],
    thickness: float,
    c: Colour,
    colours: Sequence[Colour] = (),
) -> Dict:
    """A line strip or list through points (world frame); colours: one per point (then c is unused), or none.
    thickness in pixels (scale invariant)."""
    return {"type": kind, "pose": ORIGIN, "thickness": thickness, "scale_invariant": True,
            "points": [vector(p) for p in points], "color": colour(c), "colors": [colour(x) for x in colours],
            "indices": []}  # fmt: skip
