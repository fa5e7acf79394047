"""Each vehicle's desired path p_d(gamma) as points, for the scene: from the scenario the log's meta carries, over
the gammas the vehicle went through in the run (its published states), about PATH_SPACING m apart."""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import NDArray

from supervisor.config.fleet import build_path
from supervisor.config.scenario_schema import Scenario
from supervisor.record.scene.geometry import path_points
from supervisor.record.scene.history import FleetHistory

log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)
PATH_SPACING = 0.5  # m between a path's points
PATH_POINTS = 4000  # at most, per vehicle


def desired_paths(h: FleetHistory) -> dict[int, NDArray[np.float64]]:
    """vehicle -> its path's points (n, 3); empty if the meta's scenario does not validate (a log of an older
    cpf whose scenario format has changed): the scene is then drawn without paths."""
    if h.meta is None:
        return {}
    try:
        scenario = Scenario.model_validate(h.meta.scenario)
    except ValueError as exc:  # pydantic's ValidationError is one
        log.info("the log's scenario does not validate (%s): no desired paths in the scene", exc)
        return {}
    gammas: dict[int, list[float]] = {}
    for snapshots in h.states.values():
        for vid, snap in snapshots.items():
            if np.isfinite(snap.gamma):
                gammas.setdefault(vid, []).append(snap.gamma)
    specs = {v.id: v.path for v in scenario.vehicles}
    return {vid: path_points(build_path(specs[vid]), min(g), max(g), PATH_SPACING, PATH_POINTS)
            for vid, g in sorted(gammas.items()) if vid in specs}  # fmt: skip
