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
    # Hull and fin lift (vehicles.dynamics.lift_terms; 0: the paper's model, which has none). Prestero's notation for
    # the axisymmetric hull, the lift part only (the added-mass, Munk, part comes from the masses above):
    lift_uv: float = 0.0  # Y_uv = Z_uw: sway (heave) force per u v (u w), kg/m
    lift_ur: float = 0.0  # Y_ur = -Z_uq: sway (heave) force per u r (u q), kg/rad
    lift_moment_uv: float = 0.0  # N_uv = -M_uw: yaw (pitch) moment per u v (u w), kg
    lift_moment_ur: float = 0.0  # N_ur = M_uq: yaw (pitch) moment per u r (u q), kg m/rad


LIFT_FIELDS = ("lift_uv", "lift_ur", "lift_moment_uv", "lift_moment_ur")  # VehicleParams' lift coefficients


# REMUS 100 numbers and where they come from. Sources: T. Prestero, "Verification of a six-degree of freedom
# simulation model for the REMUS autonomous underwater vehicle", MIT/WHOI MS thesis, 2001 (its coefficient tables as
# transcribed in public code: X_u|u| = -1.62 kg/m, Z_w|w| = -131 kg/m, M_q|q| = -188 kg m^2, N_r|r| = -94 kg m^2,
# z_g = 0.0196 m); T. I. Fossen, PythonVehicleSimulator, vehicles/remus100.py (rigid-body mass and inertia, added
# mass, linear damping at rest, top speed 2.5 m/s); B = W + 0.75 lbf (3.3 N) in the REMUS trim model of R. Hall and
# S. Anstee (DSTO, 2011, coefficients by D. Sgarioto).
_RIGID_MASS = 31.03  # kg (Fossen)
_ADDED_MASS = (0.839, 29.44, 29.44)  # kg (Fossen)
_INERTIA = (0.112 + 0.0336, 4.028 + 3.426, 4.028 + 3.426)  # rigid body + added, kg m^2 (Fossen)
_LINEAR_DAMPING = (31.87 / 20.0, 60.47 / 20.0, 60.47 / 20.0)  # M_ii / 20 (Fossen, at rest)
_ANGULAR_LINEAR_DAMPING = (0.56, 7.454 / 5.0, 7.454 / 5.0)  # roll: chosen (damping ratio ~0.3); J_ii / 5 (Fossen)
_TOP_SPEED = 2.5  # m/s (Fossen, remus100.py: 2.5 m/s at 1525 rpm)
_BUOYANT = 3.3  # N, B - W (Hall and Anstee: B = W + 0.75 lbf)
_CB_ABOVE_CG = 0.0196  # m (Prestero's z_g)

# Hull and fin lift, from Prestero's combined coefficients (his Table 4.x, as transcribed with his added masses in
# D. Sgarioto's REMUS coefficient file for Hall and Anstee, DSTO 2011): Y_uv = -28.6 kg/m, Y_ur = 5.22 kg/rad,
# N_uv = -24.0 kg, N_ur = -2.0 kg m/rad. Each combines lift with an added-mass (Munk) part, which eqs. (1)-(2) already
# carry through the masses: Y_ur_a = X_udot, N_uv_a = Y_vdot - X_udot, N_ur_a = Y_rdot, with X_udot = -0.93 kg,
# Y_vdot = -35.5 kg, Y_rdot = 1.93 kg m. The lift is what is left.
_X_UDOT, _Y_VDOT, _Y_RDOT = -0.93, -35.5, 1.93
LIFT = {
    "lift_uv": -28.6,  # Y_uv: no added-mass part
    "lift_ur": 5.22 - _X_UDOT,  # 6.15
    "lift_moment_uv": -24.0 - (_Y_VDOT - _X_UDOT),  # 10.57
    "lift_moment_ur": -2.0 - _Y_RDOT,  # -3.93
}


def _remus100(buoyancy_excess: float = _BUOYANT, lift: bool = True) -> VehicleParams:
    """REMUS 100 with its drag to Prestero (2001): surge X_u|u| = 1.62 kg/m, sway and heave 131 kg/m (Prestero's
    Z_w|w|; his table gives Y_v|v| = 1310 for the same hull, taken as a misprint), pitch M_q|q| = 188 kg m^2, yaw
    N_r|r| = 94 kg m^2; masses, inertias, added masses and linear damping of Fossen's consistent set (the numbers in
    the comment above). Not sourced, chosen: roll damping (0.56 N m s, no quadratic term); the thrust limit, set so
    that full thrust holds the published 2.5 m/s top speed against this surge damping (about 14.1 N); the torque
    limit 20 N m. buoyancy_excess: B - W in N (3.3 N as published: slightly buoyant). lift: the hull's and fins' lift
    (LIFT, Prestero), which the paper's model leaves out; without it the fins cannot hold the vehicle straight
    (vehicles.actuators)."""
    weight = _RIGID_MASS * GRAVITY
    lin, quad = _LINEAR_DAMPING[0], 1.62
    return VehicleParams(
        mass=(_RIGID_MASS + _ADDED_MASS[0], _RIGID_MASS + _ADDED_MASS[1], _RIGID_MASS + _ADDED_MASS[2]),
        inertia=_INERTIA,
        linear_damping=_LINEAR_DAMPING,
        quadratic_damping=(quad, 131.0, 131.0),
        angular_linear_damping=_ANGULAR_LINEAR_DAMPING,
        angular_quadratic_damping=(0.0, 188.0, 94.0),
        weight=weight,
        buoyancy=weight + buoyancy_excess,
        center_of_buoyancy=(0.0, 0.0, _CB_ABOVE_CG),  # CG below CB: roll and pitch statically stable
        max_surge_force=lin * _TOP_SPEED + quad * _TOP_SPEED * _TOP_SPEED,
        max_torque=20.0,
        **(LIFT if lift else {}),
    )


def _remus100_neutral() -> VehicleParams:
    """REMUS 100 (as `remus100`) trimmed neutrally buoyant, B = W, in the paper's model: no lift (eqs. (1)-(2)).
    Sourced: everything `remus100` sources. Chosen: the trim (a REMUS is ballasted at sea to a small excess buoyancy,
    3.3 N in Hall and Anstee; zero is our choice, so that it flies a climbing helix at a small angle of attack). The
    stand-in for the paper's Sirene, whose coefficients are not public, with the paper's idealised inputs."""
    return _remus100(buoyancy_excess=0.0, lift=False)


def _remus100_legacy() -> VehicleParams:
    """The remus100 preset before its drag was corrected (cpf-cosim issue 16), kept so that runs made with it can be
    reproduced (tests/test_bit_identical.py runs its reference scenarios on it). Its surge (6.11 kg/m, Fossen's
    axial drag), pitch and yaw (9.4 kg m^2) drag are not Prestero's; thrust limit 60 N chosen."""
    weight = _RIGID_MASS * GRAVITY
    return VehicleParams(
        mass=(_RIGID_MASS + 0.839, _RIGID_MASS + 29.44, _RIGID_MASS + 29.44),
        inertia=(0.112 + 0.0336, 4.028 + 3.426, 4.028 + 3.426),
        linear_damping=(31.87 / 20.0, 60.47 / 20.0, 60.47 / 20.0),
        quadratic_damping=(6.11, 131.0, 131.0),
        angular_linear_damping=(0.56, 7.454 / 5.0, 7.454 / 5.0),
        angular_quadratic_damping=(0.0, 9.4, 9.4),
        weight=weight,
        buoyancy=weight + 3.3,
        center_of_buoyancy=(0.0, 0.0, 0.0196),
        max_surge_force=60.0,
        max_torque=20.0,
    )


PRESETS: dict[str, VehicleParams] = {
    "remus100": _remus100(),
    "remus100_neutral": _remus100_neutral(),
    "remus100_legacy": _remus100_legacy(),
}


def has_lift(params: VehicleParams) -> bool:
    """Whether the vehicle has hull or fin lift (the paper's model has none: its drift skips the terms)."""
    return bool(params.lift_uv or params.lift_ur or params.lift_moment_uv or params.lift_moment_ur)


def without_lift(params: VehicleParams) -> VehicleParams:
    """The same vehicle in the paper's model, eqs. (1)-(2): no hull or fin lift."""
    return replace(params, **dict.fromkeys(LIFT_FIELDS, 0.0))  # type: ignore[arg-type]


def preset(name: str, **overrides: object) -> VehicleParams:
    """A named preset with some fields replaced (the scenario file's overrides)."""
    return replace(PRESETS[name], **overrides)  # type: ignore[arg-type]
