"""W-MSR (issue 29, item 3): law (5) over the neighbours a vehicle keeps after discarding up to F values above its own
gamma and F below (LeBlanc et al., IEEE JSAC 31(4), 2013), through the same extension interface as every built-in
law; with a vehicle that lies about its gamma (a gamma_offset fault) on a 3-robust graph the fleet's true gammas
still agree, where law (5) is pulled apart."""

from __future__ import annotations

import io
import re

import numpy as np
import pytest

from supervisor.analysis.summary import coordination_error
from supervisor.config.extensions import extension
from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from tests.conftest import CONFIGS, shortened
from vehicles.coordination import CoordinationGains, law5
from vehicles.resilient import Wmsr, kept

DURATION = 200.0
GAINS = CoordinationGains(k=0.2, k2=1.0, v_r=1.0)
COMPLETE5 = "[" + ", ".join(f"[{i}, {j}]" for i in range(1, 6) for j in range(i + 1, 6)) + "]"  # K5: 3-robust


def test_wmsr_discards_f_values_above_and_below_its_own():
    neighbours = [(10.0, 1.0), (1.2, 1.0), (0.9, 1.0), (-7.0, 1.0), (1.1, 1.0)]
    assert kept(1.0, neighbours, 1) == [(1.2, 1.0), (0.9, 1.0), (1.1, 1.0)]  # 10 above and -7 below gone
    assert kept(1.0, neighbours, 0) == neighbours
    assert kept(1.0, [(5.0, 1.0)], 2) == []  # fewer than f above: all of them
    law = Wmsr(f=1)
    assert law.correction(1.0, 1.0, neighbours, GAINS) == law5(1.0, 1.0, kept(1.0, neighbours, 1), GAINS, False)
    assert Wmsr(f=0).correction(1.0, 1.0, neighbours, GAINS) == law5(1.0, 1.0, neighbours, GAINS, False)


def test_wmsr_is_found_as_any_law_is():
    law = extension("law", "wmsr", {"f": 2})
    assert isinstance(law, Wmsr) and law.f == 2


def _honest_spread(law: str) -> float:
    """The largest disagreement of the true gammas over the last 20 s of 200 s (every gamma0 0: the bounded
    correction closes the start's 20 in about 100 s), vehicle 5 broadcasting gamma + 5 from 20 s on, on the complete
    graph of five vehicles."""
    text = shortened((CONFIGS / "inline5.toml").read_text(), DURATION)
    text = re.sub(r"(?m)^edges = .*$", f"edges = {COMPLETE5}", text, count=1)
    sets = [f"coordination.law={law}", "faults=[]", *(f"vehicles.{i}.gamma0=0.0" for i in range(5))]
    sets.append("vehicle.actuators=ideal")  # the law's test: inputs whose coordination closes the start in 100 s
    liar = [f"kind=gamma_offset,vehicle=5,offset=5.0,start=20,end={DURATION}"]
    scenario = parse_scenario(text, "inline5.toml", sets, liar)
    result = run_inprocess(scenario, "inline5.toml", text, None, 0, Progress(DURATION, io.StringIO(), enabled=False))
    t, error = result.series.t, coordination_error(result.series.gamma)
    return float(np.nanmax(error[t > DURATION - 20.0]))


@pytest.mark.parametrize(("law", "agrees"), [("wmsr", True), ("corrected", False)])
def test_a_lying_vehicle_does_not_pull_a_wmsr_fleet_apart(law, agrees):
    spread = _honest_spread(law)
    assert spread < 0.05 if agrees else spread > 1.0, spread
