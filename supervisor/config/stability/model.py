"""The fleet's coordination loop, linearised and sampled: the monodromy matrix over one transmit period or TDMA frame.

Model (all vehicles, perfect path following: each controller keeps sigma' R' p_d^gamma ~ 0, so the paper's eq. (3)
leaves gamma_ddot_i = -k_zeta (gamma_dot_i - v_r) + v_tilde_i), with law (5) of Aguiar & Pascoal (2007) in its
decentralised form, neighbours j replaced by what vehicle i holds of them:
    v_tilde_i = -k sum_j (gamma_dot_i - gdh_j) - k2 ((gamma_dot_i - v_r) + k sum_j (gamma_i - gh_j)).
In the errors about the synchronised motion, x_i = gamma_i - v_r t and e_i = gamma_dot_i - v_r, the loop is linear:
    x_i' = e_i,   e_i' = -(k_zeta + k2 + k deg_i) e_i + k sum_j eh_ij - k2 k (deg_i x_i - sum_j xh_ij),
where (xh_ij, eh_ij) is receiver i's prediction of sender j from j's last delivered message, stamped at its send time:
    first_order  xh' = eh, eh' = 0   (gamma_j + gamma_dot_j age);
    reference    xh' = 0,  eh' = 0   (gamma_j + v_r age: a zero-order hold of x_j);
    hold         xh' = -v_r (a forcing, the same for every state), eh' = 0: its homogeneous loop is reference's,
                 the forcing leaves a bounded offset, not a growing error.
The literal law (speed instead of speed error) has the same linear part: the analysis holds about its own settled
speed. Messages: sender j samples (x_j, e_j) at its offset o_j in every period P (all 0 for periodic transmission;
its slot start under TDMA) and each of its neighbours receives it d s later; in flight it sits in a FIFO of buffers
that advance with the predictor's dynamics, so a delivery copies the buffer into the receiver's hold. The state is
[x (n), e (n), (xh, eh) per directed link, (xb, eb) per buffer of each sender]. Between events it flows with
exp(A tau) (supervisor.config.stability.expm); events are linear maps; their product over [0, P) is the monodromy M.

Every map leaves the consensus direction c (every x, xh, xb = 1, every rate 0) fixed: law (5) is neutral to a
common shift of all gamma_i. `Layout.reduced` maps a matrix to the quotient by span(c) (M c = c for every map here, so
the induced map is well defined, and products reduce factor by factor).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from supervisor.config.links import PREDICTORS

Matrix = NDArray[np.float64]


@dataclass(frozen=True)
class Loop:
    """The continuous part: n vehicles, directed links (receiver, sender) as indices 0..n-1, gains of law (5)
    (k, k2 in 1/s) and of the path-following speed error (k_zeta, 1/s), and the receivers' predictor."""

    n: int
    links: tuple[tuple[int, int], ...]
    k: float
    k2: float
    k_zeta: float
    predictor: str = "first_order"

    def __post_init__(self) -> None:
        if self.predictor not in PREDICTORS:
            raise ValueError(f"predictor: must be one of {PREDICTORS}, got {self.predictor!r}")

    @classmethod
    def of_edges(cls, n: int, edges: Sequence[tuple[int, int]], k: float, k2: float, k_zeta: float,
                 predictor: str = "first_order") -> Loop:  # fmt: skip
        """The loop of an undirected graph on vehicles 0..n-1: each edge is two directed links."""
        links = sorted({(i, j) for a, b in edges for i, j in ((a, b), (b, a))})
        return cls(n, tuple(links), k, k2, k_zeta, predictor)

    def degree(self, i: int) -> int:
        return sum(1 for r, _ in self.links if r == i)

    def core_matrix(self) -> Matrix:
        """A of the core state [x, e, (xh, eh) per link] of the linear loop above."""
        n, m = self.n, len(self.links)
        a = np.zeros((2 * n + 2 * m, 2 * n + 2 * m))
        for i in range(n):
            a[i, n + i] = 1.0
            a[n + i, n + i] = -(self.k_zeta + self.k2 + self.k * self.degree(i))
            a[n + i, i] = -self.k2 * self.k * self.degree(i)
        for link, (i, _) in enumerate(self.links):
            xh, eh = 2 * n + 2 * link, 2 * n + 2 * link + 1
            a[n + i, eh] += self.k
            a[n + i, xh] += self.k2 * self.k
            if self.predictor == "first_order":
                a[xh, eh] = 1.0
        return a

    def continuous_matrix(self) -> Matrix:
        """The loop with every message delivered at once (no sampling, no delay): xh = x_j, eh = e_j."""
        n = self.n
        core = self.core_matrix()
        full = core[: 2 * n, : 2 * n].copy()
        for link, (_, j) in enumerate(self.links):
            full[:, j] += core[: 2 * n, 2 * n + 2 * link]
            full[:, n + j] += core[: 2 * n, 2 * n + 2 * link + 1]
        return full


@dataclass(frozen=True)
class Sampling:
    """When messages go and arrive: every `period` s, sender j at offsets[j] in [0, period) (all 0: synchronous),
    delivered `delay` s later (>= 0) on every link."""

    period: float
    delay: float
    offsets: tuple[float, ...]

    def in_flight(self, j: int) -> int:
        """Messages of sender j sent before 0 and delivered at or after 0 (in flight at the start of a period)."""
        o, p, d = self.offsets[j], self.period, self.delay
        first = -int(np.ceil((d + o) / p)) - 1
        return sum(1 for m in range(first, 1) if o + m * p < 0 <= o + m * p + d + 1e-12)

    def events(self) -> list[tuple[float, int, int]]:
        """(time in [0, period), 0: sample / 1: deliver, sender), in order; a sample first at equal times."""
        out = []
        for j, o in enumerate(self.offsets):
            arrive = (o + self.delay) % self.period
            if self.period - arrive < 1e-12:
                arrive = 0.0
            out += [(o, 0, j), (arrive, 1, j)]
        return sorted(out)
