"""Which path-following controller a scenario's vehicles steer with, and its options.

`path_following.controller = "auto"` (the default) picks by what the scenario says the controller cannot do or know:
where the vehicle has fins and a propeller (`vehicle.actuators`, or its own preset's: vehicles.actuators), whose moment
falls with the square of the speed, the line-of-sight law that asks only for what they give (vehicles.line_of_sight:
the other designs ask for more, and the vehicle leaves its tube by tens to hundreds of metres, measured in issue 24);
else where the plant's inertia or damping may differ from the model (`vehicle.uncertainty` on any of their groups), the
adaptive switching supervisor (vehicles.supervisory, the controller the paper's Lemma 1 rests on: Aguiar & Hespanha,
IEEE TAC 52(8), 2007) with its parameter set as wide as the uncertainty declared; else the backstepping design, which
the supervisor reduces to on a nominal plant (its nominal candidate is exact there: the same results, at less cost).
A named controller is used as named, with its controller_options.
"""

from __future__ import annotations

from typing import Any

from supervisor.config.plant import actuation, spreads
from supervisor.config.scenario_schema import Scenario

AUTO = "auto"
# The groups the supervisor's parameter set covers (vehicles.supervisory: each row's inertia and damping).
ESTIMATED = ("mass", "inertia", "linear_damping", "quadratic_damping", "angular_linear_damping",
             "angular_quadratic_damping")  # fmt: skip


def estimated_spread(sc: Scenario) -> float:
    """The largest declared spread of a group the supervisor estimates (0: none declared)."""
    declared = spreads(sc)
    return max((declared.get(group, 0.0) for group in ESTIMATED), default=0.0)


def controller_name(sc: Scenario, vehicle_id: int) -> str:
    """The name of vehicle_id's controller, `auto` resolved by its own actuators (a mixed fleet may steer with
    several)."""
    name = sc.path_following.controller
    if name != AUTO:
        return name
    if actuation(sc, vehicle_id) != "ideal":
        return "line_of_sight"
    return "supervisory" if estimated_spread(sc) > 0 else "backstepping"


def controller_names(sc: Scenario) -> list[str]:
    """Every controller the fleet steers with, once each, in the order of [[vehicles]]."""
    return list(dict.fromkeys(controller_name(sc, vid) for vid in sc.vehicle_ids))


def controller_options(sc: Scenario, name: str) -> dict[str, Any]:
    """The options of the controller `name` (one of controller_names): backstepping's are [path_following]'s gains;
    `auto`'s supervisor has those gains and a parameter set as wide as the declared uncertainty; a named one has the
    scenario's controller_options."""
    pf = sc.path_following
    gains = {"delta": pf.delta, "k1": pf.k1, "k2": pf.k2, "k_zeta": pf.k_zeta, "damping": pf.damping}
    if name == "backstepping":
        return gains
    if pf.controller == AUTO and name == "line_of_sight":  # its own guidance; the gains it shares are the section's
        return {"k1": pf.k1, "k2": pf.k2, "k_zeta": pf.k_zeta}
    if pf.controller == AUTO:
        return {**gains, "spread": estimated_spread(sc)}
    return dict(pf.controller_options)
