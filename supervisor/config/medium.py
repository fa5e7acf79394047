"""The water and the modem a scenario describes: the sound speed and the modem's parameters, for the channel
(supervisor.config.fleet) and for the analyses that need its timing (explain, stability)."""

from __future__ import annotations

from comms.channel.acoustics import mackenzie_sound_speed
from comms.channel.modem import ModemParams, modem
from supervisor.config.scenario_schema import Scenario, WaterSection


def sound_speed(scenario: Scenario) -> float:
    water = scenario.comms.sound_speed
    if isinstance(water, WaterSection):
        return mackenzie_sound_speed(water.temperature, water.salinity, water.depth)
    return float(water)


def modem_params(scenario: Scenario) -> ModemParams:
    c = scenario.comms
    return modem(
        c.modem, bitrate=c.bitrate, preamble=c.preamble, frame_bytes=c.frame_bytes,
        half_duplex=c.half_duplex, collisions=c.collisions,
    )  # fmt: skip
