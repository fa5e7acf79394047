"""One vehicle flying a straight line on the remus100 preset's fins, stepped on its own (vehicles.agent.step): the
tests' way to put a single plant through the default controller."""

from __future__ import annotations

import numpy as np

from supervisor.config.fleet import initial_state, vehicle_config
from supervisor.config.scenario import parse_scenario
from vehicles.agent import step

Start = tuple[float, float, float, float]  # x, y, z [m], heading [deg]


def scenario_text(
    speed: float, seconds: float, preset: str = "remus100", seed: int = 0, uncertainty: str = "0.0",
    vehicle_id: int = 1, options: str | None = None, start: Start = (0.0, 6.0, -10.0, -60.0),
) -> str:  # fmt: skip
    """A vehicle at start (x, y, z [m], heading [deg]; by default 6 m off the line, heading 60 deg off it) and a level
    line at 10 m depth along x (and a second vehicle, far off, for the graph); options: line_of_sight's
    controller_options (None: the default controller)."""
    chosen = "" if options is None else f'controller = "line_of_sight"\ncontroller_options = {options}'
    return f"""
[scenario]
name = "line"
duration = {seconds}
step = 0.1
seed = {seed}
[vehicle]
preset = "{preset}"
actuators = "remus100"
uncertainty = {uncertainty}
[path_following]
{chosen}
[coordination]
v_r = {speed}
[graph]
edges = [[{vehicle_id}, 99]]
[[vehicles]]
id = {vehicle_id}
position = [{start[0]}, {start[1]}, {start[2]}]
attitude_rpy_deg = [0.0, 0.0, {start[3]}]
path = {{ type = "line", start = [0.0, 0.0, -10.0], velocity = [1.0, 0.0, 0.0] }}
[[vehicles]]
id = 99
position = [0.0, 50.0, -10.0]
path = {{ type = "line", start = [0.0, 50.0, -10.0], velocity = [1.0, 0.0, 0.0] }}
"""


def fly_a_line(speed: float, seconds: float, **kwargs: object) -> list[float]:
    """The path error [m] at each 0.1 s step of the vehicle of scenario_text(speed, seconds, **kwargs)."""
    vehicle_id = int(kwargs.get("vehicle_id", 1))  # type: ignore[call-overload]
    sc = parse_scenario(scenario_text(speed, seconds, **kwargs), "line.toml")  # type: ignore[arg-type]
    cfg = vehicle_config(sc, vehicle_id)
    state, errors = initial_state(sc, cfg), []
    for _ in range(round(seconds / 0.1)):
        state, tel = step(cfg, state, 0.1, [])
        errors.append(float(np.linalg.norm(tel.error)))
    return errors
