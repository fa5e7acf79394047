"""vehicles.bounded_min is scipy's bounded Brent minimisation, operation for operation: the same x, bit for bit, on
smooth, flat, multi-modal and awkward functions over any interval, and through the nearest-point search on every
kind of path; and a start-up that searches the initial gammas no longer imports scipy.optimize."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

from tests.conftest import CONFIGS
from vehicles import nearest
from vehicles.bounded_min import bounded_minimum
from vehicles.nearest import closest_gamma, nearest_gamma
from vehicles.paths import Circle, Helix, Lawnmower, Line

FUNCTIONS = {
    "quadratic": lambda c: lambda x: (x - c) ** 2,
    "quartic": lambda c: lambda x: (x - c) ** 4 + 1e-3 * x,
    "cosine": lambda c: lambda x: math.cos(3.0 * x + c),
    "abs": lambda c: lambda x: abs(x - c),
    "flat": lambda c: lambda x: c,
    "step": lambda c: lambda x: 0.0 if x < c else 1.0,
    "distance": lambda c: lambda x: (20.0 * math.cos(x / 10 + c) - 3.0) ** 2 + (20.0 * math.sin(x / 10) + 1.0) ** 2,
}


def scipy_x(f, lo: float, hi: float, xatol: float, maxiter: int = 500) -> float:
    res = minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": xatol, "maxiter": maxiter})
    return float(res.x)


@settings(max_examples=400, deadline=None)
@given(
    st.sampled_from(sorted(FUNCTIONS)),
    st.floats(-50, 50),
    st.floats(-100, 100),
    st.floats(0, 200),
    st.sampled_from([1e-12, 1e-5, 0.1, 3.0]),
    st.sampled_from([500, 3]),
)
def test_the_same_x_as_scipy_bit_for_bit(name: str, c: float, lo: float, width: float, xatol: float, maxiter: int):
    f = FUNCTIONS[name](c)
    ours, theirs = bounded_minimum(f, lo, lo + width, xatol, maxiter), scipy_x(f, lo, lo + width, xatol, maxiter)
    assert ours == theirs or (math.isnan(ours) and math.isnan(theirs))
    assert type(ours) is float


def test_bad_bounds_are_refused_as_scipy_refuses_them():
    with pytest.raises(ValueError, match="finite"):
        bounded_minimum(abs, 0.0, math.inf, 1e-5)
    with pytest.raises(ValueError, match="exceeds"):
        bounded_minimum(abs, 1.0, 0.0, 1e-5)


LINE = Line((3.0, -2.0, 1.0), (0.3, -1.2, 0.05))
LAWNMOWER = Lawnmower((0.0, 0.0, -10.0), 100.0, 10.0, 4)
PATHS = [Helix(20.0, 0.05, 400.0, -2.356194490192345), Circle(15.0, 300.0, 0.5), LINE, LAWNMOWER]


@pytest.mark.parametrize("path", PATHS, ids=lambda p: type(p).__name__)
@settings(max_examples=40, deadline=None)
@given(point=st.lists(st.floats(-40, 40), min_size=3, max_size=3))
def test_the_nearest_point_search_is_unchanged(path, point):
    """closest_gamma and nearest_gamma as they were with scipy's minimize_scalar in them."""
    q = np.array(point)
    ours = (closest_gamma(path, q, -50.0, 350.0), nearest_gamma(path, q, 10.0))
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(nearest, "bounded_minimum", scipy_x)
        assert ours == (closest_gamma(path, q, -50.0, 350.0), nearest_gamma(path, q, 10.0))


def test_the_initial_gammas_are_found_without_scipy_optimize():
    """The supervisor's start-up path before it starts a vehicle: the paper scenario's gamma0 = "closest"."""
    code = (
        "import sys; from supervisor.config.scenario import load_scenario; from supervisor.config.fleet import "
        f"initial_gamma; from pathlib import Path; sc = load_scenario(Path({str(CONFIGS / 'paper.toml')!r})); "
        "print([initial_gamma(sc, v) for v in sc.vehicle_ids]); print('scipy.optimize' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split("\n")
    assert out[1] == "False"
