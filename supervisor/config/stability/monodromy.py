"""The sampled loop's maps over one period: flows, samples, deliveries (supervisor.config.stability.model), their
product (the monodromy), and its mean-square counterpart under independent losses.

Mean-square stability of a Markov jump linear system with i.i.d. modes (Costa, Fragoso & Marques, "Discrete-time
Markov jump linear systems", Springer 2005, Thm. 3.9): x+ = M(theta) x is mean-square stable iff the spectral radius
of E[M(theta) kron M(theta)] is below 1. Each link's delivery is its own independent Bernoulli draw, so that
expectation is a product over events of per-event expectations (kron of products = product of krons).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from supervisor.config.stability.expm import block_diag, expm
from supervisor.config.stability.model import Loop, Matrix, Sampling

if TYPE_CHECKING:
    from scipy.sparse.linalg import LinearOperator


@dataclass(frozen=True)
class Layout:
    """Where each part of the state sits: the core [x, e, (xh, eh) per link], then each sender's FIFO of buffers."""

    loop: Loop
    sampling: Sampling

    @cached_property
    def slots(self) -> tuple[int, ...]:
        """Buffers per sender: its messages in flight at the start of a period, plus the one it sends."""
        return tuple(self.sampling.in_flight(j) + 1 for j in range(self.loop.n))

    @cached_property
    def core(self) -> int:
        return 2 * self.loop.n + 2 * len(self.loop.links)

    def buffer(self, j: int, slot: int) -> int:
        """Index of (xb) of sender j's buffer `slot` (0: the oldest); eb follows it."""
        return self.core + 2 * (sum(self.slots[:j]) + slot)

    @cached_property
    def size(self) -> int:
        return self.core + 2 * sum(self.slots)

    @cached_property
    def generator(self) -> Matrix:
        """A of the whole state: the core loop, and buffers advancing as the receivers' predictor would."""
        buffer = np.array([[0.0, 1.0 if self.loop.predictor == "first_order" else 0.0], [0.0, 0.0]])
        return np.asarray(block_diag(self.loop.core_matrix(), *[buffer] * sum(self.slots)))

    @cached_property
    def consensus(self) -> Matrix:
        """The direction every map leaves fixed: every position-like state 1, every rate 0."""
        c = np.zeros(self.size)
        c[: self.loop.n] = 1.0
        c[2 * self.loop.n : self.size : 2] = 1.0
        return c

    def reduced(self, m: Matrix) -> Matrix:
        """The map m induces on the quotient by the consensus direction c (m c = c): on the representatives with
        x_0 = 0, z -> m z - c (m z)_0 (Ghabcheloo et al. 2009 measure the same errors, gamma_i - gamma_j)."""
        return np.asarray((m - np.outer(self.consensus, m[0]))[1:, 1:])

    def flow(self, tau: float) -> Matrix:
        return np.asarray(expm(self.generator * tau)) if tau > 0 else np.eye(self.size)

    def sample(self, j: int, slot: int) -> Matrix:
        """Sender j writes its (x_j, e_j) into its buffer `slot`."""
        m = np.eye(self.size)
        b = self.buffer(j, slot)
        m[b : b + 2] = 0.0
        m[b, j] = m[b + 1, self.loop.n + j] = 1.0
        return m

    def copy(self, link: int) -> Matrix:
        """Link's receiver takes the oldest buffer of the link's sender as its hold."""
        m = np.eye(self.size)
        h, b = 2 * self.loop.n + 2 * link, self.buffer(self.loop.links[link][1], 0)
        m[h : h + 2] = 0.0
        m[h, b] = m[h + 1, b + 1] = 1.0
        return m

    def shift(self, j: int) -> Matrix:
        """Sender j's FIFO moves up one; the freed last buffer takes (x_j, e_j) (never read before it is written
        again, and so no mode of its own; a zero there would move the consensus direction)."""
        m = np.eye(self.size)
        for slot in range(self.slots[j] - 1):
            b, nxt = self.buffer(j, slot), self.buffer(j, slot + 1)
            m[b : b + 2] = m[nxt : nxt + 2]
        return self._refill(m, j)

    def _refill(self, m: Matrix, j: int) -> Matrix:
        last = self.buffer(j, self.slots[j] - 1)
        m[last : last + 2] = 0.0
        m[last, j] = m[last + 1, self.loop.n + j] = 1.0
        return m

    def links_of(self, j: int) -> list[int]:
        return [link for link, (_, s) in enumerate(self.loop.links) if s == j]


def steps(layout: Layout) -> Iterator[tuple[str, int, float]]:
    """The period as ('flow', -, tau), ('sample', j, -), ('deliver', j, -) in order."""
    now = 0.0
    counts = [layout.sampling.in_flight(j) for j in range(layout.loop.n)]
    for t, kind, j in layout.sampling.events():
        if t > now:
            yield "flow", 0, t - now
            now = t
        if kind == 0:
            yield "sample", j, float(counts[j])
            counts[j] += 1
        else:
            yield "deliver", j, 0.0
            counts[j] -= 1
    if layout.sampling.period > now:
        yield "flow", 0, layout.sampling.period - now


def flow_rows(layout: Layout, tau: float, m: Matrix) -> Matrix:
    """exp(A tau) @ m, by blocks: the core's expm, and each buffer's 2 x 2 predictor flow."""
    core = layout.core
    out = np.empty_like(m)
    out[:core] = np.asarray(expm(layout.generator[:core, :core] * tau)) @ m[:core]
    drift = tau if layout.loop.predictor == "first_order" else 0.0
    out[core::2] = m[core::2] + drift * m[core + 1 :: 2]
    out[core + 1 :: 2] = m[core + 1 :: 2]
    return out


def apply_event(layout: Layout, kind: str, j: int, value: float, m: Matrix) -> Matrix:
    """The event's map @ m, as the row moves it is (the maps are copies of rows)."""
    if kind == "flow":
        return flow_rows(layout, value, m)
    if kind == "sample":
        return _rows(layout.sample(j, int(value)), m)
    for link in layout.links_of(j):
        m = _rows(layout.copy(link), m)
    return _rows(layout.shift(j), m)


def _rows(event: Matrix, m: Matrix) -> Matrix:
    """event @ m for an event whose rows are each a unit row (a copy): picks rows of m, O(N^2)."""
    return m[np.argmax(event, axis=1)]


def monodromy(layout: Layout) -> Matrix:
    """M over one period, every message delivered (the full state, consensus direction included)."""
    m = np.eye(layout.size)
    for kind, j, value in steps(layout):
        m = apply_event(layout, kind, j, value, m)
    return m


Losses = float | Sequence[float]  # every link's loss probability, or each link's (by its index in the loop's links)


def _stages(layout: Layout, loss: Losses) -> list[tuple[Matrix, float]]:
    """The period's maps on the quotient, each with the probability it acts (the identity otherwise): a delivery's
    copy to each link acts with 1 - that link's loss, independently; runs of certain maps are multiplied together."""
    losses = [loss] * len(layout.loop.links) if isinstance(loss, float | int) else list(loss)
    r = layout.reduced
    stages: list[tuple[Matrix, float]] = []
    pending = np.eye(layout.size)
    for kind, j, value in steps(layout):
        if kind == "deliver":
            stages.append((r(pending), 1.0))
            stages += [(r(layout.copy(link)), 1.0 - losses[link]) for link in layout.links_of(j)]
            pending = layout.shift(j)
        else:
            pending = (layout.flow(value) if kind == "flow" else layout.sample(j, int(value))) @ pending
    stages.append((r(pending), 1.0))
    return stages


def second_moment(layout: Layout, loss: Losses) -> LinearOperator:
    """X -> E[M X M'] on the quotient by the consensus direction (vec(X) -> E[M kron M] vec(X)), applied as matrix
    products, never built as a Kronecker product."""
    from scipy.sparse.linalg import LinearOperator  # here: only large loops with losses need ARPACK

    stages = _stages(layout, loss)
    size = layout.size - 1

    def apply(vec: Matrix) -> Matrix:
        x = vec.reshape(size, size)
        for m, p in stages:
            x = p * (m @ x @ m.T) + (1.0 - p) * x
        return x.reshape(-1)

    return LinearOperator((size * size, size * size), matvec=apply, dtype=float)


def second_moment_radius(layout: Layout, loss: Losses) -> float:
    """Spectral radius of the second-moment operator (below 1: mean-square stable, consensus mode excluded): built
    as E[M kron M] when small, by ARPACK on the operator otherwise."""
    if layout.size <= 21:
        size = (layout.size - 1) ** 2
        g = np.eye(size)
        for m, p in _stages(layout, loss):
            g = (p * np.kron(m, m) + (1.0 - p) * np.eye(size)) @ g
        return spectral_radius(g)
    from scipy.sparse.linalg import eigs

    # A fixed start vector: ARPACK's own is random, and the fitted k (stability.schedule) must be the same in every
    # process of a run and every run of a scenario (a new user saw k 0.021, 0.025, 0.03, 0.1 from one scenario)
    start = np.ones((layout.size - 1) ** 2)
    values = eigs(second_moment(layout, loss), k=1, which="LM", return_eigenvectors=False, tol=1e-8, maxiter=5000,
                  v0=start)  # fmt: skip
    return float(np.max(np.abs(values)))


def spectral_radius(m: Matrix) -> float:
    """max |eigenvalue|, from all of them (ARPACK's few largest converge badly here: with a long delay many
    eigenvalues crowd near the unit circle)."""
    return float(np.max(np.abs(np.linalg.eigvals(m)))) if m.size else 0.0
