"""The matrix exponential for the stability analysis, in numpy: scaling and squaring with the [13/13] Pade
approximant (Higham, "The scaling and squaring method for the matrix exponential revisited", SIAM J. Matrix Anal.
Appl. 26(4), 2005, Algorithm 2.3, its m = 13 branch: backward error below the unit roundoff for every norm).

Why not scipy.linalg.expm, which runs the same algorithm: importing scipy.linalg costs 0.6-0.9 s of CPU (it pulls in
numpy.f2py, numpy.ma and numpy.testing through scipy's array-API layer) against 12 ms for the paper's whole analysis,
and every `cpf validate`, `cpf run` and sweep process paid it. scipy is still used where it does what numpy does not
(ARPACK, for the mean-square analysis of large loops), imported there; tests hold this to scipy's result.
"""

from __future__ import annotations

import math

import numpy as np

from supervisor.config.stability.model import Matrix

# b_0 .. b_13 of the [13/13] Pade approximant to exp, and the largest 1-norm it takes without scaling (Higham 2005,
# Table 2.3).
PADE13 = (
    64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0, 129060195264000.0,
    10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0, 40840800.0, 960960.0, 16380.0, 182.0, 1.0,
)  # fmt: skip
THETA13 = 5.371920351148152


def expm(a: Matrix) -> Matrix:
    """exp(a) of a square matrix."""
    n = a.shape[0]
    norm = float(np.linalg.norm(a, 1)) if n else 0.0
    squarings = max(0, math.ceil(math.log2(norm / THETA13))) if norm > THETA13 else 0
    a = a / 2.0**squarings
    b, ident = PADE13, np.eye(n)
    a2 = a @ a
    a4 = a2 @ a2
    a6 = a4 @ a2
    u = a @ (a6 @ (b[13] * a6 + b[11] * a4 + b[9] * a2) + b[7] * a6 + b[5] * a4 + b[3] * a2 + b[1] * ident)
    v = a6 @ (b[12] * a6 + b[10] * a4 + b[8] * a2) + b[6] * a6 + b[4] * a4 + b[2] * a2 + b[0] * ident
    r = np.linalg.solve(v - u, v + u)
    for _ in range(squarings):
        r = r @ r
    return np.asarray(r)


def block_diag(*blocks: Matrix) -> Matrix:
    """The blocks on the diagonal, zeros elsewhere."""
    out = np.zeros((sum(b.shape[0] for b in blocks), sum(b.shape[1] for b in blocks)))
    row = col = 0
    for block in blocks:
        out[row : row + block.shape[0], col : col + block.shape[1]] = block
        row, col = row + block.shape[0], col + block.shape[1]
    return out
