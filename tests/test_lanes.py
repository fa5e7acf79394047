"""Vehicles stepped together as lanes (vehicles.lanes) leave the records of each stepped alone, bit for bit.

The in-process engine steps every group of alike vehicles as lanes; here every group of two or more is (MIN_LANES
lowered), against the same runs with none, over the repository's scenarios: different paths (helices, lines,
arcs), the planar model, faults, lossy TDMA links and event-triggered transmission, line of sight on fins with its
disturbance observer (tests/test_lanes_line_of_sight.py has its branches). A scenario whose vehicles cannot step as
lanes (navigation, a current) must give the same records too, alone.
"""

from __future__ import annotations

import functools
import io
import math
import struct
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import vehicles.lanes
from comms.records.records import Disturbances
from numerics.lanes import greatest, least
from supervisor.config.fleet import initial_state, radio, vehicle_config
from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from supervisor.record.recorder import read_messages
from tests.conftest import CONFIGS, shortened
from vehicles.agent import VehicleState
from vehicles.lanes import Job, shape_of, step_all
from vehicles.runtime import NodeState
from vehicles.saturation import bounded_correction, clamp, hold, slope_rate_bound
from vehicles.step import step_records

SCENARIOS = {
    "paper.toml": 60.0,
    "paper.toml+faults": 60.0,
    "examples/helix_ring_30s.toml": 120.0,
    "examples/every_fault.toml": 60.0,
    "examples/planar_paper.toml": 40.0,
    "paper_acoustic.toml": 60.0,
    "examples/circles.toml": 40.0,
    "examples/lawnmower_survey.toml": 40.0,
    "examples/micromodem_tdma.toml": 60.0,
    "studies/robustness.toml": 30.0,  # navigation and a current: its vehicles step alone (ALONE)
    "ring10_1hz.toml": 30.0,  # line of sight on fins, its disturbance observer: a generated ring's default vehicles
    "inline5.toml": 30.0,
    "paper.toml+extension": 40.0,  # a user's controller that says it takes lanes, behind vehicles.guard
}
ALONE = {"studies/robustness.toml"}
EXTENSION = ["path_following.controller=tests.samples.controllers:RetunedLanes"]


FAULTS = [  # every kind, on the paper's vehicles (tests/test_inprocess.py's)
    "kind=link_down,sender=1,receiver=2,start=10,end=15",
    "kind=link_degraded,sender=1,receiver=3,extra_loss=0.5,extra_delay=0.3,start=5,end=25",
    "kind=blackout,start=20,end=22",
    "kind=modem_silent,vehicle=3,start=30,end=33",
    "kind=vehicle_kill,vehicle=2,start=41,end=44",
    "kind=broker_kill,start=46,end=48",
    "kind=frozen_gamma,vehicle=1,start=50,end=53",
    "kind=speed_cap,vehicle=3,gamma_dot_max=0.3,start=52,end=56",
    "kind=gamma_offset,vehicle=2,offset=0.5,start=54,end=57",
    "kind=clock_skew,vehicle=3,offset=0.4,start=55",
]


def _scenario(text: str) -> Any:
    """The scenario of text, with every fault kind or the extension if its first line says so."""
    first = text.partition("\n")[0]
    return parse_scenario(
        text, "test.toml", EXTENSION if "extension" in first else [], FAULTS if "faults" in first else []
    )


def bitwise(value: Any) -> Any:
    """value with every float replaced by its bits (-0.0 is not 0.0, a NaN is itself), arrays by their bytes."""
    if isinstance(value, float):
        return ("float", struct.pack("<d", value))
    if isinstance(value, np.ndarray):
        return ("array", value.dtype.str, value.shape, value.tobytes())
    if isinstance(value, dict):
        return {k: bitwise(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [bitwise(v) for v in value]
    return value


def _log(text: str, out: Path, monkeypatch: pytest.MonkeyPatch, min_lanes: int) -> list[tuple[str, int, object]]:
    monkeypatch.setattr(vehicles.lanes, "MIN_LANES", min_lanes)
    scenario = _scenario(text)
    quiet = Progress(scenario.scenario.duration, io.StringIO(), enabled=False)
    run_inprocess(scenario, "test.toml", text, out, scenario.scenario.seed, quiet)
    return [(topic, t, m) for topic, t, m in read_messages(out) if topic != "cpf/meta"]


@pytest.mark.parametrize("name", SCENARIOS)
def test_a_run_stepped_as_lanes_records_what_it_records_stepped_alone(name, tmp_path, monkeypatch):
    base, _, extra = name.partition("+")
    text = (f"# {extra}\n" if extra else "") + shortened((CONFIGS / base).read_text(), SCENARIOS[name])
    together = [0]
    inner = vehicles.lanes._together

    def counted(jobs):
        out = inner(jobs)
        together[0] += len(jobs)
        return out

    monkeypatch.setattr(vehicles.lanes, "_together", counted)
    lanes = _log(text, tmp_path / "lanes.mcap", monkeypatch, 2)
    stepped = together[0]
    alone = _log(text, tmp_path / "alone.mcap", monkeypatch, 10**9)
    assert together[0] == stepped  # stepped alone, nothing went through the lanes
    assert len(lanes) == len(alone) and bitwise(lanes) == bitwise(alone)  # == takes -0.0 for 0.0
    scenario = _scenario(text)
    assert any(shape_of(vehicle_config(scenario, i, 0)) for i in scenario.vehicle_ids) == (name not in ALONE)
    states = sum(1 for topic, _, _ in alone if topic.endswith("/state"))
    if name in ALONE:
        assert stepped == 0
    else:  # all of them, but where a fault sets one vehicle apart (its disturbance) or leaves it alone (a kill)
        assert stepped == states if "fault" not in name else 0.8 * states < stepped < states, (stepped, states)


def _jobs(count: int, x_of: dict[int, np.ndarray] | None = None) -> list[Job]:
    """count copies of the paper's vehicles (the three in turn) at their start, nothing heard."""
    scenario = parse_scenario((CONFIGS / "paper.toml").read_text(), "paper.toml")
    ids = scenario.vehicle_ids
    jobs = []
    for n in range(count):
        cfg = vehicle_config(scenario, ids[n % len(ids)], 0)
        state = initial_state(scenario, cfg)
        if x_of and n in x_of:
            state = VehicleState(state.t, x_of[n], state.gamma, state.gamma_dot)
        node = NodeState(state)
        jobs.append(Job(shape_of(cfg), cfg, radio(scenario, cfg.vehicle_id), node, 0, 0.0, 0.1, [], [], Disturbances()))
    return jobs


def test_a_vehicle_that_diverges_among_lanes_gets_the_error_it_gets_alone():
    """A lane with a state no step survives: the group goes back to one vehicle at a time, and that vehicle's
    outcome is step_records' own FloatingPointError, in its place; the others' are unchanged."""
    healthy = _jobs(6)
    broken_x = healthy[2].node.vehicle.x.copy()
    broken_x[12] = math.inf  # surge speed
    jobs = _jobs(6, {2: broken_x})
    outcomes = step_all(jobs, min_lanes=2)
    with pytest.raises(FloatingPointError) as alone:
        j = jobs[2]
        step_records(j.cfg, j.radio, j.node, j.k, j.t, j.dt, j.heard, j.neighbours, j.dist)
    assert isinstance(outcomes[2], FloatingPointError) and str(outcomes[2]) == str(alone.value)
    for n in (0, 1, 3, 4, 5):
        lane, alone_n = outcomes[n], step_all([healthy[n]], min_lanes=10**9)[0]
        assert not isinstance(lane, Exception) and not isinstance(alone_n, Exception)
        assert bitwise(lane[1].state) == bitwise(alone_n[1].state)


def test_only_parts_that_say_they_take_lanes_step_as_lanes():
    """A controller without `lanes = True` makes its vehicle step alone, behind vehicles.guard or not; one that says
    it takes lanes is taken at its word through the guard, which checks every lane's value."""
    from dataclasses import replace

    from tests.samples.controllers import Retuned, RetunedLanes
    from vehicles.guard import Guarded

    cfg = _jobs(1)[0].cfg
    assert shape_of(cfg) is not None
    assert shape_of(replace(cfg, controller=Retuned())) is None
    assert shape_of(replace(cfg, controller=Guarded(Retuned(), "controller test"))) is None
    guarded = Guarded(RetunedLanes(), "controller test")
    assert shape_of(replace(cfg, controller=guarded)) is not None
    with pytest.raises(FloatingPointError, match=r"controller test returned .* not finite numbers"):
        guarded._finite(np.array([1.0, math.nan]))


# --- the branches, lane by lane: each function given arrays equals the scalar function of each lane, to the bit ---

SPECIAL = [0.0, -0.0, 1.0, -1.0, 0.5, -0.5, 2.0, -2.0, 1e-300, -1e-300, 1e300, math.inf, -math.inf, math.nan]
_values = st.one_of(st.sampled_from(SPECIAL), st.floats(allow_nan=True, allow_infinity=True, width=64))


def _bits(values: Any) -> list[int]:
    return np.asarray(values, dtype=np.float64).view(np.uint64).tolist()


@pytest.mark.parametrize(
    ("f", "arity"),
    [
        (least, 2),
        (greatest, 2),
        (clamp, 3),
        (hold, 4),
        (slope_rate_bound, 2),
        (bounded_correction, 2),
    ],
    ids=["least", "greatest", "clamp", "hold", "slope_rate_bound", "bounded_correction"],
)
@settings(max_examples=300, deadline=None)
@given(data=st.data())
def test_a_branch_on_lanes_is_the_scalar_branch_of_each_lane(f, arity, data):
    lanes = data.draw(st.integers(1, 6))
    columns = [data.draw(st.lists(_values, min_size=lanes, max_size=lanes)) for _ in range(arity)]
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            scalar = [f(*row) for row in zip(*columns, strict=True)]
        except ArithmeticError:
            return  # Python's floats raise here: the lanes stop and the vehicles step alone (numpy is told to raise)
        together = f(*(np.array(c, dtype=np.float64) for c in columns))
    assert _bits(np.broadcast_to(together, (lanes,))) == _bits(scalar)


@functools.cache
def _paper_cfg() -> Any:
    return _jobs(1)[0].cfg


@settings(max_examples=200, deadline=None)
@given(data=st.data())
def test_saturated_inputs_and_the_bounded_correction_on_lanes_are_each_lanes(data):
    """path_following.saturated, and agent._bounded where the path's slope may be zero (nothing to bound there)."""
    from vehicles.agent import _bounded
    from vehicles.path_following import saturated

    lanes = data.draw(st.integers(1, 6))
    cols = [data.draw(st.lists(_values, min_size=lanes, max_size=lanes)) for _ in range(3)]
    cfg = _paper_cfg()
    prm = cfg.params
    arrays: list[Any] = [np.array(c) for c in cols]
    inputs = saturated(prm, *arrays)
    scalar = [saturated(prm, *row) for row in zip(*cols, strict=True)]
    for n in range(3):
        assert _bits(inputs[n]) == _bits([s[n] for s in scalar])
    assert cfg.correction_acceleration is not None
    slopes = data.draw(st.lists(st.sampled_from([0.0, -0.0, 0.5, 1.0, 3.0]), min_size=lanes, max_size=lanes))
    v_tilde = data.draw(st.lists(st.floats(-10, 10), min_size=lanes, max_size=lanes))
    zero = [0.0] * lanes

    def point(slope: Any, z: Any) -> Any:
        return ((z, z, z), (slope, z, z), (z, z, z))

    corrections: Any = np.array(v_tilde)
    with np.errstate(all="raise", under="ignore"):  # as vehicles.lanes steps
        bounded = _bounded(cfg, point(np.array(slopes), np.array(zero)), corrections)
    assert _bits(bounded) == _bits([_bounded(cfg, point(s, 0.0), v) for s, v in zip(slopes, v_tilde, strict=True)])


_ANGLES = st.one_of(
    _values,
    st.floats(-1e7, 1e7),  # the medium reduction
    st.integers(-200, 200).map(lambda n: n * math.pi / 2),  # near multiples of pi/2: its second and third rounds
    st.integers(-200, 200).flatmap(lambda n: st.floats(n * math.pi / 2 - 1e-9, n * math.pi / 2 + 1e-9)),
)


@settings(max_examples=300, deadline=None)
@given(st.lists(_ANGLES, min_size=1, max_size=12))
def test_sincos_of_lanes_is_sincos_of_each_lane(angles):
    """numerics.sincos given an array: its arithmetic on the lanes it can take, the scalar code on the rest; the
    same bits either way, with no float error raised (vehicles.lanes raises on any). Its array form (_sincos_lanes,
    what FEW_LANES or more take) and the function on few lanes and on many (the angles repeated)."""
    from numerics import sincos
    from numerics.lanes import FEW_LANES
    from numerics.trig import _sincos_lanes

    many = angles * (FEW_LANES // len(angles) + 1)
    for values, form in ((angles, _sincos_lanes), (angles, sincos), (many, sincos)):
        with np.errstate(all="raise", under="ignore"):
            s, c = form(np.array(values, dtype=np.float64))  # type: ignore[arg-type]
        scalar = [sincos(a) for a in values]
        assert _bits(s) == _bits([v[0] for v in scalar]) and _bits(c) == _bits([v[1] for v in scalar])


def _alike(controllers: list[Any], paths: list[Any] | None = None) -> list[Job]:
    """The paper's vehicle 2, once per controller (and path), each controller behind the guard as an extension's."""
    from dataclasses import replace

    from vehicles.guard import Guarded

    base = _jobs(1)[0]
    jobs = []
    for n, controller in enumerate(controllers):
        cfg = replace(base.cfg, controller=Guarded(controller, "controller test"))
        if paths is not None:
            cfg = replace(cfg, path=paths[n])
        jobs.append(
            Job(shape_of(cfg), cfg, base.radio, NodeState(initial_state_of(cfg)), 0, 0.0, 0.1, [], [], Disturbances())
        )
    return jobs


def initial_state_of(cfg: Any) -> VehicleState:
    scenario = parse_scenario((CONFIGS / "paper.toml").read_text(), "paper.toml")
    return initial_state(scenario, cfg)


def _same_bits_as_alone(jobs: list[Job]) -> None:
    together, alone = step_all(jobs, min_lanes=2), step_all(jobs, min_lanes=10**9)
    for a, b in zip(together, alone, strict=True):
        assert not isinstance(a, Exception) and not isinstance(b, Exception)
        assert bitwise(a[1].state) == bitwise(b[1].state)


def test_vehicles_step_together_only_with_parts_the_same_to_the_bit():
    """A gain its class leaves out of its repr and ==, and a zero's sign, set vehicles apart (the review found both
    stepped with the first vehicle's: tau off, an error -0.0 recorded as 0.0)."""
    from tests.samples.controllers import Hidden
    from vehicles.paths import Line

    hidden = _alike([Hidden(k1=0.5), Hidden(k1=2.0), Hidden(k1=0.5)])
    assert hidden[0].shape == hidden[2].shape != hidden[1].shape
    _same_bits_as_alone(hidden)
    lines = [Line((5.0, -0.0, 0.0), (1.0, -0.0, 0.0)), Line((5.0, 0.0, 0.0), (1.0, 0.0, 0.0))]
    signed = _alike([Hidden(k1=0.5)] * 2, lines)
    first, second = signed[0].shape, signed[1].shape
    assert first is not None and second is not None
    assert first.shared == second.shared and first.path != second.path
    _same_bits_as_alone(signed)


def test_alike_vehicles_share_one_shape_object():
    """Equal shapes are one object, hashed once (vehicles.lane_keys.interned): grouping 1000 vehicles a step hashed
    every vehicle's nested keys again (4 us each); unequal ones stay apart."""
    from tests.samples.controllers import Hidden
    from vehicles.lane_keys import interned

    jobs = _alike([Hidden(k1=0.5), Hidden(k1=0.5), Hidden(k1=2.0)])
    shapes = [job.shape for job in jobs if job.shape is not None]
    assert len(shapes) == 3
    assert shapes[0].shared is shapes[1].shared and shapes[0].shared != shapes[2].shared
    assert interned((1.0, "a")) is interned((1.0, "a")) and interned(0.0) != interned(-0.0)
    assert hash(interned((1.0, "a"))) == hash(interned((1.0, "a")))


def _ring_jobs(paths: list[Any] | None = None) -> list[Job]:
    """ring10_1hz's ten vehicles (each on a line of its own) at their start, nothing heard; paths: theirs replaced."""
    from dataclasses import replace

    scenario = parse_scenario((CONFIGS / "ring10_1hz.toml").read_text(), "ring10_1hz.toml")
    jobs = []
    for n, vid in enumerate(scenario.vehicle_ids):
        cfg = vehicle_config(scenario, vid, 0)
        cfg = cfg if paths is None else replace(cfg, path=paths[n])
        node = NodeState(initial_state(scenario, cfg))
        jobs.append(Job(shape_of(cfg), cfg, radio(scenario, vid), node, 0, 0.0, 0.1, [], [], Disturbances()))
    return jobs


def test_a_fleet_on_paths_of_its_own_takes_their_points_in_one_call_per_stage(monkeypatch):
    """Ten lines, one per vehicle: each RK4 stage evaluates one stand-in line whose fields are the ten lines' (it
    evaluated each line alone, 40 calls a step, before); a path class that says it takes lanes but whose code
    cannot take its fields as arrays falls back to each path alone. The same bits as each vehicle alone both ways."""
    from dataclasses import dataclass

    from vehicles.paths import Line

    calls: list[int] = []
    evaluate = Line.evaluate_floats

    def counted(self: Line, gamma: Any) -> Any:
        if isinstance(gamma, np.ndarray):
            calls.append(len(gamma))
        return evaluate(self, gamma)

    jobs = _ring_jobs()
    assert len({job.shape.path for job in jobs if job.shape}) == 10
    monkeypatch.setattr(Line, "evaluate_floats", counted)
    step_all(jobs, min_lanes=2)
    assert calls == [10] * 4
    _same_bits_as_alone(jobs)

    @dataclass(frozen=True)
    class Fussy(Line):  # its code branches on a field: refuses arrays
        def evaluate_floats(self, gamma: Any) -> Any:
            if isinstance(gamma, np.ndarray):
                calls.append(len(gamma))
            return evaluate(self, gamma) if self.start[0] <= 1e9 else None

    fussy = [Fussy(job.cfg.path.start, job.cfg.path.velocity) for job in jobs]  # type: ignore[attr-defined]
    Fussy.lanes = True  # it says so itself (a subclass's inherited word does not make a stand-in)
    fussy_jobs = _ring_jobs(fussy)
    calls.clear()
    together = step_all(fussy_jobs, min_lanes=2)
    assert calls == [10]  # its stand-in tried once and refused (each path's lanes since); the vehicles still as lanes
    calls.clear()
    step_all(fussy_jobs, min_lanes=2)
    assert calls == []  # the refusal remembered
    alone = step_all(fussy_jobs, min_lanes=10**9)
    assert [bitwise(a[1].state) for a in together] == [bitwise(b[1].state) for b in alone]  # type: ignore[index]
