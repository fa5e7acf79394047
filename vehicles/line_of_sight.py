"""Line-of-sight path following that knows its inputs' limits: for a vehicle whose fins give a moment that grows
with the square of its speed (vehicles.actuators), where the backstepping design asks for more than they give.

Why. The delta-shifted backstepping law (vehicles.path_following) asks for angular rates up to about u / |delta|
and cancels the model's dynamics with torque it assumes it has: from rest it asks for 15 N m in the first second,
while a REMUS 100's fins give L u^2 d_max, 1.5 N m at 1 m/s and nothing at rest (issue 24's measurements: 47-307 m
off on the examples with fins). This law asks only for what the fins can give at the speed the vehicle has.

Guidance (Fossen & Pettersen, "On uniform semiglobal exponential stability (USGES) of proportional line-of-sight
guidance laws", Automatica 50(11), 2014; Breivik & Fossen, "Principles of guidance-based path following in 2D and
3D", CDC-ECC 2005): the vehicle steers toward the point `lookahead` metres ahead of its path point along the path's
tangent, T = p_d + lookahead t, t = p_d^gamma / |p_d^gamma| (a point on a curved path ahead would cut inside it).
The direction d to T in body axes, against the direction the vehicle moves (its sideslip and climb angles, over
ground where it knows or estimates the current: the sideslip compensation of Fossen, Pettersen & Galeazzi, IEEE TCST
23(2), 2015), gives a course error e_r = atan2(d_y, d_x) - atan2(v, u) and a climb error e_q likewise. For a
straight line, a constant speed U and a course that follows the line of sight, the cross-track error e obeys
e' = -U e / sqrt(lookahead^2 + e^2): USGES (the paper cited, Theorem 1), |e(t)| <= |e0| exp(-U t / sqrt(lookahead^2
+ e0^2)).

Rates within what the fins hold. The virtual yaw and pitch rates are the path's own turning rate (its tangent's angular
velocity in body axes, a feed-forward) plus k_heading times the error, each within the rates whose damping takes the
share `margin` of what the fins give at the present speed, tau_max(u) = min(max_torque, fin_moment u^2), beyond the
moment held M (restoring, Munk, lift, and the disturbance estimate below): up to the rate whose damping is margin
(tau_max + M) along M, and margin (tau_max - M) against it. A buoyant REMUS holding depth at 1 m/s needs more than half
its fins; a bound the same both ways (a share of tau_max - |M|) leaves it no rate once M outgrows the fins, even where M
turns it the way it must go, and a REMUS 20 % stiffer in pitch than its model then held its nose down with full fin and
dived 525 m (measured on 330787d; tests/test_line_of_sight.py flies it now). Against an M the fins cannot match the
bound is 0: the law spends the whole fin against it. A slower vehicle turns more gently instead of asking for a moment
it does not have; at rest it asks for none and thrusts first. The speed wanted along the path's tangent, over ground, is
its path point's, gamma_dot |p_d^gamma|, less k1 times the bounded along-track error (ahead of its path point it slows
down). The path point's own speed, not the fleet's v_d: a vehicle whose gamma the coordination speeds up would otherwise
lag until its along-track error paid for the difference, and eq. (3) would hold its gamma back by as much (inline5 on
fins: coordination error 0.42 at 400 s with v_d, 4e-4 with gamma_dot). The surge that gives it with the sway, heave and
current the vehicle has (in a turn it slips sideways: a surge of gamma_dot |p_d^gamma| would leave the vehicle short of
its path point, and the fleet's consensus off v_r), within [0, top speed]. Each velocity (u, q, r) then follows its
virtual value with gain k2 through the model's inverse, its damping fed forward at the virtual value (as backstepping's
"feedforward": the true damping stays on the measured velocity), less the disturbance estimate, and the inputs are held
within tau_max(u) and the thrust limit.

Disturbance observer (vehicles.disturbance_observer; its memory, vehicles.path_following.AdaptiveController). The
inverse is the nominal model's; on a plant that differs from it the proportional rate loop settles off its virtual rate
by the mismatch over k2 J, and where the fins are nearly spent that offset is the whole rate they allow (a REMUS with 20
% more heave mass and 15 % less surge mass than its model: 11 m off a line at 1.5 m/s without it, 0.01 m with it:
tests/test_disturbance_observer.py). The observer estimates the mismatch on u, q and r at the rate `observer` (None: k2,
as fast as the loop it serves; 0: off, and the law has no memory), and the inputs take it away. The estimate's own error
is multiplied each step by 1 - (1 - exp(-observer dt)) J / J_plant: it converges at any rate while the plant's inertia
is more than half the model's, and below that only while observer dt stays under about 1.6 (at +-60 %; derived from that
multiplier, not tested); the default rate keeps it far from that. What no controller can do it does not do either: where
a plant's trim needs more moment than its fins give at the path's speed (vehicles.trim), the vehicle leaves its path,
and `cpf validate` says so.

Path parameter: the paper's eq. (3) as backstepping's with delta = 0, gamma_ddot = -k_zeta (gamma_dot - v_d) +
sigma' p_d^gamma / |p_d^gamma|^2 with sigma = (p - p_d) / sqrt(1 + |p - p_d|^2) (the fleet adds v_tilde): eq. (3) in
arc length, so that the loop is the same whatever unit of gamma the scenario chose. As printed (without the
division) it pulls gamma toward the vehicle with |p_d^gamma|^2: a line at 10 m per unit of gamma held its path point
100 times harder than one at 1 m, while the vehicle's push forward, k1 along-track over |p_d^gamma|, did not grow:
the pair crept at 0.17 m/s instead of 1 and the vehicle, too slow for its fins to hold depth, left its tube by 6.7 m
(a new user's; tests/test_line_of_sight.py holds the two units' motions within 1e-6 m of each other). A path at 1 m
per unit of gamma (the rings, the lawnmower) runs as before, to the rounding of |p_d^gamma|^2 = 1.

Gains. The theorem assumes the course follows the line of sight; a cascade (the rates with k2, the course with
k_heading, the line of sight at U / lookahead) comes close to that when each loop is clearly slower than the one
inside it (singular perturbations: Khalil, Nonlinear Systems, 3rd ed., Sec. 11.5). The defaults: k1, k2 and k_zeta
as backstepping's, k_heading = k2 / 2, lookahead 8 m (5 lengths of a REMUS 100; U / lookahead = 0.125 1/s at 1 m/s,
a quarter of k_heading). tests/test_line_of_sight.py holds a straight-line approach under the theorem's exponential
bound once the course has turned. `lyapunov` is (rho - 1) + zeta^2 / 2 + (1 - cos e_r) + (1 - cos e_q), a measure of
the errors, not a proven Lyapunov function.

Fins. With vehicles.actuators' fins (fin_moment from the scenario's [vehicle] actuators) the law asks for no more
than they give. The vehicle must have the hull's and fins' lift (the remus100 preset: vehicles.params.LIFT): without
it, eqs. (1)-(2) with a REMUS 100's added masses are unstable in sway-yaw when running straight (the Munk moment,
unopposed: a pole of 1.3 1/s at 1 m/s), and the vehicle leaves its path on the fins whatever their servo (173 m off
inline5 with a 0.1 s servo, 174 m with 1 s); with the lift the pole is 0.39 1/s (tests/test_actuators.py) and the
fins hold it (tests/test_lift.py).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, Any

import numpy as np
from annotated_types import Ge, Gt, Le

from numerics import atan2, cos
from numerics.lanes import greatest, is_lanes, least, sqrt
from vehicles.disturbance_observer import NO_DISTURBANCE, Disturbance, filtered, measured
from vehicles.dynamics import Accelerations, PathVectors
from vehicles.geometry import Float3
from vehicles.params import VehicleParams
from vehicles.path_following import ControlOutput, Current, Stage, drag, saturated
from vehicles.saturation import clamp, within
from vehicles.vehicle_model import VehicleModel

# m/s: below this speed the sideslip and climb angles fade out (the angle of a velocity of a few cm/s is noise:
# at rest the vehicle steers its heading, not its course)
_CALM = 0.1


# What the law computes with (LineOfSight.lanes)
_LAW = ("start", "update", "control", "control_with", "_guidance", "_inputs", "_rates", "torque_limit")


@dataclass(frozen=True, slots=True)
class LineOfSight:
    """The law of the module docstring (entry point `line_of_sight`). lookahead [m]; k1 [m/s]; k2, k_heading,
    k_zeta [1/s]; fin_moment [N m / (m/s)^2]: the fins' largest moment per (m/s)^2 (L d_max: vehicles.actuators;
    None: the preset's constant max_torque alone bounds the moments); margin: the share of the moment available that
    the virtual rates may take against damping (the rest turns the vehicle); min_speed [m/s]: the least surge it
    asks for; observer [1/s]: the disturbance observer's rate (None: k2; 0: none)."""

    lookahead: Annotated[float, Gt(0)] = 8.0
    k1: Annotated[float, Gt(0)] = 0.5
    k2: Annotated[float, Gt(0)] = 1.0
    k_heading: Annotated[float, Gt(0)] = 0.5
    k_zeta: Annotated[float, Gt(0)] = 1.0
    fin_moment: Annotated[float, Gt(0)] | None = None
    margin: Annotated[float, Gt(0), Le(1)] = 0.5
    min_speed: Annotated[float, Ge(0)] = 0.0
    observer: Annotated[float, Ge(0)] | None = None

    @property
    def lanes(self) -> bool:
        """Whether its law takes arrays of lanes (vehicles.lanes): this class's does; a subclass that replaces a
        part of it says so itself (a class attribute lanes = True)."""
        return all(getattr(type(self), name) is getattr(LineOfSight, name) for name in _LAW)

    @property
    def adaptive(self) -> bool:
        """Whether it has a memory (vehicles.path_following.is_adaptive): its disturbance estimate, unless off."""
        return self.observer != 0.0

    def start(self, model: VehicleModel, params: VehicleParams, s: Sequence[float]) -> Disturbance:
        return NO_DISTURBANCE

    def update(
        self, memory: object, model: VehicleModel, params: VehicleParams, stages: Sequence[Stage],
        after: Sequence[float], dt: float,
    ) -> Disturbance:  # fmt: skip
        assert isinstance(memory, Disturbance)
        rate = self.k2 if self.observer is None else self.observer
        return filtered(memory, measured(model, params, stages, after, dt), rate, dt)

    def control(
        self, model: VehicleModel, params: VehicleParams, s: Sequence[float], path: PathVectors, gamma: float,
        gamma_dot: float, v_d: float, current: Current | None,
    ) -> ControlOutput:  # fmt: skip
        """Without a memory: no disturbance estimated."""
        return self.control_with(NO_DISTURBANCE, model, params, s, path, gamma, gamma_dot, v_d, current)

    def control_with(
        self, memory: object, model: VehicleModel, params: VehicleParams, s: Sequence[float], path: PathVectors,
        gamma: float, gamma_dot: float, v_d: float, current: Current | None,
    ) -> ControlOutput:  # fmt: skip
        assert isinstance(memory, Disturbance)
        p_d, p_g, _ = path
        error = (s[0] - p_d[0], s[1] - p_d[1], s[2] - p_d[2])
        rho = sqrt(1.0 + error[0] * error[0] + error[1] * error[1] + error[2] * error[2])
        along = (error[0] * p_g[0] + error[1] * p_g[1] + error[2] * p_g[2]) / rho
        zeta = gamma_dot - v_d
        drift = model.drift(s, params)
        e_r, e_q, turning, u_path = self._guidance(s, path, error, gamma_dot, current)
        wanted = _surge_for(s, p_g, u_path, u_path * gamma_dot - self.k1 * along / greatest(u_path, 1e-9), current)
        tau = self._inputs(params, s, drift, memory.inputs, (e_r, e_q), turning, wanted)
        lyapunov = (rho - 1.0) + 0.5 * zeta * zeta + (1.0 - cos(e_r)) + (1.0 - cos(e_q))
        return ControlOutput(tau, -self.k_zeta * zeta + along / greatest(u_path * u_path, 1e-18), lyapunov, drift)

    def _guidance(
        self, s: Sequence[float], path: PathVectors, error: Float3, gamma_dot: float, current: Current | None
    ) -> tuple[float, float, Float3, float]:
        """(course and climb errors [rad]: from the direction the vehicle moves over ground to the line of sight,
        the path tangent's angular velocity in body axes [rad/s], |p_d^gamma| [m per unit of gamma])."""
        _, p_g, p_gg = path
        speed = sqrt(p_g[0] * p_g[0] + p_g[1] * p_g[1] + p_g[2] * p_g[2])
        # on the tangent, not the path: a point on a curve ahead cuts inside it
        a = self.lookahead / greatest(speed, 1e-9)
        to_target = (a * p_g[0] - error[0], a * p_g[1] - error[1], a * p_g[2] - error[2])
        dx, dy, dz = _in_body(s, to_target)
        spin = gamma_dot / greatest(speed * speed, 1e-18)  # the tangent turns at (p_g x p_gg) gamma_dot / |p_g|^2
        turning = _in_body(s, (spin * (p_g[1] * p_gg[2] - p_g[2] * p_gg[1]),
                               spin * (p_g[2] * p_gg[0] - p_g[0] * p_gg[2]),
                               spin * (p_g[0] * p_gg[1] - p_g[1] * p_gg[0])))  # fmt: skip
        u, v, w = _over_ground(s, current)
        moving = least(1.0, sqrt(u * u + v * v + w * w) / _CALM)
        course = atan2(dy, dx) - moving * atan2(v, u)
        climb = atan2(dz, sqrt(dx * dx + dy * dy)) - moving * atan2(w, sqrt(u * u + v * v))
        return course, climb, turning, speed

    def _inputs(
        self, prm: VehicleParams, s: Sequence[float], drift: Accelerations, d: Float3, errors: tuple[float, float],
        turning: Float3, u_wanted: float,
    ) -> Float3:  # fmt: skip
        """(tau_u, tau_q, tau_r): each of u, q, r led to its virtual value with gain k2, within the limits; d: the
        disturbance estimate, which the inputs take away."""
        u, q, r = s[12], s[16], s[17]
        (du, _, _), (_, dq, dr) = drift
        limit = self.torque_limit(prm, u)
        lin, quad = prm.angular_linear_damping, prm.angular_quadratic_damping
        # the moment held other than damping (restoring, Munk, lift, what the observer found) shifts the rates the
        # fins can hold: more along it, less against it
        held_q = prm.inertia[1] * dq + (lin[1] + quad[1] * abs(q)) * q + d[1]
        held_r = prm.inertia[2] * dr + (lin[2] + quad[2] * abs(r)) * r + d[2]
        q_v = clamp(turning[1] - self.k_heading * errors[1], *self._rates(lin[1], quad[1], limit, held_q))
        r_v = clamp(turning[2] + self.k_heading * errors[0], *self._rates(lin[2], quad[2], limit, held_r))
        u_v = least(greatest(u_wanted, self.min_speed), top_speed(prm))
        k2 = self.k2
        tau = (
            prm.mass[0] * (-k2 * (u - u_v) - du) + drag(prm.linear_damping[0], prm.quadratic_damping[0], u_v, u) - d[0],
            prm.inertia[1] * (-k2 * (q - q_v) - dq) + drag(lin[1], quad[1], q_v, q) - d[1],
            prm.inertia[2] * (-k2 * (r - r_v) - dr) + drag(lin[2], quad[2], r_v, r) - d[2],
        )
        return _held(saturated(prm, *tau), limit)

    def _rates(self, linear: float, quadratic: float, limit: float, held: float) -> tuple[float, float]:
        """The lowest and highest virtual rates [rad/s] whose damping takes the share `margin` of what the fins give
        beyond the moment held against that direction (held > 0 turns the rate up: it adds to the fins going up and
        takes from them going down). Against a held moment the fins cannot match the bound is 0: the law asks for
        the rate to stop, which spends the whole fin against it."""
        up = _rate_within(linear, quadratic, self.margin * (limit + held))
        down = _rate_within(linear, quadratic, self.margin * (limit - held))
        return -down, up

    def turn_rate_bound(self, prm: VehicleParams, u: float, rate: float, moment: float) -> float:
        """The largest yaw rate [rad/s] this law asks for in a steady level turn at surge u that takes the yaw moment
        `moment` at `rate` (vehicles.turn): its own bound (_rates), with the moment held other than damping the
        turn's damping less its moment. An optional method of a controller: supervisor.config.turn_checks asks it
        where a path turns fastest (a controller without it is judged by the rudder alone)."""
        lin, quad = prm.angular_linear_damping[2], prm.angular_quadratic_damping[2]
        held = (lin + quad * abs(rate)) * rate - moment
        return float(self._rates(lin, quad, self.torque_limit(prm, u), held)[1])

    def torque_limit(self, prm: VehicleParams, u: float) -> float:
        """The largest pitch or yaw moment at surge speed u [N m]: the preset's, or the fins' if smaller."""
        if self.fin_moment is None:
            return prm.max_torque
        return least(prm.max_torque, self.fin_moment * u * u)


def _surge_for(s: Sequence[float], p_g: Float3, norm: float, along_speed: float, current: Current | None) -> float:
    """The surge speed through the water [m/s] that moves the vehicle along its path's tangent at along_speed over
    ground, its sway, heave and the current as they are; with the tangent more than 60 deg off its axis, as if it were
    60 deg off (the course is still turning toward the line of sight)."""
    inv = 1.0 / greatest(norm, 1e-9)  # norm: |p_g|, which the guidance has computed
    tx, ty, tz = _in_body(s, (p_g[0] * inv, p_g[1] * inv, p_g[2] * inv))
    u, v, w = _over_ground(s, current)
    return (along_speed - ty * v - tz * w) / greatest(tx, 0.5) - (u - s[12])


def _over_ground(s: Sequence[float], current: Current | None) -> Float3:
    """The body velocity over ground: through the water, plus the current where the vehicle knows or estimates it."""
    if current is None:
        return s[12], s[13], s[14]
    c = current[0]
    return s[12] + c[0], s[13] + c[1], s[14] + c[2]


def top_speed(prm: VehicleParams) -> float:
    """The surge speed full thrust holds against the surge damping [m/s]."""
    return _rate_within(prm.linear_damping[0], prm.quadratic_damping[0], prm.max_surge_force)


def _rate_within(linear: float, quadratic: float, moment: Any) -> Any:
    """The rate x >= 0 with (linear + quadratic x) x = moment (0 if moment <= 0): what that much effort holds.
    moment may be lanes (the rate of each)."""
    if is_lanes(moment):
        calm = moment <= 0.0  # a NaN is not: it goes on, as the float's does
        return np.where(calm, 0.0, _positive_rate(linear, quadratic, np.where(calm, 1.0, moment)))
    return 0.0 if moment <= 0.0 else _positive_rate(linear, quadratic, moment)


def _positive_rate(linear: float, quadratic: float, moment: Any) -> Any:
    if quadratic <= 0.0:
        return moment / linear if linear > 0.0 else math.inf
    return (-linear + sqrt(linear * linear + 4.0 * quadratic * moment)) / (2.0 * quadratic)


def _held(tau: Float3, limit: float) -> Float3:
    return tau[0], within(tau[1], limit), within(tau[2], limit)


def _in_body(s: Sequence[float], w: Float3) -> Float3:
    """R' w for the lifted state's rotation (row-major, body to inertial)."""
    r11, r12, r13, r21, r22, r23, r31, r32, r33 = s[3:12]
    return (
        r11 * w[0] + r21 * w[1] + r31 * w[2],
        r12 * w[0] + r22 * w[1] + r32 * w[2],
        r13 * w[0] + r23 * w[1] + r33 * w[2],
    )
