"""From a validated Scenario to what the broker process serves the channel with (comms.broker.broker_start).

The supervisor builds it for the broker it starts (and hands it over in a private file); a broker started by hand
builds its own from the scenario file. Either way from here, so both start identically.
"""

from __future__ import annotations

from comms.broker.broker_start import BrokerStart
from supervisor.config.fleet import broker_core
from supervisor.config.plausibility import plausibility
from supervisor.config.scenario_digest import hello
from supervisor.config.scenario_schema import Scenario


def broker_start(scenario: Scenario, seed: int) -> BrokerStart:
    """The broker of a run with this seed: a fresh channel (a restarted broker starts afresh too)."""
    greeting = hello("comms broker", scenario, seed)
    core = broker_core(scenario, seed)
    core.plausible = plausibility(scenario)  # the states it lets into the channel: what the intake records
    return BrokerStart(core, tuple(scenario.vehicle_ids), scenario.scenario.step, greeting)
