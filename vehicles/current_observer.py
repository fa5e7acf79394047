"""Estimating the ocean current on board: a position observer whose integral state is the current.

The vehicle knows its velocity relative to the water, nu (the state's, as the controller sees it), and its position
p; over ground it moves at p_dot = R nu + v_c. The observer of a constant current (Aguiar & Pascoal, "Dynamic
positioning and way-point tracking of underactuated AUVs in the presence of ocean currents", Int. J. Control 80(7),
2007; the current observer of the Medusa sea-trial controllers, hungrepo/cooperative-path-following,
Real_trial/cpf_controller.py) is p_hat_dot = R nu + c_hat + k_p e, c_hat_dot = k_c e with e = p - p_hat. A current
that changes steadily (a tide; a shear the vehicle climbs through) it follows with a lag of about 2 / omega times the
rate (at 0.05 rad/s and a 7.5e-4 m/s^2 change, 0.03 m/s: as much coordination error as an unknown 0.03 m/s current).
So the model of the current here is a steady rate of change, one state more (the internal model principle: Francis &
Wonham, Automatica 12(5), 1976):

    p_hat_dot = R nu + c_hat + 3 omega e,   c_hat_dot = r_hat + 3 omega^2 e,   r_hat_dot = omega^3 e

whose errors obey (s + omega)^3 = 0 per axis for a current changing at a constant rate: the estimate converges, and
a ramp is followed without lag.

Gains. The observer's errors obey their own linear equation whatever the controller does (it is driven by what is
measured, not by the control), so the estimate converges at any omega > 0 and the closed loop is a cascade of a
converging observer into the controller; what limits omega is the noise it passes on from navigation. It is set to
the slowest rate the backstepping design gives its own errors, omega = min(k1 / |delta|, k2) (0.5 rad/s with the
paper's gains; settled to 2 % in about 8.4 / omega = 17 s): as fast as the loop that uses the estimate, no faster.
The controller is fed (R' c_hat, its derivative) exactly as it is fed a current it is told
(vehicles.current.feedforward). Pure functions of the observer's nine states, integrated with the vehicle's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from vehicles.current import body_to_inertial, in_body
from vehicles.geometry import Float3

SIZE = 9  # p_hat (3), c_hat (3), r_hat (3), inertial, m, m/s and m/s^2


@dataclass(frozen=True, slots=True)
class CurrentObserver:
    """The observer of the module docstring: omega [rad/s], its triple pole."""

    omega: float

    @classmethod
    def for_loop(cls, k1: float, delta: float, k2: float) -> CurrentObserver:
        """The default observer for a path-following loop with these gains (module docstring)."""
        return cls(min(k1 / abs(delta), k2))

    def initial(self, s: Sequence[float]) -> tuple[float, ...]:
        """The observer's state when it starts, for the lifted state s it sees: p_hat = p, no current."""
        return (s[0], s[1], s[2], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def rates(self, s: Sequence[float], o: Sequence[float]) -> tuple[float, ...]:
        """d/dt of the observer's state o for the lifted state s it sees."""
        w = self.omega
        k_p, k_c, k_r = 3.0 * w, 3.0 * w * w, w * w * w
        ex, ey, ez = s[0] - o[0], s[1] - o[1], s[2] - o[2]
        vx, vy, vz = body_to_inertial(s[3:12], (s[12], s[13], s[14]))
        return (
            vx + o[3] + k_p * ex, vy + o[4] + k_p * ey, vz + o[5] + k_p * ez,
            o[6] + k_c * ex, o[7] + k_c * ey, o[8] + k_c * ez,
            k_r * ex, k_r * ey, k_r * ez,
        )  # fmt: skip


def estimate(o: Sequence[float]) -> Float3:
    """The current estimate c_hat of an observer state, inertial, m/s."""
    return (o[3], o[4], o[5])


def feedforward(s: Sequence[float], o: Sequence[float], o_dot: Sequence[float]) -> tuple[Float3, Float3]:
    """(c, c_dot) in body axes from the estimate, for the controller (vehicles.current.in_body)."""
    return in_body(s, (o[3], o[4], o[5]), (o_dot[3], o_dot[4], o_dot[5]))
