"""The communication graph's matrices: its Laplacian and how connected it is (lambda_2).

The coordination law (vehicles.coordination) is built on the same Laplacian; the link statistics measure the
connectivity the channel actually delivered with it.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from comms.records.records import FloatArray


def laplacian(n: int, edges: Iterable[tuple[int, int]]) -> FloatArray:
    """L = D - A of an undirected graph on nodes 0..n-1."""
    lap = np.zeros((n, n))
    for i, j in edges:
        if i != j and lap[i, j] == 0.0:
            lap[i, j] = lap[j, i] = -1.0
            lap[i, i] += 1.0
            lap[j, j] += 1.0
    return lap


def algebraic_connectivity(lap: FloatArray) -> float:
    """lambda_2 of L: positive exactly when the graph is connected."""
    return float(np.sort(np.linalg.eigvalsh(lap))[1]) if len(lap) > 1 else 0.0
