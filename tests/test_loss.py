"""Packet loss models (comms.channel.loss): rates, burstiness, stream alignment, range dependence and validation.

Statistical checks use fixed seeds and a 4-sigma tolerance computed from the model (for Gilbert-Elliott the variance
of a Markov-chain mean is inflated by (1 + rho) / (1 - rho), rho = 1 - p - r the chain's lag-1 autocorrelation).
"""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
import pytest

from comms.channel.acoustics import bit_error_rate, packet_error_rate, snr_db
from comms.channel.loss import Bernoulli, Composite, GilbertElliott, LinkBudgetRange, LinkLoss, LossModel, RangeTable

N = 200_000
BUDGET = LinkBudgetRange(source_level_db=185.0, frequency_khz=25.0, bandwidth_hz=5000.0, modulation="bpsk")
TABLE = RangeTable(ranges_m=(100.0, 500.0, 1000.0), success=(1.0, 0.8, 0.2))


def lost(model: LossModel, n: int, seed: int, distance_m: float = 1000.0, size_bytes: int = 32) -> np.ndarray:
    link, rng = model.link(), np.random.default_rng(seed)
    return np.array([link.decide(rng, distance_m, size_bytes) is not None for _ in range(n)])


def lag1_autocorrelation(x: np.ndarray) -> float:
    y = x.astype(float) - x.mean()
    return float(np.dot(y[:-1], y[1:]) / np.dot(y, y))


def loss_runs(x: np.ndarray) -> np.ndarray:
    """Lengths of runs of consecutive losses, leaving out runs cut by either end of the record."""
    edges = np.diff(np.concatenate(([0], x.astype(int), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    keep = (starts > 0) & (ends < len(x))
    return np.asarray(ends[keep] - starts[keep])


def test_bernoulli_rate_within_4_sigma() -> None:
    p = 0.2
    x = lost(Bernoulli(p), N, seed=1)
    assert abs(x.mean() - p) < 4 * math.sqrt(p * (1 - p) / N)
    assert abs(lag1_autocorrelation(x)) < 4 / math.sqrt(N)  # independent: ~0


def test_bernoulli_extremes() -> None:
    assert not lost(Bernoulli(0.0), 1000, seed=2).any()
    assert lost(Bernoulli(1.0), 1000, seed=2).all()


@pytest.mark.parametrize(("mean_loss", "mean_burst"), [(0.1, 10.0), (0.3, 3.0), (0.05, 1.5)])
def test_gilbert_elliott_long_run_loss_and_burst_length(mean_loss: float, mean_burst: float) -> None:
    ge = GilbertElliott(mean_loss, mean_burst)
    p, r = ge.p, ge.r
    assert p / (p + r) == pytest.approx(mean_loss, rel=1e-12)
    x = lost(ge, N, seed=3)
    rho = 1 - p - r
    sigma_loss = math.sqrt(mean_loss * (1 - mean_loss) / N * (1 + rho) / (1 - rho))
    assert abs(x.mean() - mean_loss) < 4 * sigma_loss
    runs = loss_runs(x)
    sigma_run = math.sqrt(1 - r) / r / math.sqrt(len(runs))  # geometric run length: std sqrt(1 - r) / r
    assert abs(runs.mean() - mean_burst) < 4 * sigma_run
    assert lag1_autocorrelation(x) == pytest.approx(rho, abs=0.02)


def test_gilbert_elliott_is_bursty_bernoulli_is_not() -> None:
    ge = lost(GilbertElliott(0.1, 10.0), N, seed=4)
    iid = lost(Bernoulli(0.1), N, seed=4)
    assert lag1_autocorrelation(ge) > 0.5
    assert abs(lag1_autocorrelation(iid)) < 4 / math.sqrt(N)


def test_gilbert_elliott_first_packet_from_stationary_distribution() -> None:
    # One packet on each of many fresh links: the first-packet loss rate is already the long-run one.
    ge = GilbertElliott(0.25, 8.0)
    rng = np.random.default_rng(5)
    n = 20_000
    first = np.array([ge.link().decide(rng, 1000.0, 32) is not None for _ in range(n)])
    assert abs(first.mean() - 0.25) < 4 * math.sqrt(0.25 * 0.75 / n)


def test_gilbert_elliott_good_and_bad_loss_overrides() -> None:
    ge = GilbertElliott(0.2, 5.0, good_loss=0.05, bad_loss=0.6)
    assert ge.loss_rate == pytest.approx(0.8 * 0.05 + 0.2 * 0.6)
    x = lost(ge, N, seed=6)
    # Loose bound: the chain's correlation inflates the variance by at most (1 + rho) / (1 - rho) = 1.75 / 0.25.
    rho = 1 - ge.p - ge.r
    sigma = math.sqrt(ge.loss_rate * (1 - ge.loss_rate) / N * (1 + rho) / (1 - rho))
    assert abs(x.mean() - ge.loss_rate) < 4 * sigma


def test_gilbert_elliott_links_are_independent_state() -> None:
    ge = GilbertElliott(0.3, 3.0)
    a, b = ge.link(), ge.link()
    rng = np.random.default_rng(7)
    for _ in range(50):
        a.decide(rng, 1000.0, 32)
    fresh = ge.link()
    rng_b, rng_f = np.random.default_rng(8), np.random.default_rng(8)
    assert [b.decide(rng_b, 1.0, 1) for _ in range(200)] == [fresh.decide(rng_f, 1.0, 1) for _ in range(200)]


MODELS: list[LossModel] = [
    Bernoulli(0.3),
    GilbertElliott(0.2, 4.0),
    BUDGET,
    TABLE,
    Composite((Bernoulli(0.3), GilbertElliott(0.2, 4.0), TABLE)),
    Composite((Composite((Bernoulli(0.5), BUDGET)), GilbertElliott(0.1, 2.0))),
    Composite(()),
]


@pytest.mark.parametrize("model", MODELS, ids=lambda m: type(m).__name__)
def test_every_decision_consumes_exactly_draws(model: LossModel) -> None:
    link = model.link()
    assert link.draws == model.draws
    rng, parallel = np.random.default_rng(9), np.random.default_rng(9)
    for i in range(300):
        distance = [50.0, 700.0, 9500.0, 20000.0][i % 4]  # near, mid and far: all outcomes occur
        link.decide(rng, distance, 32)
        parallel.random(model.draws)
        assert rng.bit_generator.state == parallel.bit_generator.state


def test_composite_draws_is_the_sum() -> None:
    assert Composite((Bernoulli(0.1), GilbertElliott(0.1, 2.0), TABLE)).draws == 1 + 2 + 1
    assert Composite(()).draws == 0


def reasons(link: LinkLoss, rng: np.random.Generator, n: int) -> list[str | None]:
    return [link.decide(rng, 700.0, 32) for _ in range(n)]


def test_composite_is_reproducible_and_loses_when_any_component_does() -> None:
    model = Composite((Bernoulli(0.2), GilbertElliott(0.2, 5.0), TABLE))
    first = reasons(model.link(), np.random.default_rng(10), 5000)
    again = reasons(model.link(), np.random.default_rng(10), 5000)
    assert first == again
    assert {"loss", "burst", "range", None} == set(first)


def test_composite_components_see_their_own_streams_unchanged() -> None:
    # Replay the composite's single stream split by draws: each component, run alone on its slice of the stream,
    # must make exactly the decisions it made inside the composite (so none is skipped or short-circuited).
    parts: tuple[LossModel, ...] = (Bernoulli(0.4), GilbertElliott(0.2, 5.0), TABLE)
    n = 3000
    uniforms = np.random.default_rng(11).random(n * 4).reshape(n, 4)
    alone = []
    for model, cols in zip(parts, [slice(0, 1), slice(1, 3), slice(3, 4)], strict=True):
        link = model.link()
        alone.append([link.decide(Replay(uniforms[i, cols]), 700.0, 32) for i in range(n)])
    combined = reasons(Composite(parts).link(), np.random.default_rng(11), n)
    expected = [next((r for r in row if r is not None), None) for row in zip(*alone, strict=True)]
    assert combined == expected
    # The case that matters occurred: the Bernoulli lost a packet and the chain, still stepped, was in a burst.
    assert any(a == "loss" and g == "burst" for a, g in zip(alone[0], alone[1], strict=True))


class Replay(np.random.Generator):
    """A Generator that hands out given uniforms: lets a component run alone on its slice of a shared stream."""

    def __init__(self, values: np.ndarray) -> None:
        super().__init__(np.random.PCG64(0))
        self._values = list(values)

    def random(self, size=None, dtype=np.float64, out=None):
        if size is None:
            return self._values.pop(0)
        return np.array([self._values.pop(0) for _ in range(size)])


def test_link_budget_success_falls_with_range() -> None:
    distances = [10.0, 1000.0, 8000.0, 9000.0, 9500.0, 10000.0, 11000.0, 30000.0]
    success = [BUDGET.success_probability(d, 32) for d in distances]
    assert all(a >= b for a, b in pairwise(success))
    assert success[0] == pytest.approx(1.0, abs=1e-12)
    assert success[-1] == pytest.approx(0.0, abs=1e-12)
    assert 0.9 < BUDGET.success_probability(9500.0, 32) < 0.99  # 1 - 0.0448
    assert BUDGET.success_probability(9500.0, 256) < BUDGET.success_probability(9500.0, 32)  # longer: more errors


def test_link_budget_equals_one_minus_per_from_acoustics() -> None:
    model = LinkBudgetRange(180.0, 12.0, 4000.0, "fsk", spreading=2.0, shipping=0.8, wind_m_s=6.0, directivity_db=2)
    for d in (500.0, 3000.0, 6000.0):
        ber = bit_error_rate(snr_db(180.0, d, 12.0, 4000.0, 2.0, 0.8, 6.0, 2.0), "fsk")
        assert model.success_probability(d, 64) == pytest.approx(1 - packet_error_rate(ber, 512), abs=1e-15)


def test_link_budget_loss_rate_matches_per() -> None:
    x = lost(BUDGET, 50_000, seed=12, distance_m=9500.0)
    per = 1 - BUDGET.success_probability(9500.0, 32)
    assert abs(x.mean() - per) < 4 * math.sqrt(per * (1 - per) / 50_000)
    assert not lost(BUDGET, 1000, seed=12, distance_m=100.0).any()
    assert lost(BUDGET, 1000, seed=12, distance_m=30000.0).all()


def test_range_table_interpolates_and_clamps() -> None:
    assert TABLE.success_probability(0.0) == 1.0
    assert TABLE.success_probability(100.0) == 1.0
    assert TABLE.success_probability(300.0) == pytest.approx(0.9, abs=1e-12)
    assert TABLE.success_probability(750.0) == pytest.approx(0.5, abs=1e-12)
    assert TABLE.success_probability(1000.0) == pytest.approx(0.2, abs=1e-12)
    assert TABLE.success_probability(5000.0) == pytest.approx(0.2, abs=1e-12)
    x = lost(TABLE, 50_000, seed=13, distance_m=750.0)
    assert abs(x.mean() - 0.5) < 4 * math.sqrt(0.25 / 50_000)
    assert RangeTable((10.0,), (0.7,)).success_probability(1e6) == pytest.approx(0.7)


@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda: Bernoulli(1.5), "p"),
        (lambda: Bernoulli(-0.1), "p"),
        (lambda: Bernoulli(math.nan), "p"),
        (lambda: GilbertElliott(1.0, 5.0), "mean_loss"),
        (lambda: GilbertElliott(-0.1, 5.0), "mean_loss"),
        (lambda: GilbertElliott(0.6, 1.0), "mean_loss"),  # p would exceed 1
        (lambda: GilbertElliott(0.1, 0.5), "mean_burst"),
        (lambda: GilbertElliott(0.1, math.inf), "mean_burst"),
        (lambda: GilbertElliott(0.1, 5.0, good_loss=1.2), "good_loss"),
        (lambda: GilbertElliott(0.1, 5.0, bad_loss=-0.2), "bad_loss"),
        (lambda: LinkBudgetRange(math.nan, 25.0, 5000.0, "bpsk"), "source_level_db"),
        (lambda: LinkBudgetRange(185.0, 0.0, 5000.0, "bpsk"), "frequency_khz"),
        (lambda: LinkBudgetRange(185.0, 25.0, -1.0, "bpsk"), "bandwidth_hz"),
        (lambda: LinkBudgetRange(185.0, 25.0, 5000.0, "ofdm"), "modulation"),  # type: ignore[arg-type]
        (lambda: LinkBudgetRange(185.0, 25.0, 5000.0, "bpsk", spreading=3.0), "spreading"),
        (lambda: LinkBudgetRange(185.0, 25.0, 5000.0, "bpsk", shipping=2.0), "shipping"),
        (lambda: LinkBudgetRange(185.0, 25.0, 5000.0, "bpsk", wind_m_s=-3.0), "wind_m_s"),
        (lambda: LinkBudgetRange(185.0, 25.0, 5000.0, "bpsk", directivity_db=math.inf), "directivity_db"),
        (lambda: RangeTable((), ()), "ranges_m"),
        (lambda: RangeTable((1.0, 2.0), (0.5,)), "success"),
        (lambda: RangeTable((1.0, 1.0), (0.5, 0.4)), "ranges_m"),
        (lambda: RangeTable((2.0, 1.0), (0.5, 0.4)), "ranges_m"),
        (lambda: RangeTable((1.0, math.inf), (0.5, 0.4)), "ranges_m"),
        (lambda: RangeTable((1.0, 2.0), (0.5, 1.1)), "success"),
        (lambda: Composite([Bernoulli(0.1)]), "models"),  # type: ignore[arg-type]
        (lambda: Composite((Bernoulli(0.1), 0.5)), "models"),  # type: ignore[arg-type]
    ],
)
def test_invalid_parameters_are_rejected_by_name(make, name: str) -> None:
    with pytest.raises(ValueError, match=rf"^{name} must be .*, got "):
        make()


def test_error_message_names_value() -> None:
    with pytest.raises(ValueError, match=r"p must be in \[0, 1\], got 1\.5"):
        Bernoulli(1.5)
