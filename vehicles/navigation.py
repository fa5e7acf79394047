"""Navigation: what a vehicle's controller believes its position is, from its sensors fused by a Kalman filter.

Sensors, measured on the true state at each sync instant t_k (noise drawn statelessly from (seed, vehicle, k), so
no engine, host or restart can change a draw):
- DVL: body velocity v_m = v + b + n_v, with b a constant bias drawn once per vehicle and n_v white;
- AHRS heading: psi_m = psi + n_psi, a rotation about the inertial vertical (roll and pitch are taken as exact: an
  AHRS's gravity reference holds them to a fraction of a degree; heading is what a magnetic compass gets wrong);
- depth sensor: z_m = z + n_z, every step;
- position fix (USBL/LBL): horizontal p_xy + n_f, at the first step at or after each multiple of fix_period, lost
  with probability fix_dropout.

Filter: a linear Kalman filter on x = [p (inertial, 3), b (DVL bias, body, 3)], driven by dead reckoning,
    p_{k+1} = p_k + dt R_hat_k (v_m,k - b),   b_{k+1} = b_k          (forward Euler over the step)
with R_hat the attitude with the measured heading. Given the measured R_hat and v_m (its inputs) the model is linear
in x, so the filter is a plain linear time-varying Kalman filter. Process noise: the DVL's white noise,
dt^2 sigma_v^2 I, and the heading noise acting across the track, dt^2 sigma_psi^2 n n' (n = (-v_y, v_x, 0), the
horizontal velocity turned by 90 deg). Depth and fixes are fused in Joseph form (Maybeck, Stochastic Models,
Estimation and Control, vol. 1, 1979, sec. 5.6; Groves, Principles of GNSS, Inertial and Multisensor Integrated
Navigation Systems, 2nd ed., 2013, ch. 3). Why this filter: it is the standard DVL-aided dead-reckoning design
reduced to what a position controller needs; estimating the bias keeps the covariance honest (an unmodelled bias
grows an error the filter does not know of) and lets the error between fixes shrink as fixes accumulate.

Within an RK4 step the controller sees the true stage state with the estimation error of t_k held over the step
(HeldError: position, heading and velocity errors): the filter runs once per sync step, as a navigation computer
does, and the plant integrates smoothly.

Products go through numerics.linalg (fixed-order sums of elementwise operations), not numpy's `@` and `linalg`
(BLAS and LAPACK, whose kernels differ per CPU): the filter gives the same bits on every machine.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from comms.records.records import FloatArray
from numerics import sincos
from numerics.linalg import det, inverse, matmul
from vehicles.geometry import Float3

NAV_STREAM = 0x6E6176  # "nav": keeps these draws apart from any other random stream of the same (seed, vehicle)
_STEP, _BIAS, _INIT = 0, 1, 2  # what a draw is for
NO_FIX, FIX, FIX_LOST = 0, 1, 2  # what happened to the position fix at a step
_SIZE = 6
_UPPER = np.triu_indices(_SIZE)


@dataclass(frozen=True, slots=True)
class NavParams:
    """The sensors of one vehicle: standard deviations (1 sigma) in m, m/s and rad; fix_period in s."""

    seed: int
    vehicle_id: int
    dvl_noise: float
    dvl_bias: float
    heading_noise: float
    depth_noise: float
    fix_period: float
    fix_noise: float
    fix_dropout: float
    initial_error: float
    planar: bool = False  # a planar vehicle: no error out of its plane reaches the controller
    true_bias: Float3 = field(init=False)  # the DVL's bias, one draw per vehicle

    def __post_init__(self) -> None:
        b = self.rng(_BIAS).standard_normal(3) * self.dvl_bias
        object.__setattr__(self, "true_bias", (float(b[0]), float(b[1]), float(b[2])))

    def rng(self, *key: int) -> np.random.Generator:
        """A generator for one purpose (and step): the same numbers wherever and whenever it is asked."""
        return np.random.default_rng([self.seed, self.vehicle_id, NAV_STREAM, *key])


@dataclass(frozen=True, slots=True)
class NavState:
    """The filter's estimate x = [p, b] and its covariance (6 x 6, symmetric)."""

    x: FloatArray
    cov: FloatArray

    def flat(self) -> tuple[float, ...]:
        """x, then the covariance's upper triangle by rows: 27 numbers, what the state message carries."""
        return (*self.x.tolist(), *self.cov[_UPPER].tolist())

    @classmethod
    def from_flat(cls, values: Sequence[float]) -> NavState:
        """Inverse of flat (exact: the covariance is kept symmetric to the bit). ValueError for a wrong length."""
        if len(values) != _SIZE + len(_UPPER[0]):
            raise ValueError(f"a navigation state has {_SIZE + len(_UPPER[0])} numbers, got {len(values)}")
        cov = np.zeros((_SIZE, _SIZE))
        cov[_UPPER] = values[_SIZE:]
        cov.T[_UPPER] = values[_SIZE:]
        return cls(np.array(values[:_SIZE], dtype=float), cov)

    @property
    def position(self) -> Float3:
        return float(self.x[0]), float(self.x[1]), float(self.x[2])


@dataclass(frozen=True, slots=True)
class HeldError:
    """How the controller's view differs from the truth over one step."""

    position: Float3  # p_hat - p, inertial, m
    heading: float  # psi_m - psi, rad (about the inertial vertical)
    velocity: Float3  # (v_m - b_hat) - v, body, m/s


@dataclass(frozen=True, slots=True)
class NavOutput:
    posterior: NavState  # the estimate at t_k, fused with the measurements of t_k
    held: HeldError  # what the controller sees wrong over the step
    prior: NavState  # dead-reckoned to t_k + dt: the next step's starting point
    fix: int  # NO_FIX, FIX or FIX_LOST


def initial(params: NavParams, position: Sequence[float]) -> NavState:
    """The estimate at the start: the true position off by initial_error per axis, the bias unknown."""
    error = params.rng(_INIT).standard_normal(3) * params.initial_error
    x = np.concatenate((np.asarray(position[:3], dtype=float) + error, np.zeros(3)))
    variances = [params.initial_error * params.initial_error] * 3 + [params.dvl_bias * params.dvl_bias] * 3
    return NavState(x, np.diag(variances))


def fix_due(k: int, dt: float, period: float) -> bool:
    """Whether step k is the first at or after a multiple of period (none at k = 0: the start is initial_error)."""
    if k <= 0:
        return False
    eps = 1e-9  # k dt / period lands a hair under an integer in floats (0.1 * 30 / 3)
    return math.floor(k * dt / period + eps) > math.floor((k - 1) * dt / period + eps)


def _heading_rotation(s: Sequence[float], angle: float) -> FloatArray:
    """R_hat = Rz(angle) R of a lifted state s (R row-major in s[3:12])."""
    sn, c = sincos(angle)
    r11, r12, r13, r21, r22, r23, r31, r32, r33 = s[3:12]
    return np.array([
        [c * r11 - sn * r21, c * r12 - sn * r22, c * r13 - sn * r23],
        [sn * r11 + c * r21, sn * r12 + c * r22, sn * r13 + c * r23],
        [r31, r32, r33],
    ])  # fmt: skip


def _update(x: FloatArray, cov: FloatArray, h: FloatArray, z: FloatArray, noise: FloatArray) -> tuple[FloatArray, ...]:
    """Kalman measurement update in Joseph form, kept symmetric; skipped if the innovation has no variance (a
    perfect sensor that already fixed the state)."""
    ch = matmul(cov, h.T)
    s = matmul(h, ch) + noise
    if det(s) <= 0.0:
        return x, cov
    gain = matmul(ch, inverse(s))
    x = x + matmul(gain, z - matmul(h, x))
    ikh = np.eye(_SIZE) - matmul(gain, h)
    cov = matmul(matmul(ikh, cov), ikh.T) + matmul(matmul(gain, noise), gain.T)
    return x, 0.5 * (cov + cov.T)


def navigate(
    params: NavParams,
    prior: NavState,
    s: Sequence[float],
    k: int,
    dt: float,
    current_body: Float3 = (0.0, 0.0, 0.0),
) -> NavOutput:
    """One sync step of the navigation computer at t_k = k dt, on the true lifted state s: measure, fuse, dead
    reckon to t_k + dt. current_body: the water's velocity in body axes, R' v_c (s's v is relative to the water)."""
    draws = params.rng(_STEP, k)
    n = draws.standard_normal(7)  # always 7 normals, then 1 uniform: no draw depends on another
    lost = draws.random() < params.fix_dropout
    p, v = np.array(s[0:3], dtype=float), np.array(s[12:15], dtype=float)
    v_m = v + np.array(params.true_bias) + params.dvl_noise * n[0:3]
    heading_error = params.heading_noise * float(n[3])
    x, cov = _update(prior.x, prior.cov, _rows([2]), p[2:3] + params.depth_noise * n[4:5], _var(params.depth_noise, 1))
    fix = NO_FIX
    if fix_due(k, dt, params.fix_period):
        fix = FIX_LOST if lost else FIX
        if not lost:
            x, cov = _update(x, cov, _rows([0, 1]), p[0:2] + params.fix_noise * n[5:7], _var(params.fix_noise, 2))
    posterior = NavState(x, cov)
    v_c = v_m - x[3:6]
    held = _held(params, x[0:3] - p, heading_error, v_c - v)
    # A bottom-locked DVL measures the velocity over ground, v + R' v_c: dead reckoning on v alone would leave the
    # current out of the estimate, which then drifts away at v_c between fixes. The controller's velocity error
    # (held) stays the sensor's own error; whether the controller knows the current is [environment]'s business.
    ground = v_c + np.array(current_body)
    return NavOutput(posterior, held, _predict(params, posterior, _heading_rotation(s, heading_error), ground, dt), fix)


def _predict(params: NavParams, post: NavState, r_hat: FloatArray, v_c: FloatArray, dt: float) -> NavState:
    """Dead reckoning over one step: p += dt R_hat (v_m - b_hat), b held; the covariance through F with the DVL and
    heading noise added."""
    f = np.eye(_SIZE)
    f[0:3, 3:6] = -dt * r_hat
    inertial = matmul(r_hat, v_c)
    across = np.array([-inertial[1], inertial[0], 0.0])
    q = np.zeros((_SIZE, _SIZE))
    q[0:3, 0:3] = (
        dt
        * dt
        * (
            params.dvl_noise * params.dvl_noise * np.eye(3)
            + params.heading_noise * params.heading_noise * np.outer(across, across)
        )
    )
    x = post.x.copy()
    x[0:3] += dt * inertial
    cov = matmul(matmul(f, post.cov), f.T) + q
    return NavState(x, 0.5 * (cov + cov.T))


def _held(params: NavParams, position: FloatArray, heading: float, velocity: FloatArray) -> HeldError:
    ex, ey, ez = (float(e) for e in position)
    vx, vy, vz = (float(e) for e in velocity)
    if params.planar:  # nothing out of the plane: the planar controller would feel it through z1
        ez = vz = 0.0
    return HeldError((ex, ey, ez), heading, (vx, vy, vz))


def _rows(indices: list[int]) -> FloatArray:
    """A measurement matrix picking the state's entries `indices`."""
    h = np.zeros((len(indices), _SIZE))
    h[range(len(indices)), indices] = 1.0
    return h


def _var(sigma: float, n: int) -> FloatArray:
    return sigma * sigma * np.eye(n)


def seen(s: Sequence[float], held: HeldError) -> list[float]:
    """The lifted state the controller sees: the true (stage) state s with the held estimation error."""
    (ex, ey, ez), (evx, evy, evz) = held.position, held.velocity
    sn, c = sincos(held.heading)
    r11, r12, r13, r21, r22, r23 = s[3:9]
    return [
        s[0] + ex, s[1] + ey, s[2] + ez,
        c * r11 - sn * r21, c * r12 - sn * r22, c * r13 - sn * r23,
        sn * r11 + c * r21, sn * r12 + c * r22, sn * r13 + c * r23,
        *s[9:12], s[12] + evx, s[13] + evy, s[14] + evz, *s[15:18],
    ]  # fmt: skip
