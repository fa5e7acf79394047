"""The hull's and fins' lift of the remus100 preset (vehicles.dynamics.lift_terms, vehicles.params.LIFT): its
numbers against their source, its signs against the physics, and what it changes: the fins fly the vehicle."""

from __future__ import annotations

import pytest

from supervisor.config.fleet import vehicle_config
from supervisor.config.scenario import parse_scenario
from tests.fly_a_line import fly_a_line
from vehicles.actuators import remus100
from vehicles.dynamics import lift_terms, planar_drift, spatial_drift
from vehicles.params import PRESETS, without_lift

REMUS = PRESETS["remus100"]
FIN_LIFT_FORCE = 9.64  # Prestero's Y_uu_delta_r = -Z_uu_delta_s, kg/(m rad): the fins' lift per (m/s)^2 and rad
FIN_MOMENT = 6.15  # Prestero's -N_uu_delta_r = -M_uu_delta_s, kg/rad: that lift times the fins' lever |x_fin|


def test_the_lift_is_prestero_combined_minus_the_added_mass_part_and_agrees_with_the_fins_geometry():
    """The preset's lift is Prestero's combined coefficients less the Munk part the masses carry; what only the fins
    can give must then agree with the fins' own coefficients: a fin at x_f meeting the flow r x_f / u gives
    Y_ur = -c x_f = M_uu_delta (6.15) and N_ur = -c x_f^2 = -M_uu_delta^2 / Y_uu_delta (-3.92), to 0.5 %."""
    assert (REMUS.lift_uv, REMUS.lift_moment_uv) == pytest.approx((-28.6, -24.0 + 35.5 - 0.93))
    assert REMUS.lift_ur == pytest.approx(FIN_MOMENT, rel=5e-3)
    assert REMUS.lift_moment_ur == pytest.approx(-(FIN_MOMENT**2) / FIN_LIFT_FORCE, rel=5e-3)


def test_the_lift_turns_the_nose_into_the_flow_damps_the_rates_and_vanishes_at_rest():
    """Weathercock stability: sliding to port (v > 0) the lift pushes to starboard and yaws the nose to port; a yaw
    rate is damped; at rest there is no lift."""
    y, _, _, n = lift_terms(1.0, 0.1, 0.0, 0.0, 0.0, REMUS)
    assert y < 0 < n
    assert lift_terms(1.0, 0.0, 0.0, 0.0, 0.2, REMUS)[3] < 0
    assert lift_terms(0.0, 0.3, -0.2, 0.1, 0.4, REMUS) == (0.0, 0.0, 0.0, 0.0)


@pytest.mark.parametrize(("v", "r"), [(0.1, 0.0), (0.0, 0.2), (-0.07, 0.3)])
def test_the_vertical_plane_mirrors_the_horizontal_one_as_the_hull_is_axisymmetric(v, r):
    """Rolled 90 deg about its axis the vehicle's sway v and yaw rate r become heave w = v and pitch rate q = -r, and
    the forces follow: Z = Y, M = -N. A sign wrong in one plane fails this."""
    y, _, _, n = lift_terms(1.3, v, 0.0, 0.0, r, REMUS)
    _, z, m, _ = lift_terms(1.3, 0.0, v, -r, 0.0, REMUS)
    assert (z, m) == pytest.approx((y, -n), rel=1e-15)


def _straight(u: float, v: float = 0.0, w: float = 0.0, q: float = 0.0, r: float = 0.0) -> list[float]:
    return [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, u, v, w, 0.0, q, r]


def test_the_drift_adds_the_lift_in_both_models():
    """The spatial and planar drifts of the preset differ from the lift-free ones by the lift, divided by the
    masses and inertias."""
    bare = without_lift(REMUS)
    s = _straight(1.2, 0.05, -0.03, 0.02, 0.1)
    y, z, m, n = lift_terms(1.2, 0.05, -0.03, 0.02, 0.1, REMUS)
    (_, v1, w1), (_, q1, r1) = spatial_drift(s, REMUS)
    (_, v0, w0), (_, q0, r0) = spatial_drift(s, bare)
    assert (v1 - v0, w1 - w0) == pytest.approx((y / REMUS.mass[1], z / REMUS.mass[2]), rel=1e-12)
    assert (q1 - q0, r1 - r0) == pytest.approx((m / REMUS.inertia[1], n / REMUS.inertia[2]), rel=1e-12)
    flat = _straight(1.2, 0.05, 0.0, 0.0, 0.1)
    (_, pv1, _), (_, _, pr1) = planar_drift(flat, REMUS)
    (_, pv0, _), (_, _, pr0) = planar_drift(flat, bare)
    y, _, _, n = lift_terms(1.2, 0.05, 0.0, 0.0, 0.1, REMUS)
    assert (pv1 - pv0, pr1 - pr0) == pytest.approx((y / REMUS.mass[1], n / REMUS.inertia[2]), rel=1e-12)


def test_with_its_lift_the_remus_flies_a_line_on_its_fins_and_without_it_cannot():
    """At 1 m/s, the remus100 preset (buoyant, with lift) on a REMUS 100's fins under the default controller holds a
    line inside the 1.2 m tube after 100 s; the same vehicle without lift (remus100_neutral is the paper's model)
    leaves it: the Munk moment, unopposed, is more than its fins hold. Holding depth, buoyant, takes the fins'
    pitch moment beyond the line-of-sight law's margin at this speed: its pitch rate keeps a share of what is left
    (vehicles.line_of_sight), so the line is held to 10 cm (none left: 0.40 m off at 200 s)."""
    with_lift = fly_a_line(1.0, 200.0, preset="remus100")
    without = fly_a_line(1.0, 200.0, preset="remus100_neutral")
    assert max(with_lift[1000:]) < 0.1
    assert max(without[1000:]) > 10.0


def test_the_preset_comes_with_its_fins():
    assert vehicle_config(parse_scenario(_SMALL, "fins.toml"), 1).actuators == remus100(REMUS.max_surge_force)


_SMALL = """
[scenario]
name = "fins"
duration = 1.0
step = 0.1
[graph]
edges = [[1, 2]]
[[vehicles]]
id = 1
position = [0.0, 0.0, -10.0]
path = { type = "line", start = [0.0, 0.0, -10.0], velocity = [1.0, 0.0, 0.0] }
[[vehicles]]
id = 2
position = [0.0, 50.0, -10.0]
path = { type = "line", start = [0.0, 50.0, -10.0], velocity = [1.0, 0.0, 0.0] }
"""
