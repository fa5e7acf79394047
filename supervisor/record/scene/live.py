"""The Foxglove scene of a run while it runs: the log's builder (scene.FleetScene's history and sweep) fed record by
record, giving each published instant's messages as soon as the instant is complete. Pure: no server, no clock.

The log's scene is built once the run is over, from every record; a live view cannot wait. An instant (a published
step k) is complete when every vehicle of the run has reported its state at k, or, for a vehicle that does not (its
process is down, or its records come late), once a state LAG_INSTANTS published instants later has come in: the
vehicle is then shown as the log shows it, "no state". Complete means a state of a later step has come in too (what
the supervisor records at t_k besides the states, a fault starting or a graph switching, comes before it), and a link
event later than t_k: the broker reports its events in time order, but on its own connection, so on the realtime
clock under load a vehicle's next state can overtake the broker's events of t_k (seen: a link going down at t_k shown
up). A run whose broker is silent past t_k (nothing sent) waits LAG_INSTANTS for it. Instants go out in order, each
once; a record about an instant already out (a later link outcome, a late state) is left out of the live view (the
log has it).

What differs from the log's scene, and why: the desired paths (foxglove/paths) go out with the first instant over
the gammas the run is planned to cover (gamma at the start + v_r x duration), and again, drawn further, whenever a
vehicle leaves them (the log draws them once, over the gammas the run went through, which a live view cannot know).
Memory stays bounded: the states of an instant and the link outcomes are dropped once it is out."""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from comms.records.events import EVENT_TOPICS
from comms.records.messages import vehicle_of_key
from supervisor.record.scene.foxglove_schemas import PATHS_TOPIC
from supervisor.record.scene.geometry import path_points
from supervisor.record.scene.history import FleetHistory
from supervisor.record.scene.paths import PATH_POINTS, PATH_SPACING
from supervisor.record.scene.scene import SceneMessage, _Placed, _placements, _Sweep, paths_update

log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)
LAG_INSTANTS = 2  # published instants a missing state or link event holds up the live view (1 s of simulated time)
PLAN_MARGIN = 0.25  # of the planned gammas, drawn on either side of them at first
Range = tuple[float, float]  # of gamma, drawn


class LiveScene:
    """Records in (`take`, as the recorder writes them), each complete instant's Foxglove messages out."""

    def __init__(self) -> None:
        self.history = FleetHistory()
        self.emitted = -1  # the last published step whose messages went out
        self.top = -1  # the latest step any state has reached
        self.heard = -math.inf  # s: the time of the latest link event (the broker's progress)
        self._sweep: _LiveSweep | None = None
        self._paths: _LivePaths | None = None
        self._is_state: dict[str, bool] = {}

    def take(self, topic: str, message: Any) -> list[SceneMessage]:
        """One record; the messages of the instants it completed (most records complete none)."""
        h = self.history
        h.take(topic, message)
        if topic in EVENT_TOPICS:
            return self._heard(message)
        if topic not in self._is_state:
            owned = vehicle_of_key(topic)
            self._is_state[topic] = owned is not None and owned[1] == "state"
        if not self._is_state[topic] or h.meta is None or not isinstance(message, dict):
            return []
        k = message.get("k")
        if type(k) is not int or k <= self.top:
            return []
        self.top = k
        return self._ready(final=False) if h.states else []

    def _heard(self, message: Any) -> list[SceneMessage]:
        """A step's link events (or an older log's single event): the broker has reported up to its time (the
        batch's, its step's: every event in it is at or before it); an instant waiting for that may now be out."""
        t = message.get("t") if isinstance(message, dict) else None
        if not isinstance(t, float | int) or not t > self.heard or self.history.meta is None:
            return []
        self.heard = float(t)
        return self._ready(final=False) if self.history.states else []

    def finish(self) -> list[SceneMessage]:
        """The messages of every instant not yet out (the run is over: nothing more will complete them)."""
        return self._ready(final=True) if self.history.meta is not None else []

    def _ready(self, final: bool) -> list[SceneMessage]:
        h = self.history
        assert h.meta is not None
        out: list[SceneMessage] = []
        fleet = len(h.meta.vehicles)
        while True:
            stale = [k for k in h.states if k <= self.emitted]  # late states of instants already out
            for k in stale:
                del h.states[k]
            if not h.states:
                return out
            k = min(h.states)
            complete = len(h.states[k]) == fleet and self.top > k and self._heard_past(k)
            if not (final or complete or k + LAG_INSTANTS * h.every <= self.top):
                return out
            out += self._instant(k)

    def _heard_past(self, k: int) -> bool:
        """Whether the broker has reported a link event after published step k (then all of k's are in)."""
        return math.isfinite(self.heard) and self.history.instant_at_or_after(self.heard) > k

    def _instant(self, k: int) -> list[SceneMessage]:
        h = self.history
        assert h.meta is not None
        if self._sweep is None:
            self._sweep = _LiveSweep(h)
            self._paths = _LivePaths(h)
        out = self._sweep.instant(k)
        self.emitted = k
        del h.states[k]
        assert self._paths is not None
        paths = self._paths.update(k * h.meta.step, self._sweep)
        return ([paths] if paths is not None else []) + out


class _LiveSweep(_Sweep):
    """The log's sweep over instants (scene._Sweep) on a history that grows as the run goes: each instant places its
    own vehicles, and puts in force what has come in up to it (graphs, faults, link outcomes), in the log's order."""

    def _placed(self, k: int) -> dict[int, _Placed]:
        return {v: placed for (_, v), placed in _placements(FleetHistory(states={k: self.h.states[k]})).items()}

    def _advance(self, k: int) -> None:
        """Graphs and faults (few) put in force again from the start; the link outcomes up to k that came in since
        the last instant, then dropped from the history."""
        h = self.h
        due = [item for item in h.outcomes.items() if item[0][1] <= k]
        for key, _ in due:
            del h.outcomes[key]
        self._start(h.graphs, h.faults, due)
        super()._advance(k)


class _LivePaths:
    """Each vehicle's desired path as drawn so far: over the gammas the run is planned to cover, drawn further when a
    vehicle leaves them. None of it if the meta's scenario does not validate (as the log's scene)."""

    def __init__(self, h: FleetHistory) -> None:
        from supervisor.config.fleet import build_path
        from supervisor.config.scenario_schema import Scenario

        assert h.meta is not None
        self.h = h
        self.ranges: dict[int, Range] = {}
        try:
            scenario = Scenario.model_validate(h.meta.scenario)
        except ValueError as exc:  # pydantic's ValidationError is one
            log.info("the run's scenario does not validate (%s): no desired paths in the live scene", exc)
            self.paths = {}
            return
        self.paths = {v.id: build_path(v.path) for v in scenario.vehicles}
        self.planned = scenario.coordination.v_r * scenario.scenario.duration  # gamma a run covers at v_r

    def update(self, t: float, sweep: _LiveSweep) -> SceneMessage | None:
        """foxglove/paths at time t if a vehicle placed is new or outside its drawn range (else None)."""
        changed = False
        for vid, placed in sweep.known.items():
            g = placed.gamma
            if vid not in self.paths or not math.isfinite(g):
                continue
            if vid not in self.ranges:
                margin = PLAN_MARGIN * abs(self.planned)  # a vehicle runs ahead of v_r while it catches up
                self.ranges[vid] = (min(g, g + self.planned) - margin, max(g, g + self.planned) + margin)
                changed = True
                continue
            low, high = self.ranges[vid]
            if not low <= g <= high:  # drawn further by the span drawn so far: a few redraws in a whole run
                span = max(high - low, abs(g - low), abs(g - high), 1e-6)
                self.ranges[vid] = (min(low, g - span), max(high, g + span)) if g < low else (low, g + span)
                changed = True
        if not changed:
            return None
        points: dict[int, NDArray[np.float64]] = {
            vid: path_points(self.paths[vid], low, high, PATH_SPACING, PATH_POINTS)
            for vid, (low, high) in self.ranges.items()
        }
        return PATHS_TOPIC, t, paths_update(self.h, t, points)
