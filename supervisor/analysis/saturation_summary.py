"""When and for how long each vehicle sat at its speed limit ([saturation] top_speed), from the recorded states.

Nothing extra goes over the wire: a vehicle's bound on |gamma_dot| at a recorded gamma is a function of its path and
its top speed (vehicles.saturation.rate_bound), and the vehicle holds gamma_dot exactly at it while saturated, so
an instant is "at the limit" where the recorded |gamma_dot| reaches the bound (to a relative 1e-9: the state's
numbers are recorded exactly).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from supervisor.analysis.summary import Series
from supervisor.config.fleet import vehicle_config
from supervisor.config.scenario_schema import Scenario
from vehicles.saturation import rate_bound

AT_LIMIT = 1.0 - 1e-9  # |gamma_dot| >= AT_LIMIT x bound: held at the bound
SHOWN_SPANS = 3  # spans listed per vehicle in the text; the count and total say the rest


@dataclass(frozen=True, slots=True)
class LimitTime:
    """One vehicle's time at its speed limit."""

    vehicle: int
    top_speed: float  # m/s
    total: float  # s at the limit
    spans: tuple[tuple[float, float], ...]  # (start, end) s of each stretch at the limit


def at_limit(scenario: Scenario, series: Series) -> list[LimitTime] | None:
    """Each vehicle's time at its speed limit; None if the scenario sets no top speed."""
    if scenario.saturation.top_speed is None:
        return None
    step = scenario.scenario.step
    out = []
    for column, vehicle in enumerate(series.vehicle_ids):
        cfg = vehicle_config(scenario, vehicle)
        assert cfg.top_speed is not None  # [saturation] top_speed is set
        gamma, rate = series.gamma[:, column], series.gamma_dot[:, column]
        bound = np.array([rate_bound(cfg.model, cfg.path, float(g), cfg.top_speed) for g in gamma])
        held = np.abs(rate) >= AT_LIMIT * bound  # NaN (vehicle down) compares False
        out.append(LimitTime(vehicle, cfg.top_speed, float(held.sum()) * step, _spans(series.t, held, step)))
    return out


def _spans(t: np.ndarray, held: np.ndarray, step: float) -> tuple[tuple[float, float], ...]:
    """(start, end) of each run of True in held; a run's end is its last instant plus one step."""
    edges = np.diff(np.concatenate(([0], held.astype(np.int8), [0])))
    starts, ends = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
    return tuple((float(t[a]), float(t[b - 1]) + step) for a, b in zip(starts, ends, strict=True))


def format_limits(limits: list[LimitTime] | None, duration: float) -> str | None:
    """Lines for the run summary; None if the scenario sets no top speed."""
    if limits is None:
        return None
    lines = []
    for item in limits:
        if not item.spans:
            lines.append(f"vehicle {item.vehicle}: never at its speed limit ({item.top_speed:.3g} m/s)")
            continue
        shown = ", ".join(f"{a:.1f}-{b:.1f}" for a, b in item.spans[:SHOWN_SPANS])
        more = ", ..." if len(item.spans) > SHOWN_SPANS else ""
        lines.append(
            f"vehicle {item.vehicle}: at its speed limit ({item.top_speed:.3g} m/s) for {item.total:.1f} s of "
            f"{duration:g} s, {len(item.spans)} span(s): {shown}{more} s"
        )
    return "\n".join(lines)


def limits_metrics(limits: list[LimitTime] | None) -> dict[str, object]:
    """For metrics.json: per vehicle, its top speed, seconds at it and the spans; {} if no top speed is set."""
    if limits is None:
        return {}
    return {
        "speed_limit": {
            str(item.vehicle): {"top_speed": item.top_speed, "seconds": item.total, "spans": list(item.spans)}
            for item in limits
        }
    }
