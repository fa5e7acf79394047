"""Line of sight, its disturbance observer and the actuators as lanes (vehicles.lanes): each lane the scalar bits.

The default vehicles of a generated ring (the remus100 preset on fins: line of sight with its observer) stepped one at
a time until these took lanes (issue 26: the 1000-AUV ring at 0.30x real time, its steps alone allowing 0.5x). Here
every branch they take on the state, given arrays, is the scalar branch of each lane; the law as a whole, with an
observer's estimate and a current, likewise; and whole runs of line-of-sight fleets, one vehicle of many runs
(a sweep's batches) on a plant that differs from the model, record what they record alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, NamedTuple

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from msgspec.structs import replace as new

from numerics import atan2, cos
from numerics.lanes import FEW_LANES
from numerics.trig import _atan2_lanes, _sincos_lanes
from supervisor.config.fleet import vehicle_config
from supervisor.config.scenario import parse_scenario
from supervisor.engine.batch import BatchRun, run_batch
from supervisor.engine.inprocess import RunResult
from tests.conftest import CONFIGS, shortened
from tests.test_lanes import _bits, _values
from vehicles.actuators import remus100
from vehicles.disturbance_observer import Disturbance
from vehicles.lane_keys import stacked, unstacked
from vehicles.lanes import shape_of
from vehicles.line_of_sight import LineOfSight, _rate_within
from vehicles.saturation import within


def _raising() -> Any:
    """numpy's float errors as vehicles.lanes steps: raised (a float error stops the lanes), underflow apart."""
    return np.errstate(all="raise", under="ignore")


_RATIOS = st.one_of(
    _values,
    st.floats(-1e3, 1e3),
    st.sampled_from([0.4375, 0.6875, 1.1875, 2.4375, 2.0**-27, 2.0**60, 2.0**61, 2.0**-60, 5e-324]),
)


_BOUNDS = [0.4375, 0.6875, 1.1875, 2.4375, 2.0**-27, 2.0**60, 2.0**61, 2.0**-60]
_NEAR_BOUNDS = st.sampled_from(_BOUNDS).flatmap(lambda b: st.floats(b * (1 - 1e-15), b * (1 + 1e-15)))
_X = st.one_of(st.floats(-1e3, 1e3), st.sampled_from([1.0, -1.0, 3.0, -0.25]))


@settings(max_examples=400, deadline=None)
@given(
    st.lists(st.tuples(_RATIOS, _RATIOS), min_size=1, max_size=12),
    st.lists(st.tuples(st.one_of(_NEAR_BOUNDS, _RATIOS), _X, st.booleans()), min_size=1, max_size=12),
)
def test_atan2_of_lanes_is_atan2_of_each_lane(pairs, ratios):
    """numerics.atan2 given arrays: fdlibm's usual path on arrays (every interval of atan's reduction, reached by
    y = ratio x with the ratio at or about each bound), the scalar code for zeros, infinities, NaNs, x = 1 and
    ratios past 2^60; no float error raised. The array forms themselves, and the functions on few lanes (the scalar
    code of each) and on FEW_LANES or more (the pairs repeated: the array forms)."""
    with np.errstate(all="ignore"):
        pairs = pairs + [((-r if flip else r) * x, x) for r, x, flip in ratios]
    many = pairs * (FEW_LANES // len(pairs) + 1)
    for values in (pairs, many):
        y, x = (np.array(column, dtype=np.float64) for column in zip(*values, strict=True))
        with _raising():
            forms = [atan2(y, x), cos(y), _atan2_lanes(y, x), _sincos_lanes(y)[1]]  # type: ignore[arg-type]
        arctangents, cosines = [atan2(a, b) for a, b in values], [cos(a) for a, _ in values]
        assert [_bits(f) for f in forms] == [_bits(arctangents), _bits(cosines)] * 2


_TANH = st.one_of(
    _values,
    st.floats(-30.0, 30.0),
    st.floats(-1e-7, 1e-7),
    st.sampled_from([2.0**-28, -(2.0**-29), 22.0, -21.99, 19.4, 1.0, -1.0, 0.17328679513998632, 0.5198603854199589]),
)


@settings(max_examples=300, deadline=None)
@given(st.lists(_TANH, min_size=1, max_size=12))
def test_tanh_of_lanes_is_tanh_of_each_lane(xs):
    """numerics.tanh given an array (the bounded correction's): s_tanh.c's and s_expm1.c's branches by where, every
    lane the scalar bits (signed zeros, NaN, +-1 past 22), no float error raised: the array form, and tanh on few
    lanes and on FEW_LANES or more."""
    from numerics import tanh
    from numerics.exponential import _tanh_lanes

    for values in (xs, xs * (FEW_LANES // len(xs) + 1)):
        with _raising():
            forms = [tanh(np.array(values, dtype=np.float64)), _tanh_lanes(np.array(values))]  # type: ignore[arg-type]
        assert [_bits(f) for f in forms] == [_bits([tanh(x) for x in values])] * 2


_LIMITS = st.sampled_from([0.0, 0.5, 1.5, 9.1, math.inf])


@settings(max_examples=300, deadline=None)
@given(data=st.data())
def test_line_of_sight_and_actuator_branches_on_lanes_are_each_lanes(data):
    """within, the rate a moment holds, and the actuators' rates (fin command with no flow, the thrust's sign)."""
    lanes = data.draw(st.integers(1, 6))
    xs = data.draw(st.lists(_values, min_size=lanes, max_size=lanes))
    limits = data.draw(st.lists(_LIMITS, min_size=lanes, max_size=lanes))
    with _raising():
        assert _bits(within(np.array(xs), np.array(limits))) == _bits(
            [within(a, b) for a, b in zip(xs, limits, strict=True)]
        )
        for linear, quadratic in ((2.0, 5.0), (2.0, 0.0), (0.0, 0.0)):
            try:
                alone = [_rate_within(linear, quadratic, x) for x in xs]
            except ArithmeticError:
                continue  # the float raises: the lanes stop too
            assert _bits(_rate_within(linear, quadratic, np.array(xs))) == _bits(alone)
    fins = remus100(86.0)
    speeds = data.draw(
        st.lists(st.sampled_from([0.0, -0.0, 1e-4, -1e-4, 1.0, -1.5, 2.5]), min_size=lanes, max_size=lanes)
    )
    states = [data.draw(st.tuples(*[st.floats(-0.3, 0.3)] * 3)) for _ in range(lanes)]
    commands = [data.draw(st.tuples(*[st.sampled_from([0.0, -0.0, 3.0, -3.0, 1e3, -50.0])] * 3)) for _ in range(lanes)]
    many: Any
    for many in (fins, replace(fins, max_rate=0.2)):
        with _raising():
            rates = many.rates(_arrays(states), _arrays(commands), np.array(speeds))
            applied = many.applied(_arrays(states), np.array(speeds))
        for n, (a, c, u) in enumerate(zip(states, commands, speeds, strict=True)):
            assert _bits([r[n] for r in rates]) == _bits(many.rates(a, c, u))
            assert _bits([r[n] for r in applied]) == _bits(many.applied(a, u))


def _arrays(rows: list[tuple[float, ...]]) -> tuple[np.ndarray, ...]:
    return tuple(np.array(column, dtype=np.float64) for column in zip(*rows, strict=True))


def _ring_cfg() -> Any:
    scenario = parse_scenario((CONFIGS / "ring10_1hz.toml").read_text(), "ring10_1hz.toml")
    return vehicle_config(scenario, 1, 0)


_VARIANTS = [{}, {"fin_moment": None}, {"min_speed": 0.3, "margin": 1.0}, {"observer": 0.0, "lookahead": 2.0}]


@pytest.mark.parametrize("variant", _VARIANTS, ids=["fins", "no-fins", "min-speed", "no-observer"])
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_the_line_of_sight_law_on_lanes_is_the_law_of_each_lane(variant, data):
    """LineOfSight.control_with over lanes of states, paths, path rates, disturbance estimates and currents (what
    the fins give at each lane's speed differs lane by lane), with its options as the ring has them and otherwise:
    each lane's outputs (inputs, gamma_ddot, Lyapunov value, the drift it computed) are the scalar law's bits."""
    cfg = _ring_cfg()
    law, model, prm = replace(cfg.controller, **variant), cfg.vehicle, cfg.params
    assert isinstance(law, LineOfSight) and law.lanes
    lanes = data.draw(st.integers(1, 5))
    small = st.floats(-2.0, 2.0)
    rows = [data.draw(st.lists(small, min_size=18, max_size=18)) for _ in range(lanes)]
    for row in rows:  # a rotation near the identity (any floats would do for the bits; these keep it a vehicle)
        for i, value in zip((3, 7, 11), (1.0, 1.0, 1.0), strict=True):
            row[i] += value
    paths = [data.draw(st.lists(small, min_size=9, max_size=9)) for _ in range(lanes)]
    gammas = data.draw(st.lists(st.floats(-0.5, 2.0), min_size=lanes, max_size=lanes))
    estimates = [data.draw(st.tuples(*[st.sampled_from([0.0, 4.0, -30.0])] * 3)) for _ in range(lanes)]
    currents = data.draw(st.booleans())
    flows = [data.draw(st.lists(st.floats(-0.5, 0.5), min_size=6, max_size=6)) for _ in range(lanes)]

    def current(columns: list[Any]) -> Any:
        return ((columns[0], columns[1], columns[2]), (columns[3], columns[4], columns[5])) if currents else None

    alone = [
        law.control_with(
            Disturbance(d), model, prm, s, ((p[0], p[1], p[2]), (p[3], p[4], p[5]), (p[6], p[7], p[8])), 0.0, g, 1.0,
            current(f),
        )
        for s, p, g, d, f in zip(rows, paths, gammas, estimates, flows, strict=True)
    ]  # fmt: skip
    s_l, p_l, f_l = list(_arrays(rows)), list(_arrays(paths)), list(_arrays(flows))
    memory = stacked([Disturbance(d) for d in estimates])
    lanes_law: Any = law  # its float code, given arrays
    path = ((p_l[0], p_l[1], p_l[2]), (p_l[3], p_l[4], p_l[5]), (p_l[6], p_l[7], p_l[8]))
    with _raising():
        out = lanes_law.control_with(memory, model, prm, s_l, path, 0.0, np.array(gammas), 1.0, current(f_l))
    for n, one in enumerate(alone):
        assert _bits([t[n] for t in out.tau]) == _bits(one.tau)
        assert _bits([out.gamma_ddot[n], out.lyapunov[n]]) == _bits([one.gamma_ddot, one.lyapunov])
        assert out.drift is not None and one.drift is not None
        assert _bits([np.broadcast_to(v, (lanes,))[n] for part in out.drift for v in part]) == _bits(
            [v for part in one.drift for v in part]
        )


def test_memories_stack_and_unstack_to_the_bit():
    """lane_keys.stacked and unstacked: a float tree's lanes (tuples, named tuples, dataclasses, what __post_init__
    set beside their fields) back as they were (-0.0, NaN's bits), a value every lane shares as itself; what cannot
    be split lane by lane refused, both ways (the reviews found a named tuple of arrays handed whole to every
    vehicle, a shared array taken for lanes, an attribute __post_init__ set lost, a memory's own array of as many
    values as lanes split among them)."""
    values = [Disturbance((1.5, -0.0, math.nan)), Disturbance((2.0, 0.0, -1e-300))]
    together = stacked(values)
    assert isinstance(together.inputs[0], np.ndarray)
    back = unstacked(together, 2, together)
    assert [_bits(v.inputs) for v in back] == [_bits(v.inputs) for v in values]
    shared = Disturbance((0.0, 0.0, 0.0))
    assert stacked([shared, shared]).inputs == shared.inputs and unstacked(shared, 3, shared) == [shared] * 3
    start = Estimate(0.0, 7)
    named = unstacked(Estimate(np.array([1.0, -0.0]), 7), 2, stacked([start, start]))
    assert named == [Estimate(1.0, 7), Estimate(-0.0, 7)] and math.copysign(1.0, named[1].a) < 0
    gains = [Gained(1.0), Gained(3.0)]
    assert [g.gain for g in unstacked(stacked(gains), 2, stacked(gains))] == [2.0, 6.0]
    weights = np.zeros(2)
    for refused in ([{"a": 1.0}, {"a": 2.0}], [weights, weights], [[1.0], [2.0]], [Estimate(1.0, 1), Estimate(1.0, 2)]):
        with pytest.raises(TypeError):
            stacked(refused)
    own = Estimate(np.zeros(2), 1)  # an array where the memory held an int: the controller's own, not lanes
    for refused_lanes in ({"a": np.zeros(2)}, [np.zeros(2)], Estimate(np.zeros(3), 1), np.zeros((2, 2)), own):
        with pytest.raises(TypeError):
            unstacked(refused_lanes, 2, Estimate(0.0, 1) if refused_lanes is not own else Estimate(1, 1))


@dataclass(frozen=True)
class Gained:
    """A memory whose __post_init__ sets an attribute beside its field."""

    a: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "gain", 2.0 * self.a)


class Estimate(NamedTuple):
    a: Any  # a float, or its lanes
    n: int


_START = Estimate(0.0, 0)  # one start for every vehicle, as line of sight's NO_DISTURBANCE


class Learner:
    """An adaptive controller that says it takes lanes, its memory a named tuple: backstepping nudged by the sum of
    its surge speeds after each step (a memory that differs vehicle by vehicle)."""

    lanes = True

    def control(self, model: Any, params: Any, s: Any, path: Any, gamma: Any, gamma_dot: Any, v_d: Any, current: Any):
        return self.control_with(_START, model, params, s, path, gamma, gamma_dot, v_d, current)

    def start(self, model: Any, params: Any, s: Any) -> Estimate:
        return _START

    def control_with(
        self, memory: Any, model: Any, params: Any, s: Any, path: Any, gamma: Any, gamma_dot: Any, v_d: Any,
        current: Any,
    ) -> Any:  # fmt: skip
        from vehicles.path_following import Backstepping, ControlOutput

        out = Backstepping().control(model, params, s, path, gamma, gamma_dot, v_d, current)
        return ControlOutput(out.tau, out.gamma_ddot + 1e-3 * memory.a, out.lyapunov, out.drift)

    def update(self, memory: Any, model: Any, params: Any, stages: Any, after: Any, dt: float) -> Estimate:
        return Estimate(memory.a + after[12], memory.n + 1)


def test_an_adaptive_controller_with_a_named_tuple_memory_steps_as_lanes_to_each_vehicles_bits():
    """Three steps of the paper's vehicles (twice over) under Learner as lanes: each vehicle's memory and state the
    bits of it stepped alone throughout, and a vehicle stepping alone after the lanes goes on from its own memory."""
    from tests.test_lanes import _jobs
    from vehicles.lanes import step_all

    learner = Learner()  # one object: vehicles step together only with the same controller (lane_keys.key)
    jobs = [new(j, cfg=replace(j.cfg, controller=learner)) for j in _jobs(6)]
    jobs = [new(j, shape=shape_of(j.cfg)) for j in jobs]
    assert all(j.shape is not None and j.cfg.adaptive is not None for j in jobs)
    assert len({j.shape.shared for j in jobs if j.shape}) == 1
    together, alone = list(jobs), list(jobs)
    for k in range(3):
        lanes, single = step_all(together, min_lanes=2), step_all(alone, min_lanes=10**9)
        for a, b in zip(lanes, single, strict=True):
            assert not isinstance(a, Exception) and not isinstance(b, Exception)
            assert type(a[0].vehicle.memory) is Estimate and a[0].vehicle.memory.n == k + 1
            mine, theirs = a[0].vehicle.memory, b[0].vehicle.memory
            assert isinstance(mine, Estimate) and isinstance(theirs, Estimate) and _bits([mine.a]) == _bits([theirs.a])
            assert _bits(a[0].vehicle.x) == _bits(b[0].vehicle.x)
        together = [new(j, node=o[0], k=k + 1, t=(k + 1) * 0.1) for j, o in zip(together, lanes, strict=True)]  # type: ignore[index]
        alone = [new(j, node=o[0], k=k + 1, t=(k + 1) * 0.1) for j, o in zip(alone, single, strict=True)]  # type: ignore[index]


def test_line_of_sight_vehicles_step_as_lanes_unless_a_part_of_the_law_is_replaced():
    """The ring's vehicles (line of sight, its observer, fins) have a shape; a subclass that replaces a part of the
    law steps alone unless it says it takes lanes."""
    cfg = _ring_cfg()
    assert cfg.adaptive is not None and cfg.actuators is not None and shape_of(cfg) is not None

    class Steeper(LineOfSight):
        def torque_limit(self, prm: Any, u: float) -> float:
            return 2.0 * LineOfSight.torque_limit(self, prm, u)

    steeper = Steeper(**{name: getattr(cfg.controller, name) for name in ("lookahead", "fin_moment")})
    assert shape_of(replace(cfg, controller=steeper)) is None


def test_runs_of_line_of_sight_vehicles_on_a_mismatched_plant_batched_are_each_run_alone(monkeypatch):
    """inline5 (line of sight on fins) with its plant 30 % off the model, so the disturbance observer's estimate is
    large: each vehicle of three runs (links of three losses) steps as lanes with itself in the others, memory and
    all, and every run's result is the run alone, bit for bit."""
    from tests.test_batch import _alone, _same, lanes_counted

    together = lanes_counted(monkeypatch)
    text = shortened((CONFIGS / "inline5.toml").read_text(), 30.0)
    losses = ("0.0", "0.3", "0.5")  # one seed: the plant is drawn from it, so each vehicle's is the same in every run
    overrides = [["vehicle.uncertainty=0.3", f"comms.loss={loss}"] for loss in losses]
    runs = [BatchRun(parse_scenario(text, "inline5.toml", o), "inline5.toml", text, 3) for o in overrides]
    results = run_batch(runs)
    assert together[0] == 3 * 5 * 300  # every vehicle of every run, every step
    cfg = vehicle_config(runs[0].scenario, 1, 3)
    assert cfg.plant is not None and cfg.plant != cfg.params
    for run, result in zip(runs, results, strict=True):
        assert isinstance(result, RunResult)
        _same(result, _alone(run))
