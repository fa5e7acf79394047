"""The link budget's issue-16 channel (comms.channel.link_budget, comms.channel.fading,
comms.channel.loss.GilbertElliottTime, SINR capture in comms.channel.channel): PER against range, the bits and Eb/N0 it
is computed on, shadowing and fading against their integrated mean, the time-based Gilbert-Elliott chain's bursts in
seconds, and capture of the stronger of two packets.

Statistical checks use fixed seeds and a 4-sigma tolerance computed from the model.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from comms.channel.acoustics import bit_error_rate, ebn0_db, packet_error_rate, snr_db
from comms.channel.channel import Capture, Channel, ChannelParams
from comms.channel.fading import gain_distribution, mean_over_gain
from comms.channel.link_budget import FadingLink, LinkBudgetRange
from comms.channel.loss import GilbertElliott, GilbertElliottTime
from comms.channel.modem import PRESETS
from comms.records.records import Kinematics, Transmission
from supervisor.config.fleet import channel_params
from supervisor.config.scenario import parse_scenario
from tests.test_loss import loss_runs

WHOI = PRESETS["whoi_micromodem_rate0"]
PLAIN = LinkBudgetRange(185.0, 25.0, 4000.0, "fsk", bitrate=80.0, frame_bytes=32)
FADED = LinkBudgetRange(185.0, 25.0, 4000.0, "fsk", bitrate=80.0, frame_bytes=32, shadowing_db=5.0, rician_k=2.0)


def per(model: LinkBudgetRange, distance_m: float, size: int = 15) -> float:
    return 1.0 - model.success_probability(distance_m, size)


def drawn_loss(model: LinkBudgetRange, distance_m: float, n: int, seed: int, dt: float = 1.0) -> float:
    link, rng = model.link(), np.random.default_rng(seed)
    return float(np.mean([link.decide(rng, distance_m, 15, k * dt) is not None for k in range(n)]))


# --- the closed form ----------------------------------------------------------------------------------------


def test_per_against_range_is_monotone_and_spans_zero_to_one() -> None:
    ranges = np.linspace(1.0, 30_000.0, 600)
    for model in (PLAIN, FADED):
        curve = np.array([1.0 - model.mean_success(r, 15) for r in ranges])
        assert np.all(np.diff(curve) >= -1e-12)
        assert curve[0] < 1e-9 and curve[-1] > 1 - 1e-9


def test_the_packet_error_counts_every_bit_of_the_padded_frame_at_eb_n0_from_the_bitrate() -> None:
    """A 15-B message on WHOI rate 0 is one 32-B frame: 256 bits, at Eb/N0 = SNR + 10 log10(4000 / 80) = SNR + 17 dB."""
    d = 12_000.0
    ebn0 = snr_db(185.0, d, 25.0, 4000.0) + 10.0 * math.log10(50.0)
    assert ebn0_db(snr_db(185.0, d, 25.0, 4000.0), 4000.0, 80.0) == pytest.approx(ebn0)
    expected = packet_error_rate(bit_error_rate(ebn0, "fsk"), 256)
    assert 0.2 < expected < 0.98  # a range where the bit count matters
    assert per(PLAIN, d) == pytest.approx(expected, rel=1e-12)
    assert (
        PLAIN.bits(15) == 256 and PLAIN.bits(33) == 512 and LinkBudgetRange(185.0, 25.0, 4000.0, "fsk").bits(15) == 120
    )


def test_a_scenario_link_budget_takes_the_modems_frames_and_bitrate_unless_told_the_old_way() -> None:
    text = (
        "[scenario]\nname = 'x'\nduration = 10.0\nstep = 0.1\n[vehicle]\npreset = 'remus100'\n"
        "[path_following]\ndelta = -1.0\nk1 = 0.5\nk2 = 1.0\nk_zeta = 1.0\n[graph]\nedges = [[1, 2]]\n"
        "[[vehicles]]\nid = 1\nposition = [0.0, 0.0, 0.0]\npath = { type = 'circle', radius = 20.0, period = 400.0 }\n"
        "[[vehicles]]\nid = 2\nposition = [5.0, 0.0, 0.0]\npath = { type = 'circle', radius = 15.0, period = 400.0 }\n"
        "[comms]\nmodem = 'whoi_micromodem_rate0'\nrange = { type = 'link_budget', source_level = 185.0 OLD }\n"
        "[comms.tdma]\nslot = 4.0\n"  # a slot holds a packet (3.2 s on air): a channel that can deliver
    )
    new = channel_params(parse_scenario(text.replace(" OLD", ""), "x.toml")).loss
    old = channel_params(parse_scenario(text.replace(" OLD", ", bits = 'message', ebn0 = 'snr'"), "x.toml")).loss
    assert new is not None and old is not None
    (new_budget,), (old_budget,) = new.models, old.models  # type: ignore[attr-defined]
    assert per(new_budget, 12_000.0) == pytest.approx(per(PLAIN, 12_000.0), rel=1e-12)
    old_expected = packet_error_rate(bit_error_rate(snr_db(185.0, 9_300.0, 25.0, 4000.0), "fsk"), 120)
    assert per(old_budget, 9_300.0) == pytest.approx(old_expected, rel=1e-12)


def test_without_fading_the_drawn_loss_matches_the_closed_form() -> None:
    d, n = 11_900.0, 20_000
    p = per(PLAIN, d)
    assert 0.2 < p < 0.8
    assert abs(drawn_loss(PLAIN, d, n, seed=3) - p) < 4 * math.sqrt(p * (1 - p) / n)
    assert PLAIN.mean_success(d, 15) == PLAIN.success_probability(d, 15)


# --- shadowing and fading -----------------------------------------------------------------------------------


def test_the_gain_distribution_integrates_known_closed_forms() -> None:
    """Rayleigh power gain g ~ Exp(1): E[g] = 1 and E[exp(-a g)] = 1 / (1 + a); shadowing alone: N(0, sigma^2) dB."""

    def linear(gains: np.ndarray) -> np.ndarray:
        return np.power(10.0, gains / 10.0)

    assert mean_over_gain(linear, 0.0, 0.0) == pytest.approx(1.0, rel=1e-3)
    assert mean_over_gain(linear, 0.0, 3.0) == pytest.approx(1.0, rel=1e-3)  # Rician keeps the mean power
    for a in (0.1, 1.0, 10.0):

        def laplace(gains: np.ndarray, a: float = a) -> np.ndarray:
            return np.exp(-a * linear(gains))

        assert mean_over_gain(laplace, 0.0, 0.0) == pytest.approx(1 / (1 + a), rel=1e-3)
    offsets, masses = gain_distribution(4.0, None)
    assert np.dot(masses, offsets) == pytest.approx(0.0, abs=1e-9)
    assert np.dot(masses, offsets**2) == pytest.approx(16.0, rel=1e-3)


@pytest.mark.parametrize("model", [FADED, LinkBudgetRange(185.0, 25.0, 4000.0, "fsk", bitrate=80.0, rician_k=0.0)])
@pytest.mark.parametrize("distance", [9_000.0, 11_000.0, 13_000.0])
def test_with_fading_the_mean_drawn_loss_matches_the_integrated_expectation(
    model: LinkBudgetRange, distance: float
) -> None:
    n = 20_000
    p = 1.0 - model.mean_success(distance, 15)
    assert 0.005 < p < 0.995  # the curve's slope, where fading matters
    assert abs(drawn_loss(model, distance, n, seed=int(distance)) - p) < 4 * math.sqrt(p * (1 - p) / n) + 1e-4


def test_fading_smooths_the_cliff() -> None:
    """Between 1 % and 99 % loss: under a kilometre without fading, several with it."""
    ranges = np.linspace(5_000.0, 20_000.0, 1500)

    def width(model: LinkBudgetRange) -> float:
        curve = np.array([1.0 - model.mean_success(r, 15) for r in ranges])
        return float(ranges[np.argmax(curve > 0.99)] - ranges[np.argmax(curve > 0.01)])

    assert width(PLAIN) < 1_000.0 and width(FADED) > 4_000.0


def test_shadowing_is_correlated_over_its_correlation_time_on_one_link() -> None:
    model = LinkBudgetRange(185.0, 25.0, 4000.0, "fsk", shadowing_db=6.0, shadowing_time=20.0)
    link, rng = model.link(), np.random.default_rng(5)
    assert isinstance(link, FadingLink)
    shadows = []
    for k in range(20_000):
        link.decide(rng, 1000.0, 15, 2.0 * k)  # a packet every 2 s: rho = exp(-2 / 20)
        assert link.shadow_db is not None
        shadows.append(link.shadow_db)
    x = np.array(shadows)
    assert np.std(x) == pytest.approx(6.0, rel=0.05)
    rho = float(np.corrcoef(x[:-1], x[1:])[0, 1])
    assert rho == pytest.approx(math.exp(-0.1), abs=0.02)


@pytest.mark.parametrize("model", [FADED, LinkBudgetRange(185.0, 25.0, 4000.0, "fsk", shadowing_db=3.0)])
def test_a_fading_link_consumes_exactly_its_draws(model: LinkBudgetRange) -> None:
    link, rng, parallel = model.link(), np.random.default_rng(1), np.random.default_rng(1)
    assert model.draws == 1 + 2 * (model.shadowing_db > 0) + 2 * (model.rician_k is not None)
    for k in range(100):
        link.decide(rng, 10_000.0 + 50 * k, 15, float(k))
        parallel.random(model.draws)
    assert rng.random() == parallel.random()


# --- time-based Gilbert-Elliott ------------------------------------------------------------------------------


def burst_seconds(model: GilbertElliott | GilbertElliottTime, dt: float, n: int, seed: int) -> tuple[float, float]:
    """(mean duration of a run of losses in s, long-run loss) with a packet every dt s."""
    link, rng = model.link(), np.random.default_rng(seed)
    lost = np.array([link.decide(rng, 100.0, 15, k * dt) is not None for k in range(n)])
    return float(np.mean(loss_runs(lost))) * dt, float(lost.mean())


@pytest.mark.parametrize("dt", [0.1, 1.0, 10.0])
def test_time_based_bursts_last_the_stated_seconds_whatever_the_packet_rate(dt: float) -> None:
    """Mean loss 0.2, bursts of 5 s. Sampled every dt, a run of losses lasts dt / (1 - P(bad | bad after dt)) s,
    which tends to 5 s as dt -> 0 (the sampling can only see whole packets); the per-packet chain's bursts instead
    last 5 packets = 5 dt s."""
    model, n = GilbertElliottTime(0.2, 5.0), 60_000
    seconds, loss = burst_seconds(model, dt, n, seed=11)
    p_stay = 0.2 + 0.8 * math.exp(-model.rate * dt)
    expected = dt / (1.0 - p_stay)
    assert seconds == pytest.approx(expected, rel=0.1)
    assert 5.0 <= expected <= 5.0 + dt  # the stated 5 s, up to one packet interval of sampling
    assert loss == pytest.approx(0.2, abs=0.03)
    per_packet, _ = burst_seconds(GilbertElliott(0.2, 5.0), dt, n, seed=11)
    assert per_packet == pytest.approx(5.0 * dt, rel=0.1)


def test_time_based_chain_forgets_its_state_after_long_silences() -> None:
    """Packets a day apart: each one's state is a fresh stationary draw, so losses are independent at the mean."""
    link, rng = GilbertElliottTime(0.3, 5.0).link(), np.random.default_rng(2)
    lost = np.array([link.decide(rng, 1.0, 15, k * 86_400.0) is not None for k in range(20_000)])
    assert lost.mean() == pytest.approx(0.3, abs=0.015)
    assert abs(float(np.corrcoef(lost[:-1], lost[1:])[0, 1])) < 0.03


# --- SINR capture ----------------------------------------------------------------------------------------------


def collide(capture: Capture | None, far_m: float) -> dict[int, str]:
    """Vehicles 1 (100 m from 3) and 2 (far_m from 3) transmit at the same instant to 3: each one's fate at 3."""
    radio = WHOI  # 3.2 s on air: the packets overlap at 3 whatever the 1.3 s difference in flight
    channel = Channel(ChannelParams(modem=radio, capture=capture), seed=0)
    here = {1: (100.0, 0.0, 0.0), 2: (-far_m, 0.0, 0.0), 3: (0.0, 0.0, 0.0)}
    everyone = {i: Kinematics(np.array(p), np.zeros(3)) for i, p in here.items()}
    for sender in (1, 2):
        tx = Transmission(sender, 0, 0.0, 0.0, 0.0, here[sender], (0.0, 0.0, 0.0))
        channel.transmit(tx, 15, {3}, everyone)
    _, events = channel.deliver(100.0)
    return {e.sender: e.kind if e.kind == "delivered" else str(e.reason) for e in events}


CAPTURE = Capture(LinkBudgetRange(170.0, 25.0, 5000.0, "bpsk"), threshold_db=10.0)


def test_capture_delivers_the_stronger_of_two_overlapping_packets_when_its_sinr_allows() -> None:
    assert collide(None, 2000.0) == {1: "collision", 2: "collision"}  # any overlap loses both
    assert collide(CAPTURE, 2000.0) == {1: "delivered", 2: "collision"}  # 1.5 * 10 log10(20) = 19.5 dB above
    assert collide(CAPTURE, 150.0) == {1: "collision", 2: "collision"}  # 2.6 dB apart: below the 10 dB threshold


def test_capture_counts_the_noise_too() -> None:
    """With a source level that leaves the stronger packet less than the threshold above the noise, its SINR is
    limited by the noise and it is lost as well, however weak the other."""
    quiet = Capture(LinkBudgetRange(95.0, 25.0, 5000.0, "bpsk"), threshold_db=10.0)
    level = quiet.budget.received_level_db(100.0) - quiet.budget.noise_level_db()
    assert level < 10.0
    assert collide(quiet, 2000.0) == {1: "collision", 2: "collision"}
