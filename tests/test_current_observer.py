"""The on-board current observer (vehicles.current_observer; issue 24): its theory, and the fleet it gives back.

Theory: per axis the errors of p_hat, c_hat and r_hat obey (s + omega)^3 = 0 for a current changing at a constant
rate, so a constant current and a ramp are both estimated without a steady error, and the error of a step in the
current decays as t^2 exp(-omega t). Closed loop: with an unknown 0.3 m/s current (steady, tidal, sheared) the
paper scenario's path error (max after the transient, and over the last 50 s) and coordination error (last 50 s)
come back within twice their still-water values (issue 24's acceptance); without the observer they do not.
"""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from supervisor.analysis.summary import coordination_error
from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from tests.conftest import ROOT
from vehicles.current_observer import CurrentObserver, estimate, feedforward

OMEGA = 0.5


def observe(current, seconds: float, dt: float = 0.01) -> list[tuple[float, tuple[float, float, float]]]:
    """A vehicle at rest in the water (nu = 0, R = I) drifting with current(t); the observer integrated by RK4.
    Returns (t, c_hat) every second."""
    observer = CurrentObserver(OMEGA)
    s = [0.0] * 18
    s[3], s[7], s[11] = 1.0, 1.0, 1.0  # R = I

    def derivative(t: float, y: list[float]) -> list[float]:
        here = [*y[:3], *s[3:]]
        return [*current(t), *observer.rates(here, y[3:])]

    y = [*s[:3], *observer.initial(s)]
    out = []
    steps_per_second = round(1.0 / dt)
    for k in range(round(seconds / dt)):
        t = k * dt
        if k % steps_per_second == 0:
            out.append((t, estimate(y[3:])))
        k1 = derivative(t, y)
        k2 = derivative(t + dt / 2, [a + dt / 2 * b for a, b in zip(y, k1, strict=True)])
        k3 = derivative(t + dt / 2, [a + dt / 2 * b for a, b in zip(y, k2, strict=True)])
        k4 = derivative(t + dt, [a + dt * b for a, b in zip(y, k3, strict=True)])
        y = [a + dt / 6 * (b1 + 2 * b2 + 2 * b3 + b4) for a, b1, b2, b3, b4 in zip(y, k1, k2, k3, k4, strict=True)]
    return out


def test_a_steady_current_is_estimated_and_its_error_decays_as_a_triple_pole():
    """Step of 0.3 m/s at t = 0: the error e(t) of c_hat solves (s + omega)^3 = 0 from e(0) = 0.3, e'(0) and e''(0)
    as the observer's equations give them; compared with that closed form at every second."""
    c = 0.3
    history = observe(lambda t: (c, 0.0, 0.0), 60.0)
    w = OMEGA
    # Position error E = p - p_hat starts at 0 with E' = c, E'' = -3 w c, and (D + w)^3 E = 0:
    # E = (a + b t + d t^2) exp(-w t) with a = 0, b = c, d = (-3 w c + 2 w b) / 2 = -w c / 2.
    # c_tilde = c - c_hat = E' + 3 w E.
    for t, (cx, cy, cz) in history:
        big_e = (c * t - w * c * t * t / 2) * math.exp(-w * t)
        big_e_dot = (c - w * c * t) * math.exp(-w * t) - w * big_e
        assert c - cx == pytest.approx(big_e_dot + 3 * w * big_e, abs=1e-6), t
        assert cy == 0.0 and cz == 0.0
    assert abs(history[-1][1][0] - c) < 1e-3 * c  # settled within 60 s (8.4 / omega = 17 s to 2 %)


def test_a_steadily_changing_current_is_followed_without_lag():
    """A current growing at 7.5e-4 m/s^2 (the paper's helix climbing through a 0.015 1/s shear): after settling,
    c_hat equals it (the constant-current observer lags by 2 rate / omega, here 3e-3 m/s)."""
    rate = 7.5e-4
    history = observe(lambda t: (0.1 + rate * t, 0.0, 0.0), 120.0)
    t, (cx, _, _) = history[-1]
    assert cx == pytest.approx(0.1 + rate * t, abs=1e-6)


def test_the_controller_is_fed_the_estimate_in_body_axes_with_its_derivative():
    """feedforward: c = R' c_hat, c_dot = -omega x c + R' c_hat_dot, for a vehicle turning at r = 0.2 rad/s."""
    yaw = 0.7
    rot = [math.cos(yaw), -math.sin(yaw), 0.0, math.sin(yaw), math.cos(yaw), 0.0, 0.0, 0.0, 1.0]
    s = [0.0, 0.0, 0.0, *rot, 0.0, 0.0, 0.0, 0.0, 0.0, 0.2]
    o = [0.0, 0.0, 0.0, 0.3, 0.1, 0.0, 0.0, 0.0, 0.0]
    o_dot = [0.0, 0.0, 0.0, 0.01, -0.02, 0.0, 0.0, 0.0, 0.0]
    c, c_dot = feedforward(s, o, o_dot)
    r = np.array(rot).reshape(3, 3)
    want_c = r.T @ np.array([0.3, 0.1, 0.0])
    want_dot = -np.cross([0.0, 0.0, 0.2], want_c) + r.T @ np.array([0.01, -0.02, 0.0])
    np.testing.assert_allclose(c, want_c, atol=1e-15)
    np.testing.assert_allclose(c_dot, want_dot, atol=1e-15)


def errors(overrides: list[str]) -> tuple[float, float, float]:
    """(path error max after the transient, path error max over the last 50 s, coordination error max over the
    last 50 s) of the paper scenario so changed, in process."""
    path = ROOT / "configs" / "paper.toml"
    sc = parse_scenario(path.read_text(), str(path), overrides)
    quiet = Progress(sc.scenario.duration, io.StringIO(), enabled=False)
    series = run_inprocess(sc, "observer", "", None, sc.scenario.seed, quiet).series
    t, path_error = series.t, series.path_error
    coordination = coordination_error(series.gamma)
    last = t >= t[-1] - 50.0
    return (
        float(np.nanmax(path_error[t >= sc.report.transient])),
        float(np.nanmax(path_error[last])),
        float(np.nanmax(coordination[last])),
    )


CURRENTS = {
    "steady": ["environment.current=[0.3, 0.0, 0.0]"],
    "tide": ["environment.tide={amplitude = [0.3, 0.0, 0.0], period = 44712.0, phase_rad = 0.785}"],
    "shear": ["environment.shear=[0.015, 0.0]"],  # 0.3 m/s over 20 m: the helices climb 20 m in 400 s
}


@pytest.fixture(scope="module")
def still_water() -> tuple[float, float, float]:
    return errors([])


@pytest.mark.parametrize("case", sorted(CURRENTS))
def test_with_an_unknown_current_the_observer_gives_back_the_still_water_errors(still_water, case):
    estimated = errors(CURRENTS[case])
    for got, still in zip(estimated, still_water, strict=True):
        assert got <= 2.0 * still, (case, estimated, still_water)


def test_without_the_observer_the_unknown_current_stays_in_the_errors(still_water):
    """The test above can fail: the same steady current with the observer off."""
    blind = errors([*CURRENTS["steady"], "environment.estimate_current=off"])
    assert blind[2] > 10.0 * still_water[2], (blind, still_water)
