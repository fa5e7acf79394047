"""From a validated Scenario to what a vehicle process serves each of its vehicles with (vehicles.start).

The supervisor builds them for the processes it starts (and hands them over in a private file); a vehicle started
by hand builds its own from the scenario file. Either way from here, so both start identically.
"""

from __future__ import annotations

from collections.abc import Sequence

from comms.records.messages import Hello, Message
from supervisor.config.fleet import initial_state, radio, restarted_node, vehicle_config
from supervisor.config.scenario_digest import digest, section_digests, vehicle_seed
from supervisor.config.scenario_schema import Scenario
from vehicles.runtime import NodeState
from vehicles.start import VehicleStart

Resume = tuple[Message, int]  # a restarted vehicle: its last recorded state message, its last transmission's seq


def vehicle_starts(
    scenario: Scenario,
    ids: Sequence[int],
    gamma0: dict[int, float] | None = None,
    resume: Resume | None = None,
    start_step: int = 0,
    seed: int | None = None,
) -> tuple[VehicleStart, ...]:
    """The start of each vehicle of ids. gamma0: initial gammas already resolved (no search for "closest");
    resume: the one vehicle of ids restarts at start_step where it coasted to from its last recorded state
    (supervisor.config.fleet.restarted_node); seed: the run's (None: the
    scenario's), which navigation noise and a perturbed plant draw from."""
    run_seed = scenario.scenario.seed if seed is None else seed
    sections = section_digests(scenario, vehicle_seed(scenario, run_seed))  # once for all: the whole scenario
    whole, dt = digest(sections), scenario.scenario.step
    starts = []
    for vid in ids:
        cfg = vehicle_config(scenario, vid, run_seed)
        if resume is not None:
            initial = restarted_node(cfg, *resume, start_step, dt, scenario.faults)
        else:
            initial = NodeState(initial_state(_starting_at(scenario, vid, (gamma0 or {}).get(vid)), cfg))
        greeting = Hello(f"vehicle {vid}", whole, sections).to_message()
        near = tuple(scenario.neighbours(vid))
        starts.append(VehicleStart(cfg, initial, radio(scenario, vid), near, dt, greeting, start_step))
    return tuple(starts)  # a process's, as it is handed over (vehicles.start.read_starts)


def _starting_at(scenario: Scenario, vid: int, gamma0: float | None) -> Scenario:
    """The scenario with vehicle vid's gamma0 set (resolved elsewhere for it: no search here); the scenario itself,
    and so its digest, stays the supervisor's."""
    if gamma0 is None:
        return scenario
    vehicles = tuple(v.model_copy(update={"gamma0": gamma0}) if v.id == vid else v for v in scenario.vehicles)
    return scenario.model_copy(update={"vehicles": vehicles})
