"""supervisor.config.per_scenario: a fleet-wide value (the fitted coupling gain) worked out once per scenario, not
once per vehicle (a ring of 1000 AUVs spent 13 s of its start-up and 7 s of its summary on it), and never handed
to another scenario."""

from __future__ import annotations

import gc
import weakref

from benchmarks.bench_scaling import ring_scenario
from supervisor.config import fleet
from supervisor.config.per_scenario import per_scenario
from supervisor.config.scenario import parse_scenario
from supervisor.config.stability import scenario as stability
from tests.conftest import CONFIGS

SLOW = '\n[comms.transmit]\npolicy = "periodic"\nperiod = 1.0\n'  # k fitted to the links: the case that costs


def test_every_vehicle_of_a_fleet_gets_the_gain_worked_out_once(monkeypatch):
    calls = []
    real = stability.coupling_gain

    def counted(sc):
        calls.append(sc)
        return real(sc)

    monkeypatch.setattr(stability, "coupling_gain", counted)
    sc = parse_scenario(ring_scenario(12, 10.0) + SLOW, "ring.toml")
    ks = {fleet.vehicle_config(sc, vid).coordination.k for vid in sc.vehicle_ids}
    assert len(calls) == 1 and ks == {real(sc)}  # fitted (the analysis ran), and the same for all


def test_each_scenario_object_has_its_own_value_and_its_entry_goes_with_it():
    seen = []

    @per_scenario
    def name(sc):
        seen.append(sc.scenario.name)
        return sc.scenario.name

    text = (CONFIGS / "paper.toml").read_text()
    a, b = parse_scenario(text, "a.toml"), parse_scenario(text.replace('name = "paper"', 'name = "other"'), "b.toml")
    assert [name(a), name(b), name(a), name(b)] == ["paper", "other", "paper", "other"] and seen == ["paper", "other"]
    gone = weakref.ref(a)
    del a, b
    gc.collect()
    assert gone() is None  # the cache holds no scenario alive
    fresh = parse_scenario(text.replace('name = "paper"', 'name = "third"'), "c.toml")
    assert name(fresh) == "third" and seen == ["paper", "other", "third"]
