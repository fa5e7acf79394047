"""Sound speed, absorption, transmission loss, noise, SNR and bit/packet errors (comms.channel.acoustics).

Check values: Mackenzie (1981) publishes 1550.744 m/s at 25 C, 35 ppt, 1000 m; the others are recomputed here from
the formulas in shared/reference/acoustics.md by an independent (numpy/scipy) code path.
"""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
import pytest
from scipy.stats import norm

from comms.channel.acoustics import (
    bit_error_rate,
    mackenzie_sound_speed,
    noise_psd_db,
    packet_error_rate,
    snr_db,
    thorp_absorption_db_per_km,
    transmission_loss_db,
)


def test_mackenzie_published_check_value() -> None:
    assert mackenzie_sound_speed(25.0, 35.0, 1000.0) == pytest.approx(1550.744, abs=1e-3)


def test_mackenzie_at_10c_35ppt_10m() -> None:
    # By the 9-term formula: 1448.96 + 45.91 - 5.304 + 0.2374 + 0.163 + 1.675e-5 - 7.1e-9 = 1489.966 m/s
    # (the reference file's "about 1483.8" does not follow from its own formula).
    assert mackenzie_sound_speed(10.0, 35.0, 10.0) == pytest.approx(1489.9664167, abs=1e-6)


def test_mackenzie_increases_with_temperature_salinity_and_depth() -> None:
    base = mackenzie_sound_speed(10.0, 35.0, 100.0)
    assert mackenzie_sound_speed(11.0, 35.0, 100.0) > base
    assert mackenzie_sound_speed(10.0, 36.0, 100.0) > base
    assert mackenzie_sound_speed(10.0, 35.0, 200.0) > base


def thorp_exact(f: float) -> float:
    return 0.11 * f**2 / (1 + f**2) + 44 * f**2 / (4100 + f**2) + 2.75e-4 * f**2 + 0.003


@pytest.mark.parametrize(("f_khz", "approx_db_km"), [(10.0, 1.2), (25.0, 6.1)])
def test_thorp_reference_values(f_khz: float, approx_db_km: float) -> None:
    alpha = thorp_absorption_db_per_km(f_khz)
    assert alpha == pytest.approx(approx_db_km, abs=0.05)
    assert alpha == pytest.approx(thorp_exact(f_khz), rel=1e-12)


def test_thorp_exact_numbers() -> None:
    # By hand: 11/101 + 4400/4200 + 0.0275 + 0.003 and 68.75/626 + 27500/4725 + 0.171875 + 0.003.
    assert thorp_absorption_db_per_km(10.0) == pytest.approx(11 / 101 + 4400 / 4200 + 0.0305, rel=1e-12)
    assert thorp_absorption_db_per_km(25.0) == pytest.approx(68.75 / 626 + 27500 / 4725 + 0.174875, rel=1e-12)


def test_thorp_rejects_nonpositive_frequency() -> None:
    with pytest.raises(ValueError, match="f_khz"):
        thorp_absorption_db_per_km(0.0)


def test_transmission_loss_monotone_in_distance_and_frequency() -> None:
    distances = [1.0, 10.0, 100.0, 1000.0, 5000.0, 20000.0]
    for f in (5.0, 25.0):
        losses = [transmission_loss_db(d, f) for d in distances]
        assert all(a < b for a, b in pairwise(losses))
    freqs = [1.0, 5.0, 10.0, 25.0, 50.0]
    losses = [transmission_loss_db(2000.0, f) for f in freqs]
    assert all(a < b for a, b in pairwise(losses))


def test_transmission_loss_value_and_clamp_below_one_metre() -> None:
    expected = 1.5 * 10 * math.log10(2000.0) + 2.0 * thorp_exact(25.0)
    assert transmission_loss_db(2000.0, 25.0) == pytest.approx(expected, rel=1e-12)
    assert transmission_loss_db(2000.0, 25.0, spreading=2.0) == pytest.approx(expected + 5 * math.log10(2000.0))
    one_metre = thorp_exact(25.0) / 1000.0  # spreading term vanishes at the 1 m reference
    assert transmission_loss_db(1.0, 25.0) == pytest.approx(one_metre, rel=1e-12)
    assert transmission_loss_db(0.0, 25.0) == transmission_loss_db(0.3, 25.0) == transmission_loss_db(1.0, 25.0)
    with pytest.raises(ValueError, match="distance_m"):
        transmission_loss_db(-1.0, 25.0)


def coates(f: np.ndarray, s: float, w: float) -> np.ndarray:
    lf = np.log10(f)
    parts = (
        17 - 30 * lf,
        40 + 20 * (s - 0.5) + 26 * lf - 60 * np.log10(f + 0.03),
        50 + 7.5 * np.sqrt(w) + 20 * lf - 40 * np.log10(f + 0.4),
        -15 + 20 * lf,
    )
    return np.asarray(10 * np.log10(sum(10 ** (p / 10) for p in parts)))


def test_noise_matches_coates_power_sum() -> None:
    f = np.array([0.5, 1.0, 10.0, 25.0, 70.0])
    for s, w in [(0.0, 0.0), (0.5, 0.0), (1.0, 10.0)]:
        ours = [noise_psd_db(float(x), s, w) for x in f]
        np.testing.assert_allclose(ours, coates(f, s, w), rtol=0, atol=1e-10)


def test_noise_falls_with_frequency_until_thermal_noise_takes_over() -> None:
    f = np.logspace(0, 2, 201)  # 1-100 kHz
    calm = np.array([noise_psd_db(float(x), 0.5, 0.0) for x in f])
    low = f <= 40.0
    assert np.all(np.diff(calm[low]) < 0)
    # With no wind, thermal noise (+20 dB/decade) wins above about 42 kHz: the minimum is there, not at 100 kHz.
    assert 40.0 < f[np.argmin(calm)] < 44.0
    assert np.all(np.diff(calm[f >= 44.0]) > 0)
    windy = np.array([noise_psd_db(float(x), 0.5, 5.0) for x in f])
    assert np.all(np.diff(windy) < 0)


def test_noise_increases_with_shipping_and_wind() -> None:
    for f in (0.1, 1.0, 10.0):
        levels = [noise_psd_db(f, s, 0.0) for s in (0.0, 0.5, 1.0)]
        assert levels[0] < levels[1] < levels[2]
    for f in (1.0, 10.0, 50.0):
        levels = [noise_psd_db(f, 0.5, w) for w in (0.0, 5.0, 15.0)]
        assert levels[0] < levels[1] < levels[2]


def test_noise_rejects_bad_parameters() -> None:
    with pytest.raises(ValueError, match="shipping"):
        noise_psd_db(10.0, shipping=1.5)
    with pytest.raises(ValueError, match="wind_m_s"):
        noise_psd_db(10.0, wind_m_s=-1.0)
    with pytest.raises(ValueError, match="f_khz"):
        noise_psd_db(-10.0)


def test_snr_falls_with_distance_and_adds_directivity() -> None:
    snrs = [snr_db(185.0, d, 25.0, 5000.0, 1.5, 0.5, 0.0) for d in (10.0, 100.0, 1000.0, 5000.0, 10000.0)]
    assert all(a > b for a, b in pairwise(snrs))
    assert snr_db(185.0, 1000.0, 25.0, 5000.0, 1.5, 0.5, 0.0, directivity_db=3.0) == pytest.approx(snrs[2] + 3.0)
    with pytest.raises(ValueError, match="bandwidth_hz"):
        snr_db(185.0, 1000.0, 25.0, 0.0)


def test_bpsk_ber_at_9_6_db_is_about_1e_5() -> None:
    ber = bit_error_rate(9.6, "bpsk")
    assert ber == pytest.approx(1e-5, rel=0.05)
    assert ber == pytest.approx(norm.sf(math.sqrt(2 * 10**0.96)), rel=1e-9)  # Q(sqrt(2 Eb/N0))


def test_fsk_ber_closed_form_and_worse_than_bpsk() -> None:
    assert bit_error_rate(10.0, "fsk") == pytest.approx(0.5 * math.exp(-5.0), rel=1e-12)
    assert bit_error_rate(0.0, "fsk") == pytest.approx(0.5 * math.exp(-0.5), rel=1e-12)
    for snr in (0.0, 5.0, 10.0):
        assert bit_error_rate(snr, "fsk") > bit_error_rate(snr, "bpsk")
    with pytest.raises(ValueError, match="modulation"):
        bit_error_rate(10.0, "qam")  # type: ignore[arg-type]


@pytest.mark.parametrize(("ber", "bits"), [(0.0, 256), (1e-3, 256), (0.01, 100), (0.5, 8), (1.0, 8), (0.3, 0)])
def test_per_matches_closed_form(ber: float, bits: int) -> None:
    assert packet_error_rate(ber, bits) == pytest.approx(1 - (1 - ber) ** bits, rel=1e-12, abs=1e-15)


def test_per_is_stable_for_tiny_ber_and_many_bits() -> None:
    # The naive 1 - (1 - 1e-12)^256 loses most digits to cancellation; n p - (n p)^2 / 2 is exact to ~1e-30 here.
    np_ = 256 * 1e-12
    assert packet_error_rate(1e-12, 256) == pytest.approx(np_ - np_**2 / 2, rel=1e-12)
    assert packet_error_rate(1e-20, 8) == pytest.approx(8e-20, rel=1e-12)
    assert packet_error_rate(1e-9, 10**9) == pytest.approx(-math.expm1(-1.0), rel=1e-8)  # -> 1 - 1/e
    assert packet_error_rate(1e-3, 10**7) == 1.0
    with pytest.raises(ValueError, match="ber"):
        packet_error_rate(1.5, 8)
    with pytest.raises(ValueError, match="bits"):
        packet_error_rate(0.1, -1)


def test_worked_link_budget_32_bytes_25_khz_185_db() -> None:
    """A 32-byte BPSK packet at 25 kHz, 5 kHz bandwidth, 185 dB re 1 uPa source, 9.5 km, k = 1.5, s = 0.5, calm.

    Worked numbers: TL = 15 log10(9500) + 9.5 x 6.1048 = 59.665 + 57.996 = 117.662 dB; NL = 22.307 dB re uPa^2/Hz;
    10 log10(5000) = 36.990; SNR = 185 - 117.662 - 22.307 - 36.990 = 8.042 dB; BER = 1.789e-4;
    PER = 1 - (1 - BER)^256 = 0.0448.
    """
    snr = snr_db(185.0, 9500.0, 25.0, 5000.0, 1.5, 0.5, 0.0)
    ber = bit_error_rate(snr, "bpsk")
    per = packet_error_rate(ber, 8 * 32)
    assert snr == pytest.approx(8.042, abs=1e-3)
    assert ber == pytest.approx(1.789e-4, rel=1e-3)
    assert per == pytest.approx(0.0448, abs=1e-4)
    # Independent path: numpy Coates, Q function from scipy.stats, plain power for the PER.
    tl = 15 * np.log10(9500.0) + 9.5 * thorp_exact(25.0)
    own_snr = 185.0 - tl - coates(np.array([25.0]), 0.5, 0.0)[0] - 10 * np.log10(5000.0)
    own_ber = norm.sf(np.sqrt(2 * 10 ** (own_snr / 10)))
    assert snr == pytest.approx(own_snr, abs=1e-9)
    assert ber == pytest.approx(own_ber, rel=1e-9)
    assert per == pytest.approx(1 - (1 - own_ber) ** 256, rel=1e-9)
