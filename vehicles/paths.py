"""Spatial paths p_d(gamma) for coordinated path-following.

In path-following each vehicle tracks a geometric path p_d(gamma) in R^3 (inertial frame, metres, z up)
instead of a trajectory in time.  The scalar path parameter gamma is a state of the vehicle's controller:
the controller decides how fast gamma advances, and the fleet coordinates by agreeing on the gammas
(e.g. making them equal).  The controller needs the point p_d(gamma), the tangent dp_d/dgamma and the
curvature term d2p_d/dgamma2, so every path returns all three from ``evaluate``.

Units: positions in metres; gamma is dimensionless (its meaning depends on the path, e.g. arc length
divided by ``scale`` for the lawnmower), so dp_d/dgamma is in m per unit gamma and d2p_d/dgamma2 in m per
unit gamma squared.

``evaluate_floats`` runs four times per integration step per vehicle, so it is scalar float arithmetic returning
tuples of floats, with the trigonometry of ``numerics`` (the same bits on every CPU; numpy's and the C library's
``sin`` pick CPU-specific kernels); ``evaluate`` is the same as arrays, and ``positions`` the vectorised counterpart
for plotting only (numpy's kernels: its last bits may differ between machines).
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field
from typing import ClassVar, Protocol, TypeAlias, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from numerics import atan2, sincos
from vehicles.geometry import Float3

Vec3: TypeAlias = NDArray[np.float64]
"""A vector of shape (3,), float64."""

__all__ = ["Circle", "Helix", "Lawnmower", "Line", "Path", "Vec3"]


@runtime_checkable
class Path(Protocol):
    """A path p_d(gamma) in R^3 with its first two derivatives with respect to gamma."""

    def evaluate(self, gamma: float) -> tuple[Vec3, Vec3, Vec3]:
        """(p_d, dp_d/dgamma, d2p_d/dgamma2) at gamma, each shape (3,) float64."""
        ...

    def evaluate_floats(self, gamma: float) -> tuple[Float3, Float3, Float3]:
        """The same as 3-tuples of floats, for the controller's hot path."""
        ...

    def positions(self, gammas: NDArray[np.float64]) -> NDArray[np.float64]:
        """p_d at many gammas, shape (n, 3) -- for plotting; vectorised."""
        ...

    @property
    def gamma_period(self) -> float | None:
        """T > 0 if the path's horizontal course repeats every T of gamma (circle; a helix also climbs by
        climb * T per period), None if it never repeats (line, lawnmower)."""
        ...

    @property
    def straight_beyond(self) -> tuple[float, float] | None:
        """For a path that never repeats: (a, b), a <= b, such that it runs straight for gamma <= a and for
        gamma >= b (so its point nearest anything lies within reach of [a, b]); None for a periodic path."""
        ...


# --- input checks -----------------------------------------------------------------------------------------


def _set(obj: object, name: str, value: object) -> None:
    # Frozen dataclasses forbid normal assignment; __post_init__ normalises and caches through this.
    object.__setattr__(obj, name, value)


def _finite(name: str, value: float) -> float:
    """value as a Python float; ValueError naming the parameter if it is not finite."""
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


def _positive(name: str, value: float) -> float:
    """value as a Python float; ValueError naming the parameter unless finite and > 0."""
    v = float(value)
    # `not (v > 0)` also rejects NaN.
    if not (v > 0):
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return _finite(name, v)


def _vec3(name: str, value: tuple[float, float, float]) -> tuple[float, float, float]:
    """value as a 3-tuple of finite Python floats; ValueError naming the parameter otherwise."""
    if len(value) != 3:
        raise ValueError(f"{name} must have 3 components, got {value!r}")
    x, y, z = (float(v) for v in value)
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return x, y, z


def _arrays(vectors: tuple[Float3, Float3, Float3]) -> tuple[Vec3, Vec3, Vec3]:
    p, dp, d2p = vectors
    return np.array(p), np.array(dp), np.array(d2p)


def _gamma_array(gammas: ArrayLike) -> NDArray[np.float64]:
    g = np.atleast_1d(np.asarray(gammas, dtype=np.float64))
    if g.ndim != 1:
        raise ValueError(f"gammas must be 1-D, got shape {g.shape}")
    return g


# --- paths ------------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Helix:
    """p_d(gamma) = [c cos(2 pi gamma / T + phi), c sin(2 pi gamma / T + phi), d gamma] + center.

    radius c [m] > 0; climb d [m per unit gamma] (any sign, 0 gives a circle); period T [gamma per
    revolution] != 0 (negative turns clockwise seen from above); phase phi [rad]; center [m].
    """

    lanes: ClassVar[bool] = True  # evaluate_floats takes arrays of lanes (vehicles.lanes): its arithmetic

    radius: float
    climb: float
    period: float
    phase: float
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    # Angular rate 2 pi / T [rad per unit gamma], precomputed for the hot path.
    _omega: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # Stored as Python floats so evaluate() does plain float math and always returns float64.
        _set(self, "radius", _positive("radius", self.radius))
        _set(self, "climb", _finite("climb", self.climb))
        if self.period == 0:
            raise ValueError(f"period must be != 0, got {self.period!r}")
        _set(self, "period", _finite("period", self.period))
        _set(self, "phase", _finite("phase", self.phase))
        _set(self, "center", _vec3("center", self.center))
        _set(self, "_omega", 2.0 * math.pi / self.period)

    def evaluate(self, gamma: float) -> tuple[Vec3, Vec3, Vec3]:
        """(p_d [m], dp_d/dgamma [m/gamma], d2p_d/dgamma2 [m/gamma^2]) at gamma."""
        return _arrays(self.evaluate_floats(gamma))

    def evaluate_floats(self, gamma: float) -> tuple[Float3, Float3, Float3]:
        c, w = self.radius, self._omega
        a = w * gamma + self.phase
        sa, ca = sincos(a)
        cx, cy, cz = self.center
        cw2 = c * w * w
        return (
            (c * ca + cx, c * sa + cy, self.climb * gamma + cz),
            (-c * w * sa, c * w * ca, self.climb),
            (-cw2 * ca, -cw2 * sa, 0.0),
        )

    def positions(self, gammas: NDArray[np.float64]) -> NDArray[np.float64]:
        """p_d [m] at many gammas, shape (n, 3)."""
        g = _gamma_array(gammas)
        a = self._omega * g + self.phase
        out = np.empty((g.size, 3))
        out[:, 0] = self.radius * np.cos(a) + self.center[0]
        out[:, 1] = self.radius * np.sin(a) + self.center[1]
        out[:, 2] = self.climb * g + self.center[2]
        return out

    @property
    def gamma_period(self) -> float:
        """|period|: one revolution (the helix is then climb * |period| higher)."""
        return abs(self.period)

    @property
    def straight_beyond(self) -> None:
        return None


@dataclass(frozen=True, slots=True)
class Circle:
    """Horizontal circle at height center[2]: the Helix with climb 0.

    radius [m] > 0; period [gamma per revolution] != 0 (negative turns clockwise); phase [rad]; center [m].
    """

    lanes: ClassVar[bool] = True  # evaluate_floats takes arrays of lanes (vehicles.lanes): its arithmetic

    radius: float
    period: float
    phase: float
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    # Delegate so the formulas live in one place (Helix).
    _helix: Helix = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # Helix validates radius, period, phase and center with the same parameter names.
        helix = Helix(self.radius, 0.0, self.period, self.phase, self.center)
        for name in ("radius", "period", "phase", "center"):
            _set(self, name, getattr(helix, name))
        _set(self, "_helix", helix)

    def evaluate(self, gamma: float) -> tuple[Vec3, Vec3, Vec3]:
        """(p_d [m], dp_d/dgamma [m/gamma], d2p_d/dgamma2 [m/gamma^2]) at gamma."""
        return self._helix.evaluate(gamma)

    def evaluate_floats(self, gamma: float) -> tuple[Float3, Float3, Float3]:
        return self._helix.evaluate_floats(gamma)

    def positions(self, gammas: NDArray[np.float64]) -> NDArray[np.float64]:
        """p_d [m] at many gammas, shape (n, 3)."""
        return self._helix.positions(gammas)

    @property
    def gamma_period(self) -> float:
        """|period|: one revolution."""
        return abs(self.period)

    @property
    def straight_beyond(self) -> None:
        return None


# |velocity| of a line, m per unit of gamma, at least: the nearest-point search divides by its square (1e-300 gave 0)
MIN_LINE_SPEED = 1e-6


@dataclass(frozen=True, slots=True)
class Line:
    """Straight line p_d(gamma) = start + gamma * velocity.

    start [m]; velocity [m per unit gamma], any non-zero vector.
    """

    lanes: ClassVar[bool] = True  # evaluate_floats takes arrays of lanes (vehicles.lanes): its arithmetic

    start: tuple[float, float, float]
    velocity: tuple[float, float, float]

    def __post_init__(self) -> None:
        _set(self, "start", _vec3("start", self.start))
        _set(self, "velocity", _vec3("velocity", self.velocity))
        if not math.hypot(*self.velocity) >= MIN_LINE_SPEED:  # 1e-300 passed as non-zero; its square is 0
            raise ValueError(f"velocity must be at least {MIN_LINE_SPEED:g} m per unit of gamma, got {self.velocity!r}")

    def evaluate(self, gamma: float) -> tuple[Vec3, Vec3, Vec3]:
        """(p_d [m], dp_d/dgamma [m/gamma], d2p_d/dgamma2 = 0) at gamma."""
        return _arrays(self.evaluate_floats(gamma))

    def evaluate_floats(self, gamma: float) -> tuple[Float3, Float3, Float3]:
        (sx, sy, sz), (vx, vy, vz) = self.start, self.velocity
        return (sx + gamma * vx, sy + gamma * vy, sz + gamma * vz), (vx, vy, vz), (0.0, 0.0, 0.0)

    def positions(self, gammas: NDArray[np.float64]) -> NDArray[np.float64]:
        """p_d [m] at many gammas, shape (n, 3)."""
        g = _gamma_array(gammas)
        start = np.asarray(self.start, dtype=np.float64)
        velocity = np.asarray(self.velocity, dtype=np.float64)
        return start + g[:, None] * velocity

    @property
    def gamma_period(self) -> None:
        return None

    @property
    def straight_beyond(self) -> tuple[float, float]:
        """Straight everywhere."""
        return (0.0, 0.0)


@dataclass(frozen=True, slots=True)
class Lawnmower:
    """Seabed survey ("lawnmower") pattern in the horizontal plane z = origin[2].

    ``legs`` parallel straight legs of length leg_length [m], spacing [m] apart, joined by semicircular
    turns of radius spacing / 2 that alternate left, right, left, ... so the pattern advances to the left
    of the first leg.  The first leg starts at origin [m] and points along heading [rad, from +x toward
    +y].  gamma = arc length / scale, so |dp_d/dgamma| = scale [m per unit gamma] everywhere.  Outside
    [0, length / scale] the path continues straight: backwards along the first leg for gamma < 0 and
    forwards along the last leg beyond its end.  The path is C1; d2p_d/dgamma2 jumps at the joins.
    """

    origin: tuple[float, float, float]
    leg_length: float
    spacing: float
    legs: int
    heading: float = 0.0
    scale: float = 1.0
    # Segment start arc lengths [m], ascending, first is 0; searched with bisect in evaluate().
    _breaks: tuple[float, ...] = field(init=False, repr=False, compare=False)
    # Per segment: True for a turn (arc), False for a straight leg.
    _is_arc: tuple[bool, ...] = field(init=False, repr=False, compare=False)
    # Per segment, leg: (start x, start y, unit direction x, y); turn: (center x, y, start angle, +-1).
    _params: tuple[tuple[float, float, float, float], ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        _set(self, "origin", _vec3("origin", self.origin))
        _set(self, "leg_length", _positive("leg_length", self.leg_length))
        _set(self, "spacing", _positive("spacing", self.spacing))
        if isinstance(self.legs, bool) or not isinstance(self.legs, int | np.integer) or self.legs < 1:
            raise ValueError(f"legs must be an int >= 1, got {self.legs!r}")
        _set(self, "legs", int(self.legs))
        _set(self, "heading", _finite("heading", self.heading))
        _set(self, "scale", _positive("scale", self.scale))
        breaks, is_arc, params = self._segments()
        _set(self, "_breaks", breaks)
        _set(self, "_is_arc", is_arc)
        _set(self, "_params", params)

    def _segments(self) -> tuple[tuple[float, ...], tuple[bool, ...], tuple[tuple[float, float, float, float], ...]]:
        """(_breaks, _is_arc, _params) of the pattern: its legs and turns, in order."""
        uy, ux = sincos(self.heading)
        nx, ny = -uy, ux  # left normal of the first leg: the direction the pattern advances
        r = 0.5 * self.spacing
        # Each turn starts with the centre at +r*n from the leg end (left turns after even legs, right
        # turns after odd legs both bend toward +n), so the radius vector starts along -n.
        start_angle = atan2(-ny, -nx)
        x0, y0 = self.origin[0], self.origin[1]
        breaks: list[float] = []
        is_arc: list[bool] = []
        params: list[tuple[float, float, float, float]] = []
        arc = 0.0
        for k in range(self.legs):
            sign = 1.0 if k % 2 == 0 else -1.0  # even legs go along +u, odd legs along -u
            # Odd legs start level with the far end of the first leg (they run back towards origin).
            along = 0.0 if k % 2 == 0 else self.leg_length
            sx = x0 + along * ux + k * self.spacing * nx
            sy = y0 + along * uy + k * self.spacing * ny
            breaks.append(arc)
            is_arc.append(False)
            params.append((sx, sy, sign * ux, sign * uy))
            arc += self.leg_length
            if k < self.legs - 1:
                ex, ey = sx + self.leg_length * sign * ux, sy + self.leg_length * sign * uy
                breaks.append(arc)
                is_arc.append(True)
                # Turn left (+1, counter-clockwise) after even legs, right (-1) after odd legs.
                params.append((ex + r * nx, ey + r * ny, start_angle, sign))
                arc += math.pi * r
        return tuple(breaks), tuple(is_arc), tuple(params)

    @property
    def length(self) -> float:
        """Arc length [m] of the finite pattern (legs plus turns), i.e. gamma = length / scale at its end."""
        return self.legs * self.leg_length + (self.legs - 1) * math.pi * 0.5 * self.spacing

    def evaluate(self, gamma: float) -> tuple[Vec3, Vec3, Vec3]:
        """(p_d [m], dp_d/dgamma [m/gamma], d2p_d/dgamma2 [m/gamma^2]) at gamma."""
        return _arrays(self.evaluate_floats(gamma))

    def evaluate_floats(self, gamma: float) -> tuple[Float3, Float3, Float3]:
        s = gamma * self.scale
        # Segment i starts at _breaks[i]; a join belongs to the following segment.  Before 0 use leg 0,
        # after the end the last segment (always a leg), so extrapolation is straight.
        i = max(bisect_right(self._breaks, s) - 1, 0)
        ls = s - self._breaks[i]
        a, b, c, d = self._params[i]
        z = self.origin[2]
        k = self.scale
        if not self._is_arc[i]:
            return (a + ls * c, b + ls * d, z), (k * c, k * d, 0.0), (0.0, 0.0, 0.0)
        r = 0.5 * self.spacing
        theta = c + d * ls / r
        st, ct = sincos(theta)
        kk_r = k * k / r  # centripetal term: speed^2 / radius
        return (a + r * ct, b + r * st, z), (-k * d * st, k * d * ct, 0.0), (-kk_r * ct, -kk_r * st, 0.0)

    def positions(self, gammas: NDArray[np.float64]) -> NDArray[np.float64]:
        """p_d [m] at many gammas, shape (n, 3)."""
        g = _gamma_array(gammas)
        s = g * self.scale
        breaks = np.asarray(self._breaks)
        idx = np.clip(np.searchsorted(breaks, s, side="right") - 1, 0, None)
        ls = s - breaks[idx]
        prm = np.asarray(self._params)[idx]
        arc = np.asarray(self._is_arc)[idx]
        r = 0.5 * self.spacing
        # Compute both forms for every sample and select; cheap and branch-free.
        theta = prm[:, 2] + prm[:, 3] * ls / r
        out = np.empty((g.size, 3))
        out[:, 0] = np.where(arc, prm[:, 0] + r * np.cos(theta), prm[:, 0] + ls * prm[:, 2])
        out[:, 1] = np.where(arc, prm[:, 1] + r * np.sin(theta), prm[:, 1] + ls * prm[:, 3])
        out[:, 2] = self.origin[2]
        return out

    @property
    def gamma_period(self) -> None:
        return None

    @property
    def straight_beyond(self) -> tuple[float, float]:
        """Straight before the first leg starts and after the last leg ends (the pattern's extensions)."""
        return (0.0, self.length / self.scale)
