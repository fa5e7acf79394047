"""How long each vehicle's inputs sat at their limits, from the recorded states (issue 24: a controller that asks for
more than its vehicle can give shows here before it shows in its errors).

Nothing extra goes over the wire: a state records the inputs the vehicle got and its surge speed, and the limits
follow from the scenario. With ideal actuators they are the vehicle's constant max_surge_force and max_torque; with
fins and a propeller (vehicles.actuators) the thrust limit and the fins' moment at that speed, L u^2 max_deflection,
capped by the controller's own limits. An input counts as at its limit within LIMIT_SHARE of it: the controller
clamps exactly, but a fin servo only approaches its stop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from supervisor.analysis.condense import SHOWN, first_looked_at, kept_note
from supervisor.analysis.summary import Series
from supervisor.config.fleet import vehicle_config
from supervisor.config.scenario_schema import Scenario

LIMIT_SHARE = 0.99  # |input| >= 0.99 x its limit: at the limit
INPUTS = ("surge", "pitch", "yaw")


@dataclass(frozen=True, slots=True)
class InputTime:
    """One vehicle's seconds at each input's limit, of the seconds it was alive."""

    vehicle: int
    seconds: tuple[float, float, float]  # surge, pitch, yaw (pitch NaN for a planar vehicle)
    alive: float  # s with a recorded state


def at_input_limits(scenario: Scenario, series: Series) -> list[InputTime] | None:
    """Each vehicle's time at its input limits; None if the series holds no inputs (an older log)."""
    if series.inputs is None or series.surge is None:
        return None
    step, out = scenario.scenario.step, []
    for column, vehicle in enumerate(series.vehicle_ids):
        limits = _limits(scenario, vehicle, series.surge[:, column])
        inputs = np.abs(series.inputs[:, :, column])
        alive = ~np.isnan(series.gamma[:, column])
        held = [inputs[:, i] >= LIMIT_SHARE * limits[i] for i in range(3)]  # NaN compares False
        planar = scenario.scenario.dimension == 2
        seconds = tuple(float("nan") if planar and i == 1 else float(held[i].sum()) * step for i in range(3))
        out.append(InputTime(vehicle, (seconds[0], seconds[1], seconds[2]), float(alive.sum()) * step))
    return out


def _limits(scenario: Scenario, vehicle: int, surge: np.ndarray) -> list[np.ndarray]:
    """Each input's limit at every recorded instant."""
    cfg = vehicle_config(scenario, vehicle)
    thrust, torque = cfg.params.max_surge_force, cfg.params.max_torque
    ones = np.ones_like(surge)
    if cfg.actuators is None:
        return [thrust * ones, torque * ones, torque * ones]
    fins = np.minimum(torque, cfg.actuators.fin_lift * surge * surge * cfg.actuators.max_deflection)
    return [min(thrust, cfg.actuators.max_thrust) * ones, fins, fins]


def format_input_limits(times: list[InputTime] | None) -> str | None:
    """One line per vehicle that spent any time at a limit, for the run summary; None if none did (or no inputs).
    More than MAX_ROWS such vehicles: the SHOWN that spent the most time at a limit (supervisor.analysis.condense)."""
    if times is None:
        return None
    found = []
    for item in times:
        shares = [(name, s / item.alive) for name, s in zip(INPUTS, item.seconds, strict=True) if item.alive and s > 0]
        if shares:
            text = ", ".join(f"{name} {percent(share)}" for name, share in shares)
            line = f"vehicle {item.vehicle}: inputs at their limits for {text} of its time"
            found.append((max(share for _, share in shares), line))
    most = first_looked_at(found, lambda item: -item[0])
    note = (
        [kept_note(SHOWN, len(found), "vehicles at a limit that were there longest")] if len(most) < len(found) else []
    )
    return "\n".join([line for _, line in most] + note) or None


def percent(share: float) -> str:
    """A share of the time as the summary prints it: whole percent, tenths below 1 %."""
    return f"{100 * share:.0f} %" if share >= 0.01 else f"{100 * share:.1f} %"


def input_limits_metrics(times: list[InputTime] | None) -> dict[str, object]:
    """For metrics.json: per vehicle, seconds at each input's limit and seconds alive; {} without inputs."""
    if times is None:
        return {}
    return {
        "inputs_at_limit": {
            str(item.vehicle): {**dict(zip(INPUTS, item.seconds, strict=True)), "alive": item.alive} for item in times
        }
    }
