"""Law (5) and the graph matrices behind it: the six properties of L_K, and corrected vs literal behaviour."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import null_space

from comms.records.graph import algebraic_connectivity, laplacian
from vehicles.coordination import CoordinationGains, Corrected, LiteralLaw, correction, correction_vector, l_k

SEEDS = range(25)


def random_connected_graph(rng: np.random.Generator) -> tuple[int, list[tuple[int, int]]]:
    """A random spanning tree plus random extra edges: always connected."""
    n = int(rng.integers(2, 9))
    edges = [(i, int(rng.integers(0, i))) for i in range(1, n)]
    edges += [(int(a), int(b)) for a, b in rng.integers(0, n, (n, 2)) if a != b]
    return n, edges


def random_case(seed: int):
    rng = np.random.default_rng(seed)
    n, edges = random_connected_graph(rng)
    return rng, n, laplacian(n, edges), rng.uniform(0.1, 5.0, n)


def min_rayleigh(lap: np.ndarray, constraint: np.ndarray) -> float:
    """min nu' L nu / nu' nu over nu with constraint' nu = 0."""
    basis = null_space(constraint[None, :])
    return float(np.linalg.eigvalsh(basis.T @ lap @ basis).min())


@pytest.mark.parametrize("seed", SEEDS)
def test_property_1_spectrum_and_eigenvectors(seed):
    _, n, _, k = random_case(seed)
    lk = l_k(k)
    eig = np.sort(np.linalg.eigvals(lk).real)
    np.testing.assert_allclose(eig, [0.0] + [1.0] * (n - 1), atol=1e-10)
    np.testing.assert_allclose(lk @ np.ones(n), 0.0, atol=1e-12)
    np.testing.assert_allclose((1.0 / k) @ lk, 0.0, atol=1e-12)


@pytest.mark.parametrize("seed", SEEDS)
def test_property_2_xi_vanishes_exactly_on_agreement_and_bounds_pairwise_errors(seed):
    rng, n, _, k = random_case(seed)
    lk = l_k(k)
    np.testing.assert_allclose(lk @ (3.7 * np.ones(n)), 0.0, atol=1e-12)
    for _ in range(20):
        gamma = rng.normal(0.0, 10.0, n)
        xi = lk @ gamma
        assert np.linalg.norm(xi) > 1e-9  # random gamma is not in span{1}
        pairwise = np.subtract.outer(gamma, gamma)
        assert (pairwise**2).max() <= 2 * (xi @ xi) + 1e-9


@pytest.mark.parametrize("seed", SEEDS)
def test_properties_3_and_4_commute_with_the_laplacian(seed):
    _, _, lap, k = random_case(seed)
    lk, kmat = l_k(k), np.diag(k)
    np.testing.assert_allclose(lk @ kmat @ lap, kmat @ lap, atol=1e-10)
    np.testing.assert_allclose(lap @ lk, lap, atol=1e-10)


@pytest.mark.parametrize("seed", SEEDS)
def test_property_5_lk_does_not_increase_the_k_inverse_norm(seed):
    rng, n, _, k = random_case(seed)
    lk, kinv = l_k(k), np.diag(1.0 / k)
    for _ in range(20):
        nu = rng.normal(0.0, 5.0, n)
        assert nu @ lk.T @ kinv @ lk @ nu <= nu @ kinv @ nu + 1e-9


@pytest.mark.parametrize("seed", SEEDS)
def test_property_6_lambda_m_is_positive_and_bounded_by_the_printed_formula(seed):
    """As printed, property 6 is an equality; numerically it holds as a lower bound (equality for K = kI)."""
    _, n, lap, k = random_case(seed)
    kinv = 1.0 / k
    lambda_2m = min_rayleigh(lap, np.ones(n))
    lambda_m = min_rayleigh(lap, kinv)
    formula = kinv.sum() ** 2 / (n * (kinv**2).sum()) * lambda_2m
    assert lambda_2m == pytest.approx(algebraic_connectivity(lap), rel=1e-9)
    assert formula > 0.0
    assert lambda_m >= formula - 1e-10


def test_property_6_is_an_equality_for_uniform_gains_but_not_in_general():
    n, edges = 4, [(0, 1), (1, 2), (2, 3)]
    lap = laplacian(n, edges)
    uniform = np.full(n, 2.0)
    assert min_rayleigh(lap, 1 / uniform) == pytest.approx(algebraic_connectivity(lap), rel=1e-9)
    k = np.array([0.2, 1.0, 3.0, 0.5])
    kinv = 1 / k
    formula = kinv.sum() ** 2 / (n * (kinv**2).sum()) * algebraic_connectivity(lap)
    assert min_rayleigh(lap, kinv) > formula * 1.05


def test_disconnected_graph_has_zero_algebraic_connectivity():
    assert algebraic_connectivity(laplacian(4, [(0, 1), (2, 3)])) == pytest.approx(0.0, abs=1e-12)
    assert algebraic_connectivity(laplacian(4, [(0, 1), (1, 2), (2, 3)])) > 0.1


@pytest.mark.parametrize("law", ["corrected", "literal"])
@pytest.mark.parametrize("seed", range(5))
def test_decentralised_law_equals_the_vector_form(law, seed):
    rng = np.random.default_rng(seed)
    n, edges = random_connected_graph(rng)
    lap = laplacian(n, edges)
    gamma, rate = rng.normal(0, 5, n), rng.normal(1, 0.3, n)
    gains = CoordinationGains(k=0.4, k2=1.3, v_r=0.8)
    vector = correction_vector(gamma, rate, lap, np.full(n, 0.4), np.full(n, 1.3), 0.8, law)
    for i in range(n):
        nbrs = [(gamma[j], rate[j]) for j in range(n) if lap[i, j] != 0 and i != j]
        assert correction(gamma[i], rate[i], nbrs, gains, law) == pytest.approx(vector[i], rel=1e-12, abs=1e-12)
        chosen = Corrected() if law == "corrected" else LiteralLaw()  # the objects a run calls: the same numbers
        assert chosen.correction(gamma[i], rate[i], nbrs, gains) == correction(gamma[i], rate[i], nbrs, gains, law)


def simulate_coordination(law: str, k_zeta: float = 1.0, k2: float = 2.0, seconds: float = 60.0):
    """The coordination subsystem (4) with perfect path following: gamma_ddot = -k_zeta (gamma_dot - v_r) + v_tilde."""
    lap = laplacian(3, [(0, 1), (0, 2)])
    gamma, rate, dt, v_r = np.array([0.0, 10.0, -5.0]), np.zeros(3), 0.01, 1.0
    for _ in range(round(seconds / dt)):
        v_tilde = correction_vector(gamma, rate, lap, np.full(3, 0.5), np.full(3, k2), v_r, law)  # type: ignore[arg-type]
        accel = -k_zeta * (rate - v_r) + v_tilde
        gamma, rate = gamma + dt * rate, rate + dt * accel
    return gamma, rate


def test_corrected_law_reaches_agreement_at_the_reference_speed():
    gamma, rate = simulate_coordination("corrected")
    assert np.ptp(gamma) < 1e-4
    np.testing.assert_allclose(rate, 1.0, atol=1e-4)


def test_literal_law_agrees_but_settles_at_a_fraction_of_the_reference_speed():
    gamma, rate = simulate_coordination("literal", k_zeta=1.0, k2=2.0)
    assert np.ptp(gamma) < 1e-4
    np.testing.assert_allclose(rate, 1.0 / 3.0, atol=1e-4)  # k_zeta v_r / (k_zeta + K2)
