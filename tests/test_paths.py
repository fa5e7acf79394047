"""Tests for vehicles.paths: derivatives against finite differences, geometry, closest_gamma, input checks."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from numpy.typing import NDArray

from vehicles.nearest import closest_gamma
from vehicles.paths import Circle, Helix, Lawnmower, Line, Path

# --- cases ------------------------------------------------------------------------------------------------
# Each smooth case: (path, gammas to test at, FD step in gamma, atol on dp, atol on d2p).
# Steps are a small fraction of the path's own gamma scale; tolerances sit well above the FD truncation
# and round-off errors for that step.

PAPER_PHASE = -3.0 * math.pi / 4.0

SMOOTH_CASES: list[tuple[Path, NDArray[np.float64], float, float, float]] = [
    (Helix(20.0, 0.05, 400.0, PAPER_PHASE), np.linspace(-500.0, 1500.0, 41), 1e-2, 1e-9, 1e-9),
    (Helix(20.0, 0.05, -400.0, 0.3, (10.0, -5.0, -30.0)), np.linspace(-500.0, 1500.0, 41), 1e-2, 1e-9, 1e-9),
    (Helix(3.0, -0.7, 12.5, 2.0, (-1.0, 2.0, 3.0)), np.linspace(-20.0, 40.0, 61), 1e-3, 1e-8, 1e-6),
    (Helix(50.0, 0.0, -2.0 * math.pi, 0.0), np.linspace(-10.0, 10.0, 41), 1e-4, 1e-6, 1e-4),
    (Circle(30.0, 600.0, 0.5), np.linspace(-700.0, 700.0, 41), 1e-2, 1e-9, 1e-9),
    (Circle(8.0, -25.0, -1.0, (4.0, 5.0, -12.0)), np.linspace(-50.0, 50.0, 41), 1e-3, 1e-8, 1e-6),
    (Line((0.0, 0.0, -5.0), (1.0, 0.0, 0.0)), np.linspace(-100.0, 100.0, 21), 1e-3, 1e-8, 1e-6),
    (Line((3.0, -2.0, 1.0), (0.3, -1.2, 0.05)), np.linspace(-100.0, 100.0, 21), 1e-3, 1e-8, 1e-6),
]

LAWNMOWERS: list[Lawnmower] = [
    Lawnmower((0.0, 0.0, -10.0), 100.0, 10.0, 4),
    Lawnmower((5.0, -3.0, -20.0), 50.0, 8.0, 3, heading=0.7, scale=2.5),
    Lawnmower((-40.0, 12.0, -5.0), 30.0, 4.0, 5, heading=-2.0, scale=0.3),
    Lawnmower((1.0, 1.0, 0.0), 20.0, 6.0, 2, heading=math.pi),
    Lawnmower((0.0, 0.0, -1.0), 10.0, 2.0, 1, heading=1.0, scale=4.0),
]

ALL_PATHS: list[Path] = [*(case[0] for case in SMOOTH_CASES), *LAWNMOWERS]


def _unit(m: Lawnmower) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(u, n): first leg direction and its left normal, horizontal unit vectors."""
    u = np.array([math.cos(m.heading), math.sin(m.heading), 0.0])
    n = np.array([-math.sin(m.heading), math.cos(m.heading), 0.0])
    return u, n


def _leg_gammas(m: Lawnmower, k: int) -> tuple[float, float]:
    """(gamma at start, gamma at end) of leg k, from the documented geometry, not from internals."""
    period = m.leg_length + math.pi * m.spacing / 2.0
    return k * period / m.scale, (k * period + m.leg_length) / m.scale


def _joins(m: Lawnmower) -> list[float]:
    """gammas of every leg/turn join."""
    out: list[float] = []
    for k in range(m.legs - 1):
        # Leg k ends where turn k starts; turn k ends where leg k + 1 starts.
        out += [_leg_gammas(m, k)[1], _leg_gammas(m, k + 1)[0]]
    return out


def _gammas(m: Lawnmower, n: int = 400) -> NDArray[np.float64]:
    """Gammas covering the pattern plus extrapolation on both sides."""
    end = m.length / m.scale
    return np.linspace(-0.2 * end, 1.2 * end, n)


def _fd(path: Path, g: float, h: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Central finite differences (first, second) of the position at g with step h."""
    pm, p0, pp = path.evaluate(g - h)[0], path.evaluate(g)[0], path.evaluate(g + h)[0]
    return (pp - pm) / (2.0 * h), (pp - 2.0 * p0 + pm) / (h * h)


# --- derivatives ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("path", "gammas", "h", "atol1", "atol2"), SMOOTH_CASES, ids=repr)
def test_smooth_derivatives_match_finite_differences(
    path: Path, gammas: NDArray[np.float64], h: float, atol1: float, atol2: float
) -> None:
    for g in gammas:
        _, dp, d2p = path.evaluate(float(g))
        fd1, fd2 = _fd(path, float(g), h)
        np.testing.assert_allclose(dp, fd1, rtol=1e-7, atol=atol1, err_msg=f"dp at gamma={g}")
        np.testing.assert_allclose(d2p, fd2, rtol=1e-5, atol=atol2, err_msg=f"d2p at gamma={g}")


@pytest.mark.parametrize("path", ALL_PATHS, ids=repr)
def test_evaluate_returns_three_float64_vectors(path: Path) -> None:
    for value in path.evaluate(0.37):
        assert value.shape == (3,)
        assert value.dtype == np.float64


@pytest.mark.parametrize("m", LAWNMOWERS, ids=repr)
def test_lawnmower_first_derivative_matches_fd_everywhere(m: Lawnmower) -> None:
    # Includes the joins themselves and points within the step of them: the path is C1, so the central
    # difference still converges there, with error <= step * jump in d2p = h_s * scale / r.
    h_s = 1e-5  # step in arc length [m]
    h = h_s / m.scale
    gammas = np.concatenate([_gammas(m), np.array(_joins(m)), np.array(_joins(m)) + 0.3 * h])
    for g in gammas:
        fd1, _ = _fd(m, float(g), h)
        np.testing.assert_allclose(m.evaluate(float(g))[1], fd1, atol=1e-4 * m.scale, err_msg=f"gamma={g}")


@pytest.mark.parametrize("m", LAWNMOWERS, ids=repr)
def test_lawnmower_second_derivative_matches_fd_away_from_joins(m: Lawnmower) -> None:
    h_s = 1e-3  # step in arc length [m]
    h = h_s / m.scale
    joins = np.array(_joins(m) or [math.inf])
    gammas = _gammas(m)
    gammas = gammas[np.min(np.abs(gammas[:, None] - joins[None, :]), axis=1) > 2.0 * h]
    assert gammas.size > 300
    for g in gammas:
        _, fd2 = _fd(m, float(g), h)
        # Round-off of the second difference ~ 4 eps |p| / h_s^2 in arc-length units.
        np.testing.assert_allclose(m.evaluate(float(g))[2], fd2, atol=1e-6 * m.scale**2, err_msg=f"gamma={g}")


@pytest.mark.parametrize("m", LAWNMOWERS, ids=repr)
def test_lawnmower_is_c1_across_joins(m: Lawnmower) -> None:
    eps = 1e-9
    for gj in _joins(m):
        p_before, dp_before, _ = m.evaluate(gj - eps)
        p_at, dp_at, _ = m.evaluate(gj)
        p_after, dp_after, _ = m.evaluate(gj + eps)
        np.testing.assert_allclose(p_before, p_at, atol=1e-6, err_msg=f"position at join {gj}")
        np.testing.assert_allclose(p_after, p_at, atol=1e-6, err_msg=f"position at join {gj}")
        np.testing.assert_allclose(dp_before, dp_at, atol=1e-6 * m.scale, err_msg=f"tangent at join {gj}")
        np.testing.assert_allclose(dp_after, dp_at, atol=1e-6 * m.scale, err_msg=f"tangent at join {gj}")


# --- helix ------------------------------------------------------------------------------------------------


def test_helix_matches_paper_formula_literally() -> None:
    c, d, T, phi = 20.0, 0.05, 400.0, PAPER_PHASE
    helix = Helix(radius=c, climb=d, period=T, phase=phi)
    for gamma in [0.0, 1.0, 57.3, 100.0, 250.0, -40.0, 1234.5]:
        expected = np.array(
            [
                c * np.cos(2 * np.pi * gamma / T + phi),
                c * np.sin(2 * np.pi * gamma / T + phi),
                d * gamma,
            ]
        )
        np.testing.assert_allclose(helix.evaluate(gamma)[0], expected, rtol=0, atol=1e-12)


def test_helix_center_offsets_and_negative_period_turns_clockwise() -> None:
    center = (10.0, -5.0, -30.0)
    ccw = Helix(20.0, 0.05, 400.0, 0.3)
    cw = Helix(20.0, 0.05, -400.0, 0.3, center)
    for gamma in [0.0, 33.0, 150.0]:
        p_ccw, p_cw = ccw.evaluate(gamma)[0], cw.evaluate(gamma)[0] - np.array(center)
        # Negative period mirrors the angle about the phase: same radius and height, opposite turn.
        np.testing.assert_allclose(np.hypot(p_cw[0], p_cw[1]), 20.0, atol=1e-12)
        np.testing.assert_allclose(p_cw[2], p_ccw[2], atol=1e-12)
    # z-component of (p - center) x dp: positive counter-clockwise, negative clockwise.
    for path, centre, sign in [(ccw, (0.0, 0.0, 0.0), 1.0), (cw, center, -1.0)]:
        p, dp, _ = path.evaluate(7.0)
        r = p - np.array(centre)
        assert sign * (r[0] * dp[1] - r[1] * dp[0]) > 0


def test_circle_is_flat_helix() -> None:
    circle = Circle(8.0, -25.0, -1.0, (4.0, 5.0, -12.0))
    helix = Helix(8.0, 0.0, -25.0, -1.0, (4.0, 5.0, -12.0))
    for gamma in np.linspace(-30.0, 30.0, 13):
        for a, b in zip(circle.evaluate(float(gamma)), helix.evaluate(float(gamma)), strict=True):
            np.testing.assert_allclose(a, b, rtol=0, atol=0)
        # and it is the circle: written out here, not through the Helix it delegates to
        angle = 2 * np.pi * gamma / -25.0 - 1.0
        expected = (4.0 + 8.0 * np.cos(angle), 5.0 + 8.0 * np.sin(angle), -12.0)
        np.testing.assert_allclose(circle.evaluate(float(gamma))[0], expected, atol=1e-12)


def test_line_is_start_plus_gamma_velocity() -> None:
    line = Line((3.0, -2.0, 1.0), (0.3, -1.2, 0.05))
    for gamma in [-7.0, 0.0, 2.5]:
        p, dp, d2p = line.evaluate(gamma)
        np.testing.assert_allclose(p, np.array([3.0, -2.0, 1.0]) + gamma * np.array([0.3, -1.2, 0.05]))
        np.testing.assert_allclose(dp, [0.3, -1.2, 0.05])
        np.testing.assert_allclose(d2p, [0.0, 0.0, 0.0], atol=0)


# --- lawnmower geometry -----------------------------------------------------------------------------------


@pytest.mark.parametrize("m", LAWNMOWERS, ids=repr)
def test_lawnmower_speed_is_scale_everywhere(m: Lawnmower) -> None:
    for g in np.concatenate([_gammas(m, 1000), np.array(_joins(m))]):
        p, dp, _ = m.evaluate(float(g))
        np.testing.assert_allclose(np.linalg.norm(dp), m.scale, rtol=1e-12)
        assert p[2] == m.origin[2]
        assert dp[2] == 0.0


@pytest.mark.parametrize("m", LAWNMOWERS, ids=repr)
def test_lawnmower_legs_are_parallel_and_spaced(m: Lawnmower) -> None:
    u, n = _unit(m)
    origin = np.array(m.origin)
    p0, dp0, _ = m.evaluate(0.0)
    np.testing.assert_allclose(p0, origin, atol=1e-12)
    np.testing.assert_allclose(dp0 / m.scale, u, atol=1e-12)
    for k in range(m.legs):
        start, end = _leg_gammas(m, k)
        direction = u if k % 2 == 0 else -u
        for g in np.linspace(start, end, 7)[1:-1]:
            p, dp, d2p = m.evaluate(float(g))
            rel = p - origin
            # Every point of leg k is k * spacing to the left of the first leg, along u within [0, L].
            np.testing.assert_allclose(rel @ n, k * m.spacing, atol=1e-9)
            assert -1e-9 <= rel @ u <= m.leg_length + 1e-9
            np.testing.assert_allclose(dp / m.scale, direction, atol=1e-12)
            np.testing.assert_allclose(d2p, np.zeros(3), atol=0)
        # Leg length: start and end points are leg_length apart along the leg direction.
        np.testing.assert_allclose(m.evaluate(end)[0] - m.evaluate(start)[0], m.leg_length * direction, atol=1e-9)


@pytest.mark.parametrize("m", [m for m in LAWNMOWERS if m.legs > 1], ids=repr)
def test_lawnmower_turns_join_consecutive_legs(m: Lawnmower) -> None:
    u, n = _unit(m)
    r = m.spacing / 2.0
    for k in range(m.legs - 1):
        _, end_k = _leg_gammas(m, k)
        start_next, _ = _leg_gammas(m, k + 1)
        p_end = m.evaluate(end_k)[0]
        p_next = m.evaluate(start_next)[0]
        # The next leg starts one spacing to the left of where this one ends.
        np.testing.assert_allclose(p_next - p_end, m.spacing * n, atol=1e-9)
        # The turn is a semicircle of radius r about the midpoint, bulging outward past the leg end.
        centre = p_end + r * n
        direction = u if k % 2 == 0 else -u
        for g in np.linspace(end_k, start_next, 9):
            p, _, d2p = m.evaluate(float(g))
            np.testing.assert_allclose(np.linalg.norm(p - centre), r, rtol=1e-12)
            assert (p - centre) @ direction >= -1e-9
            if end_k < g < start_next:
                # Centripetal: towards the centre with magnitude scale^2 / r.
                np.testing.assert_allclose(d2p, -(m.scale**2 / r**2) * (p - centre), atol=1e-9)
        p_mid, _, d2p_mid = m.evaluate(0.5 * (end_k + start_next))
        np.testing.assert_allclose(p_mid, centre + r * direction, atol=1e-9)
        np.testing.assert_allclose(d2p_mid, -(m.scale**2 / r) * direction, atol=1e-9)


@pytest.mark.parametrize("m", LAWNMOWERS, ids=repr)
def test_lawnmower_extrapolates_straight_beyond_both_ends(m: Lawnmower) -> None:
    u, _ = _unit(m)
    origin = np.array(m.origin)
    for g in [-0.001, -1.0, -37.5]:
        p, dp, d2p = m.evaluate(g)
        np.testing.assert_allclose(p, origin + g * m.scale * u, atol=1e-9)
        np.testing.assert_allclose(dp, m.scale * u, atol=1e-12)
        np.testing.assert_allclose(d2p, np.zeros(3), atol=0)
    g_end = m.length / m.scale
    p_end = m.evaluate(g_end)[0]
    last = u if (m.legs - 1) % 2 == 0 else -u
    _, last_end = _leg_gammas(m, m.legs - 1)
    np.testing.assert_allclose(g_end, last_end, rtol=1e-14)
    for extra in [0.001, 1.0, 37.5]:
        p, dp, d2p = m.evaluate(g_end + extra)
        np.testing.assert_allclose(p, p_end + extra * m.scale * last, atol=1e-9)
        np.testing.assert_allclose(dp, m.scale * last, atol=1e-12)
        np.testing.assert_allclose(d2p, np.zeros(3), atol=0)


# --- positions / closest_gamma ----------------------------------------------------------------------------


@pytest.mark.parametrize("path", ALL_PATHS, ids=repr)
def test_positions_equals_stacked_evaluate(path: Path) -> None:
    if isinstance(path, Lawnmower):
        gammas = np.concatenate([_gammas(path, 500), np.array(_joins(path))])
    else:
        gammas = np.linspace(-300.0, 300.0, 500)
    expected = np.stack([path.evaluate(float(g))[0] for g in gammas])
    got = path.positions(gammas)
    assert got.shape == (gammas.size, 3)
    assert got.dtype == np.float64
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)


def test_positions_rejects_2d_input() -> None:
    with pytest.raises(ValueError, match="gammas must be 1-D"):
        Line((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)).positions(np.zeros((2, 2)))


def _off_path_point(path: Path, gamma: float, offset: float) -> NDArray[np.float64]:
    """A point `offset` metres from p_d(gamma), perpendicular to the tangent, with gamma its nearest."""
    p, dp, _ = path.evaluate(gamma)
    if isinstance(path, Helix | Circle):
        # Radially outward from the axis: perpendicular to the tangent and away from the centre of curvature.
        radial = p - np.array(path.center)
        radial[2] = 0.0
        return p + offset * radial / np.linalg.norm(radial)
    # Any perpendicular direction works for straight parts; vertical is perpendicular for horizontal paths.
    side = np.cross(dp, [0.0, 0.0, 1.0])
    if np.linalg.norm(side) < 1e-12:
        side = np.cross(dp, [1.0, 0.0, 0.0])
    return p + offset * side / np.linalg.norm(side)


@pytest.mark.parametrize(
    ("path", "gamma", "lo", "hi"),
    [
        (Helix(20.0, 0.05, 400.0, PAPER_PHASE), 123.456789, 0.0, 1000.0),
        (Helix(20.0, 0.05, -400.0, 0.3, (10.0, -5.0, -30.0)), 987.654321, 0.0, 1000.0),
        (Circle(30.0, 600.0, 0.5), 77.7777, 0.0, 590.0),
        (Line((3.0, -2.0, 1.0), (0.3, -1.2, 0.05)), -12.3456789, -50.0, 50.0),
        (Lawnmower((0.0, 0.0, -10.0), 100.0, 10.0, 4), 108.123456, -10.0, 500.0),
        (Lawnmower((5.0, -3.0, -20.0), 50.0, 8.0, 3, heading=0.7, scale=2.5), 31.234567, 0.0, 60.0),
    ],
    ids=repr,
)
def test_closest_gamma_recovers_known_gamma(path: Path, gamma: float, lo: float, hi: float) -> None:
    for offset in [0.0, 0.5, 2.0]:
        point = _off_path_point(path, gamma, offset)
        # 1e-9 is far tighter than start-up needs, but checks the Newton polish past Brent's sqrt(eps).
        np.testing.assert_allclose(closest_gamma(path, point, lo, hi), gamma, rtol=0, atol=1e-9)


def test_closest_gamma_vertical_offset_on_lawnmower_turn() -> None:
    m = Lawnmower((0.0, 0.0, -10.0), 100.0, 10.0, 4)
    gamma = 100.0 + 0.3 * math.pi * 5.0  # inside the first turn
    point = m.evaluate(gamma)[0] + np.array([0.0, 0.0, 2.0])
    np.testing.assert_allclose(closest_gamma(m, point, -10.0, 500.0), gamma, rtol=0, atol=1e-9)


def test_closest_gamma_clamps_to_interval() -> None:
    line = Line((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    assert closest_gamma(line, np.array([20.0, 1.0, 0.0]), 0.0, 10.0) == 10.0
    assert closest_gamma(line, np.array([-5.0, 1.0, 0.0]), 0.0, 10.0) == 0.0
    assert closest_gamma(line, np.array([5.0, 1.0, 0.0]), 3.0, 3.0) == 3.0


def test_closest_gamma_rejects_bad_arguments() -> None:
    line = Line((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="lo <= hi"):
        closest_gamma(line, np.zeros(3), 1.0, 0.0)
    with pytest.raises(ValueError, match="samples must be >= 2"):
        closest_gamma(line, np.zeros(3), 0.0, 1.0, samples=1)
    with pytest.raises(ValueError, match="point must have shape"):
        closest_gamma(line, np.zeros(2), 0.0, 1.0)


# --- constructors -----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("factory", "message"),
    [
        (lambda: Helix(-3.0, 0.05, 400.0, 0.0), "radius must be > 0, got -3.0"),
        (lambda: Helix(0.0, 0.05, 400.0, 0.0), "radius must be > 0, got 0.0"),
        (lambda: Helix(float("nan"), 0.05, 400.0, 0.0), "radius must be > 0, got nan"),
        (lambda: Helix(20.0, 0.05, 0.0, 0.0), "period must be != 0, got 0.0"),
        (lambda: Helix(20.0, float("inf"), 400.0, 0.0), "climb must be finite, got inf"),
        (lambda: Helix(20.0, 0.05, 400.0, 0.0, (0.0, 0.0)), "center must have 3 components"),  # type: ignore[arg-type]
        (lambda: Circle(-1.0, 10.0, 0.0), "radius must be > 0, got -1.0"),
        (lambda: Circle(5.0, 0.0, 0.0), "period must be != 0, got 0.0"),
        (lambda: Line((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)), "velocity must be at least 1e-06 m per unit of gamma"),
        # a new user's: non-zero, but its square is 0 (a ZeroDivisionError in the run that cpf validate passed)
        (lambda: Line((0.0, 0.0, 0.0), (1e-300, 0.0, 0.0)), "velocity must be at least 1e-06 m per unit of gamma"),
        (lambda: Line((0.0, float("nan"), 0.0), (1.0, 0.0, 0.0)), "start must be finite"),
        (lambda: Lawnmower((0.0, 0.0, 0.0), 0.0, 10.0, 3), "leg_length must be > 0, got 0.0"),
        (lambda: Lawnmower((0.0, 0.0, 0.0), 100.0, -1.0, 3), "spacing must be > 0, got -1.0"),
        (lambda: Lawnmower((0.0, 0.0, 0.0), 100.0, 10.0, 0), "legs must be an int >= 1, got 0"),
        (lambda: Lawnmower((0.0, 0.0, 0.0), 100.0, 10.0, 2.5), "legs must be an int >= 1, got 2.5"),  # type: ignore[arg-type]
        (lambda: Lawnmower((0.0, 0.0, 0.0), 100.0, 10.0, 3, scale=0.0), "scale must be > 0, got 0.0"),
        (lambda: Lawnmower((0.0, 0.0, 0.0), 100.0, 10.0, 3, heading=math.nan), "heading must be finite"),
    ],
)
def test_constructors_reject_bad_parameters(factory: object, message: str) -> None:
    assert callable(factory)
    with pytest.raises(ValueError, match=re.escape(message)):
        factory()


def test_paths_are_frozen_hashable_and_normalised() -> None:
    helix = Helix(20, 0, 400, 0, (1, 2, 3))  # ints are accepted and stored as floats
    assert helix.radius == 20.0 and isinstance(helix.radius, float)
    assert helix.center == (1.0, 2.0, 3.0) and all(isinstance(v, float) for v in helix.center)
    assert helix.evaluate(0)[0].dtype == np.float64
    with pytest.raises(dataclasses.FrozenInstanceError):
        helix.radius = 3.0  # type: ignore[misc]
    assert hash(helix) == hash(Helix(20.0, 0.0, 400.0, 0.0, (1.0, 2.0, 3.0)))
    m = Lawnmower((0, 0, 0), 10, 2, 3)
    assert m == Lawnmower((0.0, 0.0, 0.0), 10.0, 2.0, 3)
    assert isinstance(m, Path) and isinstance(helix, Path)
