"""Model mismatch: a plant's parameters drawn around the controller's nominal ones, reproducibly.

Each coefficient is multiplied by (1 + spread e), e uniform in [-1, 1], one draw per coefficient (each diagonal entry
its own), one set per vehicle. The draws come from a generator seeded by (scenario seed, vehicle id) alone, in a
fixed order over every coefficient whether it is perturbed or not, so a vehicle gets the same plant in every engine,
in every hosting, after a restart, and when the spread of another group changes.

Restoring terms: the buoyancy B (and with it the righting moment B r_B) and the net weight W - B each get their own
factor; W follows as B + (W - B). Perturbing W and B on their own would turn a +-20 % spread on 300 N into a net
weight of up to +-120 N, a vehicle no thruster of its size could hold. The centre of buoyancy's components get
theirs (a zero stays zero). The lift (vehicles.params: Y_uv, Y_ur, N_uv, N_ur) gets one factor per coefficient; its
draws come after every other group's, so a plant drawn before the lift was added is drawn the same. Actuator limits
are not perturbed: they are the controller's to know.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from vehicles.params import LIFT_FIELDS, VehicleParams

# The groups a spread may be given for, in the order their factors are drawn (3 each unless scalar).
GROUPS = (
    "mass", "inertia", "linear_damping", "quadratic_damping", "angular_linear_damping", "angular_quadratic_damping",
    "buoyancy", "net_weight", "center_of_buoyancy", "lift",
)  # fmt: skip
_SIZE = {"buoyancy": 1, "net_weight": 1, "lift": len(LIFT_FIELDS)}  # coefficients per group (3 unless given)
_STREAM = 0x706C616E74  # "plant": keeps this stream apart from any other drawn from the same seed and vehicle


def factors(seed: int, vehicle_id: int) -> dict[str, tuple[float, ...]]:
    """e in [-1, 1] for every coefficient of every group, for this (seed, vehicle)."""
    rng = np.random.default_rng([seed, vehicle_id, _STREAM])
    # group i's draws start at 3 i (a scalar group leaves two unused), so adding a group at the end keeps the others'
    draws = rng.uniform(-1.0, 1.0, size=3 * (len(GROUPS) - 1) + _SIZE[GROUPS[-1]])
    return {g: tuple(float(e) for e in draws[3 * i : 3 * i + _SIZE.get(g, 3)]) for i, g in enumerate(GROUPS)}


def perturbed(nominal: VehicleParams, spread: Mapping[str, float], seed: int, vehicle_id: int) -> VehicleParams:
    """The plant of vehicle_id: nominal with each group's coefficients scaled by (1 + spread[group] e); a group
    absent from spread (or at 0) stays nominal."""
    e = factors(seed, vehicle_id)

    def scaled(group: str, values: tuple[float, ...]) -> tuple[float, ...]:
        s = spread.get(group, 0.0)
        return tuple(v * (1.0 + s * f) for v, f in zip(values, e[group], strict=False))

    def vec(group: str) -> tuple[float, float, float]:
        a, b, c = scaled(group, getattr(nominal, group))
        return a, b, c

    buoyancy = scaled("buoyancy", (nominal.buoyancy,))[0]
    net = scaled("net_weight", (nominal.weight - nominal.buoyancy,))[0]
    lift = scaled("lift", tuple(getattr(nominal, name) for name in LIFT_FIELDS))
    return replace(
        nominal,
        **dict(zip(LIFT_FIELDS, lift, strict=True)),
        mass=vec("mass"),
        inertia=vec("inertia"),
        linear_damping=vec("linear_damping"),
        quadratic_damping=vec("quadratic_damping"),
        angular_linear_damping=vec("angular_linear_damping"),
        angular_quadratic_damping=vec("angular_quadratic_damping"),
        center_of_buoyancy=vec("center_of_buoyancy"),
        buoyancy=buoyancy,
        weight=buoyancy + net,
    )
