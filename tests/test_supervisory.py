"""The adaptive switching supervisor (vehicles.supervisory; Aguiar & Hespanha, IEEE TAC 52(8), 2007): on a fixed
plant its switching settles, on the candidate of that plant in every row the motion excites; from then on the
backstepping Lyapunov function never increases (the certainty-equivalence candidate is the exact design); on the
nominal plant it is the backstepping controller to the bit; `auto` chooses it where the scenario declares the plant
uncertain; its options are checked."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from supervisor.config.fleet import controller_of
from supervisor.config.scenario import parse_scenario
from supervisor.errors import ScenarioError
from tests.conftest import CONFIGS
from tests.test_path_following import GAINS, PAPER_HELIX, REMUS, spatial_start
from vehicles.agent import Telemetry, VehicleConfig, VehicleState, step
from vehicles.coordination import CoordinationGains
from vehicles.dynamics import SPATIAL
from vehicles.nearest import closest_gamma
from vehicles.params import VehicleParams
from vehicles.path_following import Backstepping
from vehicles.supervisory import SupervisorMemory, Supervisory, _candidates, factors

SUPERVISOR = Supervisory()
GRID = [(a, b, c) for a in factors(0.6, 3) for b in factors(0.6, 3) for c in factors(0.6, 3)]
SURGE, PITCH, YAW = 0, 4, 5  # rows of the monitoring signals


# The design's claims are for unsaturated inputs: the thrust limit raised to the 60 N the preset had before issue 16,
# as in test_path_following's Lyapunov tests (the start's first seconds reach the REMUS's own 14 N).
NOMINAL = dataclasses.replace(REMUS, max_surge_force=60.0)


def run_alone(controller, plant: VehicleParams | None, seconds: float, dt: float = 0.1):
    """One vehicle 3 m off the paper's helix, no neighbours; its telemetry and its supervisor's memories."""
    cfg = VehicleConfig(1, SPATIAL, NOMINAL, PAPER_HELIX, controller, CoordinationGains(v_r=1.0), plant=plant)
    x0 = spatial_start((-12.0, -16.0, 1.0), (0, 0, -45))
    state = VehicleState(0.0, x0, closest_gamma(PAPER_HELIX, x0[:3], -200.0, 200.0), 0.0)
    log: list[Telemetry] = []
    memories: list[SupervisorMemory] = []
    for _ in range(round(seconds / dt)):
        state, tel = step(cfg, state, dt, neighbours=[])
        log.append(tel)
        if isinstance(state.memory, SupervisorMemory):
            memories.append(state.memory)
    return log, memories


@pytest.mark.parametrize("level", [(1.0, 1.6, 1.6), (0.4, 0.4, 0.4), (1.6, 1.6, 1.6)])
def test_on_a_fixed_plant_the_switching_settles_on_its_candidate_and_v_then_never_increases(level):
    """Hespanha, Liberzon & Morse (Automatica 39(2), 2003): with a finite set holding the plant and hysteresis, the
    switching stops. Here it stops within 120 s (measured: 6, 113 and 1 s), on the plant's own candidate in the
    surge, pitch and yaw rows (the ones the controller inverts), and from then on the controller is the exact design
    for this plant: V non-increasing (to 1e-6 of its start, as for the nominal design in test_path_following)."""
    plant = _candidates(NOMINAL, 0.6, 3)[GRID.index(level)]
    log, memories = run_alone(SUPERVISOR, plant, 200.0, dt=0.02)  # the step of test_path_following's V tests
    last = memories[-1]
    settled = next(i for i in range(len(memories)) if memories[i].selected == last.selected
                   and all(m.selected == last.selected for m in memories[i:]))  # fmt: skip
    assert settled * 0.02 < 120.0
    assert last.switches < 20
    for row in (SURGE, PITCH, YAW):
        assert GRID[last.selected[row]] == level, (row, GRID[last.selected[row]])
    tau = np.array([t.tau for t in log])[settled + 1 :]
    assert np.all(np.abs(tau[:, 0]) < NOMINAL.max_surge_force) and np.all(np.abs(tau[:, 1:]) < NOMINAL.max_torque)
    v = np.array([t.lyapunov for t in log])[settled + 1 :]
    assert np.max(np.diff(v)) <= 1e-6 * max(v[0], 1e-3)
    assert v[-1] < 1e-3


def test_on_a_nominal_plant_it_is_the_backstepping_controller_to_the_bit():
    """The nominal candidate's prediction is exact there: no switch, and the same floats as backstepping."""
    supervised, memories = run_alone(Supervisory(), None, 60.0)
    plain, _ = run_alone(Backstepping(), None, 60.0)
    assert memories[-1].switches == 0
    assert all(
        np.array_equal(a.x, b.x) and a.tau.tolist() == b.tau.tolist() for a, b in zip(supervised, plain, strict=True)
    )


def test_a_wrong_model_moves_the_supervisor_off_the_nominal_candidate():
    """It acts: on a plant with 1.6 x the quadratic damping, the run differs from backstepping's (which cannot
    know), and its path error after 100 s is closer to the nominal run's |delta| = 1 m."""
    plant = _candidates(NOMINAL, 0.6, 3)[GRID.index((1.0, 1.0, 1.6))]
    supervised, memories = run_alone(SUPERVISOR, plant, 200.0)
    plain, _ = run_alone(GAINS, plant, 200.0)
    assert memories[-1].switches > 0
    late = slice(1000, None)
    off = [abs(float(np.linalg.norm(t.error)) - 1.0) for t in supervised[late]]
    plain_off = [abs(float(np.linalg.norm(t.error)) - 1.0) for t in plain[late]]
    assert max(off) < max(plain_off)


PAPER = (CONFIGS / "paper.toml").read_text()


@pytest.mark.parametrize(
    ("sets", "chosen"),
    [
        ([], Backstepping(damping="feedforward")),
        (["vehicle.uncertainty=0.3"], Supervisory(spread=0.3)),
        (["vehicle.uncertainty={angular_quadratic_damping = 0.5, buoyancy = 0.8}"], Supervisory(spread=0.5)),
        (["vehicle.uncertainty={buoyancy = 0.2}"], Backstepping()),  # restoring terms: outside its parameter set
        (["vehicle.uncertainty=0.3", "path_following.controller=backstepping"], Backstepping()),
        (["vehicle.uncertainty=0.3", "path_following.k1=0.7"], Supervisory(k1=0.7, spread=0.3)),
        (
            ["path_following.controller=supervisory", "path_following.controller_options={levels = 5}"],
            Supervisory(levels=5),
        ),
    ],
)
def test_auto_chooses_the_supervisor_where_the_scenario_declares_the_inertia_or_damping_uncertain(sets, chosen):
    assert controller_of(parse_scenario(PAPER, "paper.toml", sets), 1) == chosen


@pytest.mark.parametrize(
    ("sets", "message"),
    [
        (["path_following.controller_options={levels = 5}"], "path_following.controller_options: auto chooses"),
        (["path_following.controller=supervisory", "path_following.controller_options={levels = 4}"],
         "levels must be odd so that the nominal parameters are a candidate, got 4"),
        (["path_following.controller=supervisory", "path_following.controller_options={spread = 1.0}"],
         "path_following.controller_options.spread: Input should be less than 1"),
        (["path_following.controller=supervisory", "path_following.controller_options={hysteresis = 0}"],
         "path_following.controller_options.hysteresis: Input should be greater than 0"),
    ],
)  # fmt: skip
def test_bad_supervisor_options_are_one_line_errors(sets, message):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(PAPER, "paper.toml", sets)
    assert message in str(err.value)
    assert "\n" not in str(err.value)


def test_a_restarted_vehicle_starts_its_memory_again():
    """A restarted vehicle's state is rebuilt from its last report (supervisor.config.fleet.restore_state), which
    carries no memory: the supervisor starts again from the nominal candidate, as at the start of the run."""
    plant = _candidates(NOMINAL, 0.6, 3)[GRID.index((1.0, 1.0, 1.6))]
    cfg = VehicleConfig(1, SPATIAL, NOMINAL, PAPER_HELIX, SUPERVISOR, CoordinationGains(v_r=1.0), plant=plant)
    x0 = spatial_start((-12.0, -16.0, 1.0), (0, 0, -45))
    state = VehicleState(0.0, x0, closest_gamma(PAPER_HELIX, x0[:3], -200.0, 200.0), 0.0)
    for _ in range(300):
        state, _ = step(cfg, state, 0.1, neighbours=[])
    learned = state.memory
    assert isinstance(learned, SupervisorMemory) and learned.switches > 0
    restarted, _ = step(cfg, VehicleState(state.t, state.x, state.gamma, state.gamma_dot), 0.1, neighbours=[])
    again = restarted.memory
    assert isinstance(again, SupervisorMemory)
    assert again.switches < learned.switches
    assert float(np.max(again.monitor)) < float(np.max(learned.monitor))


def test_cpf_validate_says_which_controller_auto_chose_and_why():
    from supervisor.config.explain import what_would_run

    uncertain = what_would_run(parse_scenario(PAPER, "paper.toml", ["vehicle.uncertainty=0.3"]))
    nominal = what_would_run(parse_scenario(PAPER, "paper.toml", []))
    assert "Path following: supervisory, delta -1 m (auto: inertia or damping uncertain by up to +-30 %)." in uncertain
    assert "Path following: backstepping, delta -1 m (auto: the nominal plant)." in nominal
