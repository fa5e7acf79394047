"""Many vehicles' steps at once, each float of the closed loop a numpy array with one lane per vehicle (issue 26).

Vehicles whose closed loops differ only in their paths, coordination laws, predictors and what they heard (a fleet
of alike vehicles; the same vehicle in many runs) integrate together: vehicles.runtime.prepare and
vehicles.agent.begin one vehicle at a time, then vehicles.agent.rk4 once for all of them (the same code as one
vehicle's: numpy's elementwise arithmetic rounds as Python's floats, and the closed loop's branches on the state take
lanes: numerics.lanes), the law's correction lane by lane (extensions written for floats) and the path's point once
for the lanes on one path that takes lanes (else lane by lane), then agent.finish, runtime.complete and step.records
one vehicle at a time. So each vehicle's records are those of vehicles.step.step_records, bit for bit
(tests/test_lanes.py holds it over scenarios).

Only parts that say they take lanes (`lanes = True`: the built-in backstepping and line-of-sight controllers, the
AUV model and the actuators, and an extension that says so) are stepped so, and vehicles step together only where
those parts, the parameters and the saturations are the same to the bit (vehicles.lane_keys); a vehicle with
navigation, or a current, observer, actuators or controller that does not say so steps alone. An adaptive
controller's memory (line of sight's disturbance estimate) steps as lanes too: each vehicle's, floats in tuples,
named tuples and dataclasses, becomes one of arrays (lane_keys.stacked) for the step and each vehicle's again after
it (lane_keys.unstacked). A group whose stepping raises anything, a float exception included (numpy is told to raise
where Python's floats would or might), is stepped again one vehicle at a time: errors are exactly those of the scalar
step.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import msgspec
import numpy as np

from comms.records.records import Disturbances, Heard
from numerics.lanes import takes_lanes
from vehicles.agent import Along, VehicleConfig, begin, finish, neighbour_values, rk4
from vehicles.dynamics import PathVectors
from vehicles.lane_keys import interned, key, stacked, unstacked
from vehicles.runtime import NodeState, Prepared, Radio, complete, prepare
from vehicles.step import StepRecords, records, step_records
from vehicles.stepping import Begun, Stepped

# Fewer alike vehicles than this step one at a time: numpy's cost per call (~1 us against a float's ~30 ns) and
# what each vehicle still does alone outweigh the arrays below it. Measured (benchmarks.bench_lanes, copies of the
# paper's vehicles, two runs): lanes cost 1.5-2.0x a vehicle's step alone at 16, 1.1-1.2x at 24, 0.98-1.07x at 32,
# 0.8-0.9x at 48, 0.56x at 192.
MIN_LANES = 32

Outcome = tuple[NodeState, StepRecords] | Exception  # an exception: what step_records raised for that vehicle


class Job(msgspec.Struct, frozen=True):
    """step_records' arguments for one vehicle, and its shape (shape_of(cfg), kept by the caller: a key a step is
    too dear for)."""

    shape: Shape | None
    cfg: VehicleConfig
    radio: Radio
    node: NodeState
    k: int
    t: float
    dt: float
    heard: Sequence[Heard]
    neighbours: Sequence[int]
    dist: Disturbances


def step_all(jobs: Sequence[Job], min_lanes: int | None = None, strict: bool = False) -> list[Outcome]:
    """Each job's step_records (or what it raised), groups of at least min_lanes (None: MIN_LANES) alike vehicles
    stepped together as lanes; strict: a group whose lanes raise raises (a benchmark's lanes are lanes), instead of
    stepping one vehicle at a time."""
    least = MIN_LANES if min_lanes is None else min_lanes
    if len(jobs) < least:  # no group can be large enough: no grouping (a small fleet's every step)
        return [_one(job) for job in jobs]
    slots: dict[int, Outcome] = {}
    together = _together if strict else _lanes
    for group in _groups(jobs):
        stepped = together([jobs[i] for i in group]) if len(group) >= least else None
        for n, i in enumerate(group):
            slots[i] = stepped[n] if stepped is not None else _one(jobs[i])
    return [slots[i] for i in range(len(jobs))]


def _one(job: Job) -> Outcome:
    try:
        return step_records(job.cfg, job.radio, job.node, job.k, job.t, job.dt, job.heard, job.neighbours, job.dist)
    except Exception as exc:  # handed back to be raised in the vehicle's turn, as the scalar loop would
        return exc


def _groups(jobs: Sequence[Job]) -> list[list[int]]:
    """Indices of the jobs that may step together (in order), and each job that may not alone."""
    groups: dict[object, list[int]] = {}
    alone: list[list[int]] = []
    bits: dict[int, object] = {}  # key by id: a step's jobs share their t and dt objects (and the jobs hold them)
    for i, job in enumerate(jobs):
        shape = job.shape
        if shape is None:
            alone.append([i])
        else:  # of the disturbances, the stages read the cap alone (agent._rate_limits)
            values = (job.t, job.dt, job.dist.gamma_dot_cap)
            keys = [bits[id(v)] if id(v) in bits else bits.setdefault(id(v), key(v)) for v in values]
            groups.setdefault((shape.shared, *keys), []).append(i)
    return [*groups.values(), *alone]


class Shape(NamedTuple):
    """shape_of's: the key of what the lanes share, and of the vehicle's path (lanes on the same path take its
    point at once)."""

    shared: object
    path: object


def shape_of(cfg: VehicleConfig) -> Shape | None:
    """What must be the same for vehicles to step together (None: this one steps alone): every part the stages
    compute with as arrays, to the bit (vehicles.lane_keys)."""
    if cfg.navigation is not None:
        return None
    parts = (cfg.controller, cfg.vehicle, cfg.current, cfg.current_observer, cfg.actuators)
    if not all(part is None or takes_lanes(part) for part in parts):
        return None
    shared = (
        type(cfg.model), cfg.model.dim, cfg.params, cfg.plant, cfg.current_known, cfg.top_speed, cfg.correction_limit,
        cfg.correction_acceleration, cfg.coordination.v_r, *parts,
    )  # fmt: skip
    return Shape(interned(shared), interned(cfg.path))


def _lanes(jobs: Sequence[Job]) -> list[Outcome] | None:
    """The jobs stepped together; None if that raised (they are then stepped one at a time)."""
    try:
        return _together(jobs)
    except Exception:  # anything: the scalar step gives the error, if there is one
        return None


def _together(jobs: Sequence[Job]) -> list[Outcome]:
    first = jobs[0]
    cfgs = [job.cfg for job in jobs]
    before = [prepare(j.cfg, j.radio, j.node, j.t, j.dt, j.heard, j.neighbours, j.dist) for j in jobs]
    begun = [begin(cfg, p.state, None) for cfg, p in zip(cfgs, before, strict=True)]
    z = list(np.array([b.z for b in begun]).T.copy())
    memory = stacked([b.memory for b in begun])

    paths = _path_lanes(jobs)

    def along(t: float) -> LaneAlong:
        heard = [neighbour_values(j.cfg, p.state, t, j.neighbours) for j, p in zip(jobs, before, strict=True)]
        return LaneAlong(cfgs, heard, paths)

    with np.errstate(all="raise", under="ignore"):  # where Python's floats raise, or might: alone, they say what
        stepped = rk4(first.cfg, first.t, Begun(z, memory, ()), first.dt, along, first.dist, None)
    lanes = _unstacked(stepped, len(jobs), memory)
    return [_finished(j, p, b, s) for j, p, b, s in zip(jobs, before, begun, lanes, strict=True)]


def _finished(job: Job, before: Prepared, begun: Begun, stepped: Stepped) -> Outcome:
    state, telemetry = finish(job.cfg, before.state, begun, stepped, job.dt, job.dist, None)
    node, out = complete(before, state, telemetry)
    try:
        return node, records(job.cfg, job.k, job.t, out)
    except FloatingPointError as exc:  # its state is not sane: step_records raises the same
        return exc


def _unstacked(stepped: Stepped, lanes: int, began: object) -> list[Stepped]:
    """One Stepped per lane, of floats (a value the same for every lane comes as a float); began: the stacked
    memory the step began with."""
    z = np.array(stepped.z).T.tolist()
    v_tilde, lyapunov = _column(stepped.v_tilde, lanes), _column(stepped.lyapunov, lanes)
    error = list(zip(*(_column(e, lanes) for e in stepped.seen_error), strict=True))
    applied = list(zip(*(_column(a, lanes) for a in stepped.applied), strict=True))
    memory = unstacked(stepped.memory, lanes, began)
    return [Stepped(z[n], memory[n], v_tilde[n], error[n], lyapunov[n], applied[n]) for n in range(lanes)]


def _column(value: Any, lanes: int) -> list[float]:
    return np.broadcast_to(np.asarray(value, dtype=np.float64), (lanes,)).tolist()


class PathLanes(NamedTuple):
    """Lanes whose path's point is taken in one call: path (their shared path, or a stand-in whose attributes are the
    lanes' paths' stacked: lane_keys.stacked) evaluated at their gammas; None: lane by lane. parts: the groups of
    one path each to fall back on if the stand-in's evaluation raises."""

    lanes: list[int]
    path: object | None
    parts: tuple[PathLanes, ...] = ()


class LaneAlong(Along):
    """agent.Along for lanes: each vehicle's own law lane by lane through its float code, and its path's point for
    all the lanes whose paths are of one class that takes lanes (`lanes = True`: the helix, circle and line) at once,
    else lane by lane."""

    __slots__ = ("cfgs", "heards", "paths")

    def __init__(
        self, cfgs: Sequence[VehicleConfig], heards: Sequence[list[tuple[float, float]]], paths: list[PathLanes]
    ) -> None:
        super().__init__(cfgs[0], heards[0])
        self.cfgs, self.heards, self.paths = cfgs, heards, paths

    def point(self, gamma: Any) -> PathVectors:
        c = np.empty((9, len(self.cfgs)))
        for group in self.paths:
            self._fill(c, gamma, group)
        return (c[0], c[1], c[2]), (c[3], c[4], c[5]), (c[6], c[7], c[8])

    def _fill(self, c: np.ndarray, gamma: Any, group: PathLanes) -> None:
        lanes, path = group.lanes, group.path
        if path is None:
            for n in lanes:
                c[:, n] = _flat(self.cfgs[n].model.path_seen(self.cfgs[n].path.evaluate_floats(float(gamma[n]))))
            return
        if group.parts and id(path) in _REFUSED:
            self._fill_parts(c, gamma, group)
            return
        try:
            values = _flat(self.cfgs[lanes[0]].model.path_seen(path.evaluate_floats(gamma[lanes])))  # type: ignore[attr-defined]
        except Exception:
            if not group.parts:
                raise
            _REFUSED.add(id(path))  # a stand-in its class's code cannot take: each path's lanes, from now on
            self._fill_parts(c, gamma, group)
            return
        for row, value in enumerate(values):
            c[row, lanes] = value

    def _fill_parts(self, c: np.ndarray, gamma: Any, group: PathLanes) -> None:
        for part in group.parts:
            self._fill(c, gamma, part)

    def correction(self, gamma: Any, gamma_dot: Any) -> Any:
        values = zip(self.cfgs, self.heards, gamma.tolist(), gamma_dot.tolist(), strict=True)
        return np.array([cfg.law.correction(g, gd, heard, cfg.coordination) for cfg, heard, g, gd in values])


def _flat(point: PathVectors) -> list[Any]:
    p, v, a = point
    return [*p, *v, *a]


def _path_lanes(jobs: Sequence[Job]) -> list[PathLanes]:
    """The lanes grouped for their paths' points: by path (the same to the bit: the same vehicle of many runs), and
    those of one class that takes lanes together, through a stand-in (a fleet on lines of its own). Worked out once
    for the same paths in the same order: a fleet's are the same objects step after step."""
    paths = [job.cfg.path for job in jobs]
    ids = tuple(map(id, paths))
    kept = _PATH_LANES.get(ids)
    if kept is None:
        if len(_PATH_LANES) >= 64:
            _PATH_LANES.clear()
            _REFUSED.clear()
        kept = _PATH_LANES[ids] = (paths, _grouped(jobs))
    return kept[1]


def _grouped(jobs: Sequence[Job]) -> list[PathLanes]:
    same: dict[object, list[int]] = {}
    for n, job in enumerate(jobs):
        assert job.shape is not None  # only such jobs step as lanes
        same.setdefault(job.shape.path, []).append(n)
    by_class: dict[type, list[PathLanes]] = {}
    out: list[PathLanes] = []
    for lanes in same.values():
        path = jobs[lanes[0]].cfg.path
        if not takes_lanes(path):
            out.append(PathLanes(lanes, None))
        else:
            by_class.setdefault(type(path), []).append(PathLanes(lanes, path if len(lanes) > 1 else None))
    for cls, groups in by_class.items():
        # A stand-in only for a class that says it takes lanes itself: a subclass of one that does may compute with
        # what its fields do not hold (as a controller's subclass must say so again)
        alike = len(groups) > 1 and vars(cls).get("lanes") is True
        out += _merged(groups, [jobs[n].cfg.path for g in groups for n in g.lanes]) if alike else groups
    return out


def _merged(groups: list[PathLanes], paths: list[Any]) -> list[PathLanes]:
    """One group of the lanes of groups through a stand-in of their paths (in the order of the lanes), or groups as
    they are if the paths do not stack."""
    lanes = [n for group in groups for n in group.lanes]
    try:
        stand_in = stacked(paths)
    except TypeError:
        return groups
    return [PathLanes(lanes, stand_in, tuple(groups))]


# The lanes' path groups by their paths' identities (the paths held, so no id is reused while its entry lives).
_PATH_LANES: dict[tuple[int, ...], tuple[list[Any], list[PathLanes]]] = {}
_REFUSED: set[int] = set()  # ids of the stand-ins (held by _PATH_LANES) whose evaluation raised
