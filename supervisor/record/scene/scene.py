"""The Foxglove scene of a run: cpf records in, Foxglove messages (foxglove_schemas) out. Pure and deterministic.

`FleetScene.take` every record of a run (as the recorder writes it, or as a log is read: an old log gives its scene
too), then `messages()` gives every Foxglove message in (time, topic) order. At each published instant (every
history.PUBLISH_PERIOD s of simulated time, in whole steps):

- foxglove/transforms (foxglove.FrameTransforms): world -> vehicle_<id>, each vehicle's position and attitude, and
  world -> fleet, the centroid of the vehicles as last placed (unrotated): what a 3-D panel's camera follows;
- foxglove/scene (foxglove.SceneUpdate): entity vehicle_<id> (an arrow along body x, a label with its id, gamma and
  the faults acting on it, in red while any does; grey with "no state" while its process is down), its virtual
  target p_d(gamma) (a sphere, joined to the vehicle by a thin line); entity links (each directed link of the graph
  in force as the half of the segment between its two vehicles on the sender's side, coloured by what its last
  packet did: LINK_COLOURS; a link fault's kind as a label there); entity fleet (the faults that act on the whole
  fleet, as a label above it);
- foxglove/trail/<id> (foxglove.PosesInFrame): the vehicle's poses over the last TRAIL_SECONDS, one every
  TRAIL_SPACING s, and its current pose;
- foxglove/coordination/<id> (cpf.Coordination), for each vehicle reporting at the instant: its gamma minus the mean
  of theirs, its path error's norm and gamma_dot (PLOT_DIGITS decimals), what Foxglove's plots cannot compute from
  the state records (a plot draws a field, not a norm or a difference between topics).

And once, at t = 0, foxglove/paths (foxglove.SceneUpdate): each vehicle's desired path over the gammas the run went
through, as a line strip (its own topic, so that Foxglove, which shows a topic's last message after a seek, keeps
showing it).
"""

from __future__ import annotations

import json
import logging
import math
from collections import Counter
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from comms.records.records import LinkEvent
from comms.records.state import StateReport
from supervisor.record.scene import primitives as fx
from supervisor.record.scene.foxglove_schemas import (
    FLEET_FRAME,
    PATHS_TOPIC,
    SCENE_TOPIC,
    TRANSFORMS_TOPIC,
    coordination_topic,
    trail_topic,
)
from supervisor.record.scene.geometry import quaternions
from supervisor.record.scene.history import FaultEvent, FleetHistory, Graph, Link, Outcome, Snapshot
from supervisor.record.scene.paths import desired_paths

log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)

SceneMessage = tuple[str, float, dict[str, Any]]  # (topic, simulation time s, message)
LinkOutcome = tuple[tuple[Link, int], Outcome]  # ((link, published instant), its last outcome): a history's
TRAIL_SECONDS = 30.0
TRAIL_SPACING = 2.0  # s between a trail's poses
VEHICLE_LENGTH = 2.0  # m: the arrow (a REMUS 100 is 1.6 m long)
TARGET_DIAMETER = 0.6  # m
LABEL_HEIGHT = 2.0  # m above the vehicle
PLOT_DIGITS = 6  # decimals of foxglove/coordination's numbers
# Tableau 10, the palette of the report's figures: vehicle n in colour n (mod 10).
PALETTE = ((0.12, 0.47, 0.71), (1.0, 0.5, 0.05), (0.17, 0.63, 0.17), (0.84, 0.15, 0.16), (0.58, 0.4, 0.74),
           (0.55, 0.34, 0.29), (0.89, 0.47, 0.76), (0.5, 0.5, 0.5), (0.74, 0.74, 0.13), (0.09, 0.75, 0.81))  # fmt: skip
DELIVERED = (0.1, 0.85, 0.2, 1.0)
LOST = (1.0, 0.6, 0.0, 1.0)
COLLIDED = (0.85, 0.2, 0.9, 1.0)
OUT_OF_RANGE = (0.3, 0.5, 1.0, 1.0)
FAULTED = (1.0, 0.1, 0.1, 1.0)
UNHEARD = (0.6, 0.6, 0.6, 0.5)  # no packet has reached its end yet, or one still in flight at the end of the run
LINK_COLOURS = {"delivered": DELIVERED, "loss": LOST, "burst": LOST, "degraded": LOST, "collision": COLLIDED,
                "half_duplex": COLLIDED, "range": OUT_OF_RANGE, "link_down": FAULTED, "blackout": FAULTED,
                "modem_silent": FAULTED, "broker_down": FAULTED}  # fmt: skip
WHITE, RED, GREY = (1.0, 1.0, 1.0, 1.0), (1.0, 0.25, 0.25, 1.0), (0.5, 0.5, 0.5, 0.8)


def vehicle_colour(index: int, alpha: float = 1.0) -> fx.Colour:
    r, g, b = PALETTE[index % len(PALETTE)]
    return (r, g, b, alpha)


def frame_of(vehicle: int) -> str:
    return f"vehicle_{vehicle}"


@dataclass
class FleetScene:
    """Records in (`take`), the scene's messages out (`messages`)."""

    history: FleetHistory = field(default_factory=FleetHistory)

    def take(self, topic: str, message: Any) -> None:
        self.history.take(topic, message)

    def take_state(self, report: StateReport) -> None:
        self.history.take_state(report)

    def take_event(self, event: LinkEvent) -> None:
        self.history.take_event(event)

    def messages(self) -> Iterator[SceneMessage]:
        return scene_messages(self.history)


def scene_messages(h: FleetHistory) -> Iterator[SceneMessage]:
    """Every Foxglove message of the history, in (time, topic) order; none without the run's meta or states.
    Made as they are asked for: a long run's scene is never all in memory (nor in the garbage collector's way)."""
    if h.meta is None or not h.states:
        return
    paths = desired_paths(h)
    if paths:
        yield PATHS_TOPIC, 0.0, paths_update(h, 0.0, paths)
    state = _Sweep(h)
    for k in sorted(h.states):
        yield from state.instant(k)


def paths_update(h: FleetHistory, t: float, paths: dict[int, NDArray[np.float64]]) -> dict[str, Any]:
    """The foxglove/paths message at time t: each vehicle's path (its points) as a line strip in its colour."""
    entities = [fx.entity(t, f"path_{vid}", lines=[fx.line(fx.LINE_STRIP, fx.rounded(points), 2.0,
                                                        _colour(h, vid, 0.6))])
                for vid, points in sorted(paths.items())]  # fmt: skip
    return fx.scene_update(entities)


def _colour(h: FleetHistory, vid: int, alpha: float = 1.0) -> fx.Colour:
    """The vehicle's colour: its place in the fleet's palette (a vehicle the meta does not name: its id's)."""
    return vehicle_colour(h.places.get(vid, vid), alpha)


class _Placed(NamedTuple):
    """A vehicle as last published: gamma, and its position, virtual target and attitude rounded for the view."""

    gamma: float
    position: list[float]
    target: list[float]
    orientation: list[float]  # x, y, z, w
    pose: dict[str, Any]  # position and orientation as foxglove.Pose


class _Sweep:
    """Walks the published instants in order, keeping what is in force (graph, faults, each link's last outcome,
    each vehicle's last pose and its trail)."""

    def __init__(self, h: FleetHistory) -> None:
        self.h = h
        self.last: dict[Link, Outcome] = {}
        self.known: dict[int, _Placed] = {}  # vehicle -> as last published
        self.placed: dict[tuple[int, int], _Placed] | None = None  # (k, vehicle) -> placed: the run's, made once
        self.trails: dict[int, list[tuple[int, dict[str, Any]]]] = {}  # vehicle -> (k, pose) samples
        self._start(h.graphs, h.faults, h.outcomes.items())

    def _start(self, graphs: Iterable[Graph], faults: Iterable[FaultEvent], outcomes: Iterable[LinkOutcome]) -> None:
        """What happens during the run, in the log's order, none of it in force yet (graph: the meta's)."""
        self.graphs = sorted(graphs, key=lambda g: (g.t, g.edges))
        self.faults = sorted(faults, key=lambda f: (f.t, f.phase == "start", f.kind, _key(f.detail)))
        self.outcomes = sorted(outcomes, key=lambda item: (item[0][1], item[0][0]))
        self.done = [0, 0, 0]  # graphs, faults, outcomes in force
        # The directed links of the graph in force, sorted: worked out when the graph changes, not every instant.
        self.directed = _directed(self.h.meta.edges if self.h.meta is not None else ())
        self.acting: Counter[tuple[str, str]] = Counter()  # (kind, detail as JSON) of the faults acting

    def _placed(self, k: int) -> dict[int, _Placed]:
        """Vehicle -> placed at published step k, for each vehicle whose state of k is in."""
        if self.placed is None:
            self.placed = _placements(self.h)
        return {v: self.placed[(k, v)] for v in sorted(self.h.states[k])}

    def instant(self, k: int) -> list[SceneMessage]:
        """The messages of published step k."""
        assert self.h.meta is not None
        t = k * self.h.meta.step
        self._advance(k)
        present = self.h.states[k]
        ids = sorted(present)
        self.known.update(self._placed(k))
        transforms = [
            fx.frame_transform(t, frame_of(v), self.known[v].position, self.known[v].orientation) for v in ids
        ]
        transforms.append(fx.frame_transform(t, FLEET_FRAME, self._centroid(), fx.IDENTITY))
        out: list[SceneMessage] = [(TRANSFORMS_TOPIC, t, fx.frame_transforms(transforms))]
        out.append((SCENE_TOPIC, t, fx.scene_update(self._entities(t, set(present)))))
        out += [(trail_topic(v), t, self._trail(t, k, v)) for v in ids]
        return out + _coordination(t, present)

    def _centroid(self) -> list[float]:
        """The mean of the vehicles' positions as last placed (summed in the order of their ids: the same bits on
        any machine), rounded as a position."""
        placed = [self.known[v].position for v in sorted(self.known)]
        return fx.rounded([[sum(p[axis] for p in placed) / len(placed) for axis in range(3)]])[0]

    def _advance(self, k: int) -> None:
        """Everything that happened up to published step k put in force."""
        at, done = self.h.instant_at_or_after, self.done
        while done[0] < len(self.graphs) and at(self.graphs[done[0]].t) <= k:
            self.directed = _directed(self.graphs[done[0]].edges)
            done[0] += 1
        while done[1] < len(self.faults) and at(self.faults[done[1]].t) <= k:
            fault = self.faults[done[1]]
            key = (fault.kind, _key(fault.detail))
            self.acting[key] += 1 if fault.phase == "start" else -1
            if self.acting[key] <= 0:
                del self.acting[key]
            done[1] += 1
        while done[2] < len(self.outcomes) and self.outcomes[done[2]][0][1] <= k:
            (link, _), outcome = self.outcomes[done[2]]
            self.last[link] = outcome
            done[2] += 1

    def _entities(self, t: float, present: set[int]) -> list[dict[str, Any]]:
        acting = [(kind, json.loads(detail)) for kind, detail in sorted(self.acting)]
        entities = [self._vehicle(t, vid, vid in present, acting) for vid in sorted(self.known)]
        entities.append(self._links(t, acting))
        entities.append(self._fleet(t, acting))
        return entities

    def _vehicle(self, t: float, vid: int, present: bool, acting: list[tuple[str, dict[str, Any]]]) -> dict[str, Any]:
        v = self.known[vid]
        faults = [kind for kind, detail in acting if detail.get("vehicle") == vid]
        label = f"AUV {vid}\nγ = {v.gamma:.2f}" if present else f"AUV {vid}: no state"
        label += "".join(f"\n{kind}" for kind in faults)
        above = [v.position[0], v.position[1], round(v.position[2] + LABEL_HEIGHT, fx.POSITION_DIGITS)]
        colour, faded = (_colour(self.h, vid) if present else GREY), _colour(self.h, vid, 0.6)
        return fx.entity(
            t, frame_of(vid),
            arrows=[fx.arrow(v.position, v.orientation, VEHICLE_LENGTH, colour)],
            spheres=[fx.sphere(v.target, TARGET_DIAMETER, faded)],
            lines=[fx.line(fx.LINE_STRIP, [v.position, v.target], 1.0, faded)],
            texts=[fx.text(above, label, RED if faults else WHITE)],
            metadata=fx.metadata({"gamma": f"{v.gamma:.6g}", "faults": ", ".join(faults) or "none"}),
        )  # fmt: skip

    def _links(self, t: float, acting: list[tuple[str, dict[str, Any]]]) -> dict[str, Any]:
        """Each directed link of the graph in force, between two vehicles placed: the sender's half of the segment
        between them, coloured by its last packet's fate; a link fault's kind written at the middle of that half."""
        pairs = [(s, r) for s, r in self.directed if s in self.known and r in self.known]
        if not pairs:
            return fx.entity(t, "links")
        # One array for all the links' ends (a fleet of 1000 made two small arrays a link an instant): numpy's
        # element-wise sums and halves are those of one link at a time, to the bit.
        a = np.array([self.known[s].position for s, _ in pairs])
        b = np.array([self.known[r].position for _, r in pairs])
        ends = np.empty((2 * len(pairs), 3))
        ends[0::2], ends[1::2] = a, (a + b) / 2
        colours, where, kinds_at, fates = [], [], [], {}
        for n, (s, r) in enumerate(pairs):
            fate = self.last.get((s, r))
            word = "none yet" if fate is None else fate[3] or fate[2]
            colour = UNHEARD if fate is None else LINK_COLOURS.get(word, UNHEARD)
            colours += [colour, colour]
            fates[f"{s}->{r}"] = word
            kinds = [kind for kind, detail in acting if _on_link(detail, s, r)]
            if kinds:
                where.append(0.75 * a[n] + 0.25 * b[n])
                kinds_at.append(" ".join(kinds))
        labels = [fx.text(p, words, RED) for p, words in zip(fx.rounded(where), kinds_at, strict=True)] if where else []
        lines = [fx.line(fx.LINE_LIST, fx.rounded(ends), 3.0, UNHEARD, colours)]
        return fx.entity(t, "links", lines=lines, texts=labels, metadata=fx.metadata(fates))

    def _fleet(self, t: float, acting: list[tuple[str, dict[str, Any]]]) -> dict[str, Any]:
        """The faults on the whole fleet (no vehicle, no link: blackout, broker_kill, graph_switch), above it."""
        kinds = [kind for kind, detail in acting if not {"vehicle", "sender"} & set(detail)]
        if not kinds or not self.known:
            return fx.entity(t, "fleet")
        x, y, z = self._centroid()
        above = fx.rounded([[x, y, z + 3 * LABEL_HEIGHT]])[0]
        return fx.entity(t, "fleet", texts=[fx.text(above, "\n".join(kinds), RED)])

    def _trail(self, t: float, k: int, vid: int) -> dict[str, Any]:
        """The vehicle's poses of the last TRAIL_SECONDS, one every TRAIL_SPACING s (steps counted from 0, so a
        trail's poses stay where they are as it moves on), then its current pose."""
        assert self.h.meta is not None
        here = self.known[vid].pose
        stride = max(1, round(TRAIL_SPACING / (self.h.every * self.h.meta.step)))  # in published instants
        trail = self.trails.setdefault(vid, [])
        while trail and (k - trail[0][0]) * self.h.meta.step > TRAIL_SECONDS:
            trail.pop(0)
        poses = [p for _, p in trail]
        if (k // self.h.every) % stride == 0:
            trail.append((k, here))
        return fx.poses_in_frame(t, [*poses, here])


def _coordination(t: float, present: dict[int, Snapshot]) -> list[SceneMessage]:
    """foxglove/coordination/<id> at time t of each vehicle present: gamma minus the mean of the finite gammas
    present (summed in the order of the ids), |error| and gamma_dot; a value that is not finite left out."""
    ids = sorted(present)
    gammas = [present[v].gamma for v in ids if math.isfinite(present[v].gamma)]
    mean = sum(gammas) / len(gammas) if gammas else math.nan
    out: list[SceneMessage] = []
    for v in ids:
        s = present[v]
        values = {"gamma_offset": s.gamma - mean, "path_error": s.path_error, "gamma_dot": s.gamma_dot}
        message = {key: round(x, PLOT_DIGITS) for key, x in values.items() if math.isfinite(x)}
        out.append((coordination_topic(v), t, message))
    return out


def _placements(h: FleetHistory) -> dict[tuple[int, int], _Placed]:
    """(k, vehicle) -> the vehicle placed at published step k: every number rounded, in a few numpy calls for the
    whole run (per instant, numpy's overhead was most of the scene's time)."""
    keys = [(k, v) for k in sorted(h.states) for v in sorted(h.states[k])]
    snaps = [h.states[k][v] for k, v in keys]
    positions = np.array([s.position for s in snaps])
    targets = np.array([s.target for s in snaps])
    targets = np.where(np.isfinite(targets), targets, positions)  # a diverged error: no target to show
    qs = fx.rounded(quaternions(np.array([s.rotation for s in snaps])), fx.QUATERNION_DIGITS)
    rows = zip(keys, snaps, fx.rounded(positions), fx.rounded(targets), qs, strict=True)
    return {key: _Placed(snap.gamma, p, target, q, fx.pose(p, q)) for key, snap, p, target, q in rows}


def _directed(edges: Iterable[Link]) -> list[Link]:
    """Both directions of each edge, sorted."""
    return sorted({(i, j) for i, j in edges} | {(j, i) for i, j in edges})


def _key(detail: dict[str, Any]) -> str:
    return json.dumps(detail, sort_keys=True)


def _on_link(detail: dict[str, Any], sender: int, receiver: int) -> bool:
    """Whether a fault's detail names the link sender -> receiver (or it both ways, with `both`)."""
    if detail.get("sender") == sender and detail.get("receiver") == receiver:
        return True
    return bool(detail.get("both")) and detail.get("sender") == receiver and detail.get("receiver") == sender
