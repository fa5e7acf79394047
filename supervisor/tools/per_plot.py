"""Packet error against range for the modem presets (`cpf per`): the link budget's closed form without fading, the
numerically integrated mean with shadowing and fading, and the mean of the channel's own draws at a few ranges
(with a 2-sigma bar), so a figure shows that the simulated links lose what the closed form says they should.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from comms.channel.link_budget import LinkBudgetRange
from comms.channel.modem import PRESETS, ModemParams
from supervisor.analysis.figures import colour, new_figure, save

MAX_RANGE_M = 200_000.0  # the search for where a preset's link dies stops here
CURVE_POINTS = 120
DRAW_RANGES = 12


@dataclass(frozen=True, slots=True)
class Channel:
    """What the figure is drawn for (units as in comms.channel.link_budget.LinkBudgetRange)."""

    source_level_db: float = 185.0
    size_bytes: int = 15
    shadowing_db: float = 4.0
    rician_k: float | None = 1.0
    spreading: float = 1.5
    draws: int = 2000
    seed: int = 0


def budget(modem: ModemParams, channel: Channel, fading: bool) -> LinkBudgetRange:
    """The link budget a scenario with this modem and `range = { type = "link_budget", ... }` would build."""
    return LinkBudgetRange(
        channel.source_level_db, modem.frequency_khz, modem.bandwidth_hz, modem.modulation, channel.spreading,
        bitrate=modem.bitrate, frame_bytes=modem.frame_bytes,
        shadowing_db=channel.shadowing_db if fading else 0.0, rician_k=channel.rician_k if fading else None,
    )  # fmt: skip


def edge_of_coverage(model: LinkBudgetRange, size_bytes: int) -> float:
    """The range (m) where the closed-form PER reaches 0.5, by bisection on the monotone curve."""
    low, high = 1.0, MAX_RANGE_M
    if 1.0 - model.success_probability(high, size_bytes) < 0.5:
        return high
    for _ in range(60):
        mid = math.sqrt(low * high)
        low, high = (mid, high) if 1.0 - model.success_probability(mid, size_bytes) < 0.5 else (low, mid)
    return high


def drawn_per(model: LinkBudgetRange, distance_m: float, channel: Channel) -> float:
    """The share of `draws` packets the model's link loses at distance_m (its own random stream)."""
    link, rng = model.link(), np.random.default_rng([channel.seed, round(distance_m)])
    lost = sum(link.decide(rng, distance_m, channel.size_bytes, float(k)) is not None for k in range(channel.draws))
    return lost / channel.draws


def plot_per(names: Sequence[str], channel: Channel, out: Path) -> Path:
    """One panel per modem preset: PER against range in km."""
    cols = min(3, len(names))
    rows = math.ceil(len(names) / cols)
    fig = new_figure(4.2 * cols, 3.4 * rows)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax, name in zip(axes, names, strict=False):
        _panel(ax, name, channel)
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    k = (
        "none"
        if channel.rician_k is None
        else ("Rayleigh" if channel.rician_k == 0 else f"Rician K = {channel.rician_k:g}")
    )
    fig.suptitle(
        f"PER of a {channel.size_bytes}-B packet, SL {channel.source_level_db:g} dB, spreading "
        f"{channel.spreading:g}; shadowing {channel.shadowing_db:g} dB, fading {k}"
    )
    return save(fig, out)


def _panel(ax: object, name: str, channel: Channel) -> None:
    from matplotlib.axes import Axes

    assert isinstance(ax, Axes)
    plain, faded = budget(PRESETS[name], channel, False), budget(PRESETS[name], channel, True)
    edge = edge_of_coverage(plain, channel.size_bytes)
    ranges = np.linspace(0.3 * edge, 1.6 * edge, CURVE_POINTS)
    closed = [1.0 - plain.success_probability(r, channel.size_bytes) for r in ranges]
    mean = [1.0 - faded.mean_success(r, channel.size_bytes) for r in ranges]
    ax.plot(ranges / 1000, closed, "--", color="0.4", label="closed form, no fading")
    ax.plot(ranges / 1000, mean, color=colour(0), label="mean with fading (integrated)")
    if faded.fading:
        at = np.linspace(0.4 * edge, 1.5 * edge, DRAW_RANGES)
        drawn = np.array([drawn_per(faded, r, channel) for r in at])
        bar = 2.0 * np.sqrt(drawn * (1.0 - drawn) / channel.draws)
        ax.errorbar(at / 1000, drawn, yerr=bar, fmt="o", ms=3, color=colour(1), label=f"{channel.draws} draws each")
    ax.set(title=name, xlabel="range [km]", ylabel="packet error rate", ylim=(-0.03, 1.03))
    ax.grid(alpha=0.3)
    ax.legend(fontsize="x-small", loc="lower right")


def modem_names(chosen: Sequence[str]) -> list[str]:
    """The presets asked for (every one with a bitrate when none is named); ValueError for an unknown name."""
    for name in chosen:
        if name not in PRESETS:
            raise ValueError(f"--modem: unknown modem {name!r}, expected one of {sorted(PRESETS)}")
    return list(chosen) or [name for name, m in PRESETS.items() if m.bitrate is not None]
