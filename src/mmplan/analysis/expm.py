"""Matrix exponential of a small square matrix, in NumPy alone.

The vibration study (:mod:`mmplan.analysis.vibration`) needs the exponential of one 4 x 4
step matrix; ``scipy.linalg`` would cost a quarter of a second to import, more than the
study itself, on every ``mmplan plan``. Method: balancing by exact powers of two
(Parlett-Reinsch: the oscillator's matrix has entries of 1 and omega^2 side by side), then
scaling and squaring with the degree-13 Pade approximant (N. J. Higham, "The scaling and
squaring method for the matrix exponential revisited", SIAM J. Matrix Anal. Appl. 26(4),
2005: the algorithm behind ``scipy.linalg.expm``). Tested against closed forms and SciPy.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mmplan.arrays import Array

#: Coefficients of the degree-13 Pade approximant of exp, and the 1-norm up to which it is
#: accurate to double precision (Higham 2005, Table 2.3).
PADE13 = (64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0,
          129060195264000.0, 10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0,
          40840800.0, 960960.0, 16380.0, 182.0, 1.0)
THETA13 = 5.371920351148152


def balance(matrix: Array, sweeps: int = 50) -> tuple[Array, Array]:
    """``(B, d)`` with ``B = D^-1 A D``, ``D = diag(d)`` a diagonal of powers of two that
    brings each row's off-diagonal 1-norm near its column's (Parlett-Reinsch; exact in
    floating point)."""
    a = np.array(matrix, dtype=float)
    d = np.ones(len(a))
    for _ in range(sweeps):
        changed = False
        for i in range(len(a)):
            col = float(np.abs(a[:, i]).sum() - abs(a[i, i]))
            row = float(np.abs(a[i, :]).sum() - abs(a[i, i]))
            if col == 0.0 or row == 0.0:
                continue
            total, f = col + row, 1.0
            while col < row / 2:
                col, row, f = col * 2, row / 2, f * 2
            while col >= row * 2:
                col, row, f = col / 2, row * 2, f / 2
            if col + row < 0.95 * total:
                changed = True
                d[i] *= f
                a[:, i] *= f
                a[i, :] /= f
        if not changed:
            break
    return a, d


def _pade13(a: Array) -> Array:
    """exp(a) for a matrix (n, n), or a stack of them (K, n, n), of 1-norm <= THETA13."""
    b = PADE13
    eye = np.eye(a.shape[-1])
    a2 = a @ a
    a4 = a2 @ a2
    a6 = a4 @ a2
    u = a @ (a6 @ (b[13] * a6 + b[11] * a4 + b[9] * a2)
             + b[7] * a6 + b[5] * a4 + b[3] * a2 + b[1] * eye)
    v = (a6 @ (b[12] * a6 + b[10] * a4 + b[8] * a2)
         + b[6] * a6 + b[4] * a4 + b[2] * a2 + b[0] * eye)
    out: Array = np.asarray(np.linalg.solve(v - u, v + u), dtype=float)
    return out


def expm(matrix: ArrayLike) -> Array:
    """exp(A) of a small square matrix with finite entries (module docstring)."""
    a, d = balance(np.asarray(matrix, dtype=float))
    norm = float(np.abs(a).sum(axis=0).max()) if a.size else 0.0
    squarings = int(np.ceil(np.log2(norm / THETA13))) if norm > THETA13 else 0
    out = _pade13(a / 2.0**squarings)
    for _ in range(squarings):
        out = out @ out
    result: Array = d[:, None] * out / d[None, :]
    return result


def expm_scaled(matrix: ArrayLike, scales: ArrayLike) -> Array:
    """exp(h A) for every h of ``scales`` (K,) at once, (K, n, n): the method of :func:`expm`
    on a stack (one balancing of A serves every h: scaling A by h scales every row and column
    sum alike, so the same powers of two balance it; the squarings per h). For the vibration
    study's time-scaled plans, one exponential per distinct step: 600 one at a time cost
    12-15 ms of every ``mmplan plan``, the stack about 1 ms (same values to rounding, tests)."""
    a, d = balance(np.asarray(matrix, dtype=float))
    h = np.asarray(scales, dtype=float).reshape(-1)
    norm = float(np.abs(a).sum(axis=0).max()) if a.size else 0.0
    with np.errstate(divide="ignore"):
        ratio = np.abs(h) * norm / THETA13
        squarings = np.where(ratio > 1.0, np.ceil(np.log2(np.maximum(ratio, 1.0))), 0.0)
    squarings = squarings.astype(int)
    stack = (h / 2.0**squarings)[:, None, None] * a[None, :, :]
    out = _pade13(stack)
    for k in range(int(squarings.max(initial=0))):
        more = squarings > k
        out[more] = out[more] @ out[more]
    result: Array = d[None, :, None] * out / d[None, None, :]
    return result

