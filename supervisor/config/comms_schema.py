"""The scenario's [comms] section: the acoustic channel between vehicles (comms/channel/channel.py), its loss models,
links, transmission policy and TDMA schedule. Re-exported by supervisor/config/scenario_schema.py.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, field_validator, model_validator

from comms.channel.modem import PRESETS as MODEMS
from supervisor.config.schema_base import (
    MAX_BYTES,
    MAX_COUNT,
    MAX_DELAY,
    MAX_FLEET,
    MAX_GAIN,
    MAX_GAMMA,
    MAX_LENGTH,
    MAX_TIME,
    ExtensionName,
    Float,
    Int,
    Probability,
    StrictModel,
    VehicleId,
    one_of,
)


class WaterSection(StrictModel):
    """Sound speed from Mackenzie's equation (valid for T 2-30 C, S 25-40 ppt, D 0-8000 m)."""

    temperature: Float = Field(ge=2, le=30, description="deg C")
    salinity: Float = Field(default=35.0, ge=25, le=40, description="ppt")
    depth: Float = Field(default=0.0, ge=0, le=8000, description="m")


class BurstSection(StrictModel):
    """Gilbert-Elliott loss given as its long-run loss rate and either its mean burst length in packets (the chain
    steps once per packet) or its mean burst duration in seconds (the chain runs in time: bursts last seconds
    whatever the packet rate)."""

    mean_loss: Float = Field(ge=0, lt=1, description="long-run share of packets lost")
    mean_burst: Float | None = Field(
        default=None, ge=1, le=1e6, description="mean number of packets lost in a row (per-packet chain)"
    )
    mean_duration: Float | None = Field(
        default=None,
        gt=0,
        le=MAX_TIME,
        description="s, mean duration of a burst (time-based chain), instead of mean_burst",
    )

    @model_validator(mode="after")
    def _one_burst_length(self) -> BurstSection:
        if (self.mean_burst is None) == (self.mean_duration is None):
            given = "neither" if self.mean_burst is None else "both"
            raise ValueError(f"give exactly one of mean_burst (packets) and mean_duration (s), {given} given")
        return self


class LinkBudgetSection(StrictModel):
    """Range-dependent loss from the link budget; carrier, bandwidth and modulation come from the modem."""

    type: Literal["link_budget"]
    source_level: Float = Field(ge=0, le=300, description="dB re 1 uPa at 1 m")
    spreading: Float = Field(default=1.5, ge=1, le=2, description="spreading exponent k (1 cylindrical, 2 spherical)")
    shipping: Float = Field(default=0.5, ge=0, le=1, description="shipping activity for the ambient noise (Coates)")
    wind: Float = Field(default=0.0, ge=0, le=100, description="wind speed for the ambient noise, m/s")
    directivity: Float = Field(default=0.0, ge=-100, le=100, description="directivity index added to the SNR, dB")
    shadowing: Float = Field(
        default=0.0, ge=0, le=30, description="log-normal shadowing: standard deviation in dB on the SNR; 0: none"
    )
    shadowing_time: Float = Field(
        default=0.0, ge=0, le=MAX_TIME,
        description="s, correlation time of a link's shadowing (Gauss-Markov); 0: a fresh draw per packet",
    )  # fmt: skip
    rician_k: Float | None = Field(
        default=None, ge=0, le=1000,
        description="fast fading per packet: Rician K factor (line-of-sight over scattered power), 0 for Rayleigh; "
        "omitted: no fast fading",
    )  # fmt: skip
    bits: Literal["frame", "message"] = Field(
        default="frame",
        description="bits the packet error counts: frame (every bit sent, padded to the modem's frames) or message "
        "(the packet's bytes alone, as before issue 16)",
    )
    ebn0: Literal["bitrate", "snr"] = Field(
        default="bitrate",
        description="Eb/N0 for the bit error: bitrate (SNR x bandwidth / bitrate, needs the modem's bitrate) or snr "
        "(Eb/N0 taken as the in-band SNR, as before issue 16)",
    )


class RangeTableSection(StrictModel):
    """Range-dependent loss from a table of packet success probability against range (m)."""

    type: Literal["table"]
    ranges: tuple[Annotated[Float, Field(ge=0, le=MAX_LENGTH)], ...] = Field(
        min_length=1, max_length=10_000, description="ranges, m, ascending"
    )
    success: tuple[Probability, ...] = Field(
        min_length=1, max_length=10_000, description="probability a packet arrives at each range"
    )


RangeSpec = Annotated[LinkBudgetSection | RangeTableSection, Field(discriminator="type")]


class LinkSection(StrictModel):
    """One directed link's own loss and extra delay (its loss and burst replace the fleet-wide ones)."""

    sender: VehicleId = Field(description="vehicle id")
    receiver: VehicleId = Field(description="vehicle id; sender -> receiver must be an edge of the graph")
    loss: Float | None = Field(default=None, ge=0, le=1, description="independent loss; omitted: comms.loss")
    burst: BurstSection | None = Field(default=None, description="bursty loss; omitted: comms.burst")
    extra_delay: Float = Field(default=0.0, ge=0, le=MAX_DELAY, description="added to every packet's delay, s")

    def losses(self, fleet_loss: float, fleet_burst: BurstSection | None) -> tuple[float, BurstSection | None]:
        """The link's loss and burst: its own where given, whatever their value (a loss of 0 too), the fleet's
        (comms.loss, comms.burst) where left out. The one rule the channel, the checks and the analysis take."""
        return (fleet_loss if self.loss is None else self.loss), (fleet_burst if self.burst is None else self.burst)


class TransmitSection(StrictModel):
    """When vehicles transmit: periodically, or when their gamma leaves what their neighbours predict."""

    policy: ExtensionName = Field(
        default="periodic",
        description="periodic: every period; event: when gamma leaves the prediction by h(t); an installed "
        "extension's name (`cpf plugins`), or package.module:Name (its options in `options`)",
    )
    options: dict[str, Any] = Field(
        default_factory=dict, description="an extension policy's own options (its fields); the built-ins use the keys "
        "below",
    )  # fmt: skip
    period: Float | None = Field(
        default=None,
        gt=0,
        le=MAX_TIME,
        description="periodic: s between messages, a whole number of steps; omitted: every step",
    )
    threshold: Float = Field(default=0.05, gt=0, le=MAX_GAMMA, description="event: c0 of h(t) = c0 + c1 exp(-alpha t)")
    threshold_decay: Float = Field(default=0.0, ge=0, le=MAX_GAMMA, description="event: c1")
    decay_rate: Float = Field(default=0.0, ge=0, le=MAX_GAIN, description="event: alpha, 1/s")
    min_interval: Float = Field(
        default=0.0, ge=0, le=MAX_TIME, description="event: s between messages at least, a whole number of steps"
    )
    heartbeat: Float | None = Field(
        default=None, gt=0, le=MAX_TIME, description="event: s between messages at most, a whole number of steps"
    )


class TdmaSection(StrictModel):
    """A TDMA schedule: each vehicle transmits only in its own slot; a frame is one slot per vehicle."""

    slot: Float = Field(
        gt=0,
        le=MAX_TIME,
        description="s, a whole number of steps; must hold a packet's airtime plus the longest propagation delay",
    )
    order: tuple[VehicleId, ...] | None = Field(
        default=None,
        max_length=MAX_FLEET,
        description="slot owners in order, every vehicle once; omitted: the ids as listed",
    )


class CommsSection(StrictModel):
    """The acoustic channel between vehicles (comms/channel/channel.py). Defaults: the ideal channel."""

    sound_speed: Annotated[Float, Field(ge=1000, le=2000)] | WaterSection = Field(
        default=1500.0, description="m/s (sea water: about 1450-1550), or water properties"
    )
    modem: str = Field(
        default="ideal", description="modem preset (cpf presets): bitrate, frames, duplex, carrier",
        json_schema_extra=one_of(MODEMS),
    )  # fmt: skip
    bitrate: Float | None = Field(default=None, ge=1, le=1e9, description="bit/s, overrides the modem's")
    preamble: Float | None = Field(default=None, ge=0, le=MAX_DELAY, description="s, overrides the modem's")
    frame_bytes: Int | None = Field(
        default=None, gt=0, le=MAX_BYTES, description="fixed frame size, B, overrides the modem's"
    )
    half_duplex: bool | None = Field(default=None, description="deaf while transmitting; overrides the modem's")
    collisions: bool | None = Field(default=None, description="overlapping packets lost; overrides the modem's")
    packet_bytes: Int | None = Field(
        default=None, gt=0, le=MAX_BYTES,
        description="B on air; omitted: the encoded message size (15 B; 16 B if an id is over 255)",
    )  # fmt: skip
    jitter: Float = Field(default=0.0, ge=0, le=MAX_DELAY, description="extra delay, uniform on [0, jitter], s")
    loss: Float = Field(default=0.0, ge=0, le=1, description="independent (Bernoulli) loss per directed link")
    burst: BurstSection | None = Field(default=None, description="bursty (Gilbert-Elliott) loss per directed link")
    range: RangeSpec | None = Field(default=None, description="range-dependent loss: type = link_budget or table")
    loss_model: ExtensionName | None = Field(
        default=None,
        description="a loss model of its own on every directed link, after range, loss and burst (a packet is lost "
        "if any of them loses it): an installed one's name (`cpf plugins`: bernoulli, gilbert_elliott, "
        "gilbert_elliott_time, link_budget, range_table) or package.module:Name; omitted: none",
    )
    loss_model_options: dict[str, Any] = Field(
        default_factory=dict, description="the loss model's own options (its fields, e.g. bernoulli: p)"
    )
    links: tuple[LinkSection, ...] = Field(
        default=(), max_length=MAX_COUNT, description="per directed link settings ([[comms.links]])"
    )
    transmit: TransmitSection = Field(default=TransmitSection(), description="when vehicles transmit")
    tdma: TdmaSection | None = Field(default=None, description="a TDMA schedule; omitted: transmit at will")
    reception: Literal["overlap", "sinr"] = Field(
        default="overlap",
        description="with collisions: overlap (any overlap at a receiver loses both) or sinr (capture: a packet "
        "survives when its SINR, overlapping packets counted as noise, reaches capture_threshold; needs range "
        "type = link_budget)",
    )
    capture_threshold: Float = Field(
        default=10.0, ge=-30, le=100, description="dB, the SINR a packet needs to survive overlaps (reception = sinr)"
    )
    stats_window: Float = Field(
        default=10.0, gt=0, le=MAX_TIME, description="s: link statistics and delivered lambda_2"
    )

    @field_validator("modem")
    @classmethod
    def _known_modem(cls, value: str) -> str:
        if value not in MODEMS:
            raise ValueError(f"unknown modem {value!r}, expected one of {sorted(MODEMS)}")
        return value
