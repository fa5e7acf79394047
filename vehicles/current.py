"""The ocean current: its inertial velocity v_c(t, p) and how it enters the vehicle's equations, in floats.

    v_c(t, p) = constant + tide sin(2 pi t / period + phase) + shear (z - shear_origin)

- constant: a uniform, steady stream [vx, vy, vz], m/s;
- tide: a tidal stream, amplitude vector [ax, ay, az] m/s, period s (12.42 h for the M2 tide), phase rad;
- shear: a linear horizontal shear in depth, [dvx/dz, dvy/dz] 1/s, zero at z = shear_origin. Chosen over a field on
  a grid because it is the one spatial structure every coastal current has (wind-driven surface layer, bottom
  boundary layer), it needs two numbers, and it is divergence free (the horizontal speed depends on z alone), so it
  is a physical flow; vehicles at different depths (the paper's helices climb) feel different currents.

How it acts (Fossen, "How to incorporate wind, waves and ocean currents in the marine craft equations of motion",
IFAC MCMC 2012; Handbook of Marine Craft Hydrodynamics and Motion Control, 2011, sec. 8.3 and Property 8.1): the
added-mass Coriolis and Munk terms and the damping act on the velocity relative to the water v_r = v - R' v_c, and
for an irrotational constant current the whole model (2) may be written in v_r with p_dot = R v_r + v_c. This
simulator takes that form: **the state's body velocity is the velocity relative to the water**, the dynamics (2) are
unchanged and only the kinematics (1a) gain the current. A restarted vehicle needs nothing handed over: v_c is a
function of (t, p). The form neglects the force of an accelerating stream on a vehicle that is not neutrally buoyant,
(m - rho Vol) R' dv_c/dt: for a tide of 0.5 m/s over 12.42 h, dv_c/dt is below 1e-4 m/s^2.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from numerics import cos, sin
from vehicles.geometry import Float3

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, slots=True)
class Current:
    """v_c(t, p) of the module docstring; the default is still water."""

    constant: Float3 = (0.0, 0.0, 0.0)  # m/s, inertial (z up)
    tide_amplitude: Float3 = (0.0, 0.0, 0.0)  # m/s
    tide_period: float = 44712.0  # s (M2: 12.42 h); used only with a non-zero amplitude
    tide_phase: float = 0.0  # rad
    shear: tuple[float, float] = (0.0, 0.0)  # dvx/dz, dvy/dz, 1/s
    shear_origin: float = 0.0  # z where the shear term is zero, m

    def velocity(self, t: float, z: float) -> Float3:
        """v_c at time t [s] and height z [m] (the field does not depend on x and y), inertial frame, m/s."""
        (cx, cy, cz), (ax, ay, az) = self.constant, self.tide_amplitude
        tide = sin(TWO_PI * t / self.tide_period + self.tide_phase)
        dz = z - self.shear_origin
        return cx + ax * tide + self.shear[0] * dz, cy + ay * tide + self.shear[1] * dz, cz + az * tide

    def rate(self, t: float, z: float, z_dot: float) -> Float3:
        """dv_c/dt along a vehicle's motion (height rate z_dot): the tide's time derivative plus the shear it
        climbs through; inertial frame, m/s^2. What a controller that knows the current feeds forward."""
        ax, ay, az = self.tide_amplitude
        w = TWO_PI / self.tide_period
        tide = w * cos(w * t + self.tide_phase)
        return ax * tide + self.shear[0] * z_dot, ay * tide + self.shear[1] * z_dot, az * tide


def body(rotation: Sequence[float], vector: Float3) -> Float3:
    """R' vector for R given row-major (9 floats): an inertial vector in body axes."""
    r11, r12, r13, r21, r22, r23, r31, r32, r33 = rotation
    x, y, z = vector
    return r11 * x + r21 * y + r31 * z, r12 * x + r22 * y + r32 * z, r13 * x + r23 * y + r33 * z


def body_to_inertial(rotation: Sequence[float], vector: Float3) -> Float3:
    """R vector for R given row-major (9 floats): a body vector in inertial axes."""
    r11, r12, r13, r21, r22, r23, r31, r32, r33 = rotation
    x, y, z = vector
    return r11 * x + r12 * y + r13 * z, r21 * x + r22 * y + r23 * z, r31 * x + r32 * y + r33 * z


def feedforward(current: Current, t: float, s: Sequence[float]) -> tuple[Float3, Float3]:
    """(c, c_dot) for a lifted state s (vehicles.dynamics) at time t: the current in body axes c = R' v_c and its
    derivative c_dot = -omega x c + R' dv_c/dt, what a controller that knows the current needs (vehicles.path_following
    .control). The state's v is relative to the water, so the height rate is (R v)_z + v_c,z."""
    rot = s[3:12]
    v_c = current.velocity(t, s[2])
    z_dot = rot[6] * s[12] + rot[7] * s[13] + rot[8] * s[14] + v_c[2]
    return in_body(s, v_c, current.rate(t, s[2], z_dot))


def in_body(s: Sequence[float], v_c: Float3, v_c_dot: Float3) -> tuple[Float3, Float3]:
    """(c, c_dot) in body axes of an inertial current v_c and its rate along the motion, for a lifted state s:
    c = R' v_c, c_dot = -omega x c + R' v_c_dot (the known current's and the observer's estimate's alike)."""
    rot = s[3:12]
    c = body(rot, v_c)
    dx, dy, dz = body(rot, v_c_dot)
    p, q, r = s[15:18]
    return c, (dx - (q * c[2] - r * c[1]), dy - (r * c[0] - p * c[2]), dz - (p * c[1] - q * c[0]))
