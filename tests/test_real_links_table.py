"""The README's slow-links table ("Coordination on slow links", scripts/real_links_study.py) held to its printed
digits, cell by cell for the rows a reader compares: the defaults every 10 and 30 s (with the paper's fault and
without), 30 s with 8 s on air, and the former defaults' divergence. A run is deterministic: a change that moves a
cell fails here, not only when someone re-runs the study (a new user's audit found the table held by the script
alone)."""

from __future__ import annotations

import pytest

from supervisor.config.scenario import parse_scenario
from supervisor.tools.stability_check import simulate
from tests.conftest import CONFIGS

PAPER = CONFIGS / "paper.toml"
FORMER = ["coordination.predictor=first_order", "coordination.schedule=none", "saturation.correction=none"]


def measured(*overrides: str) -> tuple[float, float]:
    """(coordination error over the last 50 s, path error after the transient), as the study measures them."""
    outcome = simulate(parse_scenario(PAPER.read_text(), str(PAPER), list(overrides)))
    return outcome.last, outcome.path_error


@pytest.mark.parametrize(
    ("overrides", "coordination", "path"),
    [
        (["comms.transmit.period=10"], 0.00271, 1.17),
        (["comms.transmit.period=30"], 0.322, 1.17),
        (["comms.transmit.period=30", "faults=[]"], 0.00273, 1.06),
        (["comms.transmit.period=30", "comms.bitrate=15"], 0.692, 1.17),
    ],
)
def test_the_defaults_rows(overrides, coordination, path):
    last, path_error = measured(*overrides)
    assert float(f"{last:.3g}") == coordination and float(f"{path_error:.3g}") == path


def test_the_former_defaults_diverge_every_30_s():
    last, path_error = measured("comms.transmit.period=30", *FORMER)
    assert float(f"{last:.3g}") == 322 and float(f"{path_error:.3g}") == 37.5
