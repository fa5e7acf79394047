"""Vehicle parameters of the model of eqs. (1)-(2), and named presets.

All matrices of the paper's model are diagonal here: M = M_RB + M_A, J = J_RB + J_A, damping
D_v(v) = diag(lin + quad |v|), D_omega(omega) likewise. Units: kg, kg m^2, N s/m, N s^2/m^2, N m s, N m s^2, N, m.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

GRAVITY = 9.81  # m/s^2


@dataclass(frozen=True, slots=True)
class VehicleParams:
    """Rigid body + hydrodynamics + actuator limits of one underactuated AUV (body axes x fwd, y port, z up)."""

    mass: tuple[float, float, float]  # diagonal of M (rigid body + added mass), kg
    inertia: tuple[float, float, float]  # diagonal of J (rigid body + added inertia), kg m^2
    linear_damping: tuple[float, float, float]  # X_v1, Y_v2, Z_v3, N s/m
    quadratic_damping: tuple[float, float, float]  # X_|v1|v1, ..., N s^2/m^2
    angular_linear_damping: tuple[float, float, float]  # K_w1, M_w2, N_w3, N m s
    angular_quadratic_damping: tuple[float, float, float]  # N m s^2
    weight: float  # W = m g, N
    buoyancy: float  # B = rho g volume, N
    center_of_buoyancy: tuple[float, float, float]  # r_B relative to the centre of mass, body axes, m
    max_surge_force: float  # |tau_u| limit, N
    max_torque: float  # |tau_q|, |tau_r| limit, N m


def _remus100() -> VehicleParams:
    """REMUS 100: masses, added masses and drag as in Fossen's PythonVehicleSimulator (remus100.py), drag
    coefficients of Prestero (2001); roll damping chosen for a damping ratio of about 0.3 (not published)."""
    rigid_mass = 31.03
    weight = rigid_mass * GRAVITY
    return VehicleParams(
        mass=(rigid_mass + 0.839, rigid_mass + 29.44, rigid_mass + 29.44),
        inertia=(0.112 + 0.0336, 4.028 + 3.426, 4.028 + 3.426),
        linear_damping=(31.87 / 20.0, 60.47 / 20.0, 60.47 / 20.0),
        quadratic_damping=(6.11, 131.0, 131.0),
        angular_linear_damping=(0.56, 7.454 / 5.0, 7.454 / 5.0),
        angular_quadratic_damping=(0.0, 9.4, 9.4),
        weight=weight,
        buoyancy=weight + 3.3,  # slightly buoyant: W - B = -3.3 N (Prestero)
        center_of_buoyancy=(0.0, 0.0, 0.0196),  # CG 1.96 cm below CB: roll and pitch statically stable
        max_surge_force=60.0,
        max_torque=20.0,
    )


PRESETS: dict[str, VehicleParams] = {"remus100": _remus100()}


def preset(name: str, **overrides: object) -> VehicleParams:
    """A named preset with some fields replaced (the scenario file's overrides)."""
    return replace(PRESETS[name], **overrides)  # type: ignore[arg-type]
