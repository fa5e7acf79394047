"""The water and the modem a scenario describes: the sound speed and the modem's parameters, for the channel
(supervisor.config.fleet) and for the analyses that need its timing (explain, stability)."""

from __future__ import annotations

from comms.channel.acoustics import mackenzie_sound_speed
from comms.channel.modem import ModemParams, modem
from comms.records.wire import message_size, wide_for
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


def message_bytes(scenario: Scenario) -> int:
    """The bytes of one coordination message on the water: comms.packet_bytes if given, else the encoded size of the
    fleet's message (comms.records.wire: 15 B, 16 B for a fleet with an id above 255)."""
    return scenario.comms.packet_bytes or message_size(wide_for(scenario.vehicle_ids))
