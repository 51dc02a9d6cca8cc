r"""Time-optimal scaling of a planned generator path under torque limits (time mode, SPEC 3).

The extended-Jacobian generator without torque limits gives a collision-free path
q(sigma) with q' = dq/dsigma and q'' = F (sigma is the generator's own time). Traversing it
with the time rate w = dsigma/dt in [0, 1] gives dq/dt = w q', ddq = w^2 F + dw/dt q' and,
with x = w^2 and v = dx/dsigma (so dw/dt = v/2), efforts affine in (x, v) (eq. (22) of 000;
c(q, w q') = w^2 (c(q, q') - g) + g without friction):

.. math::

    \tau_i = \alpha_i x_i + \tfrac12 \beta_i v_i + \tau_{g,i},\quad
    \alpha_i = \tau_{F,i} - \tau_{g,i},\ \beta_i = T_{m,i} q'_i,\quad x_{i+1} = x_i + v_i \Delta_i.

Every sample must keep tau in the safety zone (eq. (25) of 000), and on each interval
[sigma_i, sigma_i+1] the constant v_i must keep it there at both ends: at sigma_i with x_i and
at sigma_i+1 with x_i + v_i Delta_i (the "first-order interpolation" discretization of
TOPP-RA, Pham & Pham 2018, sec. VI). Checking only the start of each interval (collocation)
lets v jump wherever beta is small: at rest q' = 0, so beta = 0 and the first interval's v is
bounded by nothing but the next controllable set, and the greedy forward pass then zig-zags
(x = 0, 0.099, 0, 0.047 on random-6 of the random test set: w 0.31 -> 0 -> 0.22, dq 0 -> -1.0
-> 0 -> -1.9 rad/s at a constant ddq, and a torque of 3x the limit on arrival at sigma_1).
This is a time-optimal path
parametrization problem, solved by reachability analysis (TOPP-RA, Pham & Pham 2018): a
backward pass computes the controllable sets [K_lo, K_hi] of x at each sample (two small 2D
LPs per sample), a forward pass from rest (x_0 = 0, the analogue of u0 = 0) takes the
largest admissible v. If x_0 = 0 is not controllable the limits are infeasible on this path
(eq. (30) of 000 generalized) and the first sample where a controllable set is empty is
reported. The geometric path and hence the clearance are those of the unconstrained plan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


def _lp2(A: Array, b: Array, c: Array) -> Array | None:
    """argmax c.z over the polygon A z <= b (z in R^2, bounded), by vertex enumeration."""
    m = len(b)
    i, j = np.triu_indices(m, 1)
    det = A[i, 0] * A[j, 1] - A[i, 1] * A[j, 0]
    ok = np.abs(det) > 1e-14
    i, j, det = i[ok], j[ok], det[ok]
    zx = (b[i] * A[j, 1] - A[i, 1] * b[j]) / det
    zu = (A[i, 0] * b[j] - b[i] * A[j, 0]) / det
    Z = np.stack([zx, zu], axis=1)
    feas = np.all(b + 1e-9 * (1 + np.abs(b)) >= Z @ A.T, axis=1)
    if not feas.any():
        return None
    Z = Z[feas]
    return np.asarray(Z[int(np.argmax(Z @ c))], dtype=float)


@dataclass(frozen=True)
class Scaling:
    """Result of :func:`time_optimal_scaling`.

    Attributes:
        x: Squared time rate w^2 at each sample (N,). v: dx/dsigma on each interval, (N,)
            (0 at the last sample).
        t: Real time of each sample (N,). feasible: x_0 = 0 was controllable.
        first_empty: First sample with an empty controllable set (None when feasible).
    """

    x: Array
    v: Array
    t: Array
    feasible: bool
    first_empty: int | None


def _rows(alpha: Array, beta: Array, g: Array, lo: Array, hi: Array) -> tuple[Array, Array]:
    """Zone constraints as A [x, v] <= b at one sample (finite limits only)."""
    A, b = [], []
    for k in range(len(alpha)):
        if np.isfinite(hi[k]):
            A.append([alpha[k], 0.5 * beta[k]])
            b.append(hi[k] - g[k])
        if np.isfinite(lo[k]):
            A.append([-alpha[k], -0.5 * beta[k]])
            b.append(g[k] - lo[k])
    return np.array(A, dtype=float).reshape(-1, 2), np.array(b, dtype=float)


def _interval_rows(
    alpha: Array, beta: Array, g: Array, lo: Array, hi: Array, i: int, delta: float
) -> tuple[Array, Array]:
    """Zone constraints of interval i on [x_i, v_i]: at sample i and, with x_i + v_i delta,
    at sample i + 1 (first-order interpolation; module docstring)."""
    A0, b0 = _rows(alpha[i], beta[i], g[i], lo, hi)
    A1, b1 = _rows(alpha[i + 1], beta[i + 1], g[i + 1], lo, hi)
    A1 = np.stack([A1[:, 0], A1[:, 0] * delta + A1[:, 1]], axis=1)
    return np.vstack([A0, A1]), np.concatenate([b0, b1])


def time_optimal_scaling(
    sigma: Array, alpha: Array, beta: Array, g: Array, lo: Array, hi: Array, w_max: float = 1.0
) -> Scaling:
    """TOPP-RA on the sampled path (module docstring).

    Args:
        sigma: Path parameter at the samples (N,), increasing.
        alpha, beta, g: Effort coefficients (N, n_act).
        lo, hi: Safety zone (n_act,).
        w_max: Largest time rate (1: never faster than the unconstrained generator).
    """
    N = len(sigma)
    delta = np.diff(sigma)
    x_max = w_max * w_max
    box = (
        np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]),
        np.array([x_max, 0.0, 1e6, 1e6]),
    )
    K_lo, K_hi = np.zeros(N), np.zeros(N)
    first_empty: int | None = None
    for i in range(N - 1, -1, -1):
        if i == N - 1:
            A, b = _rows(alpha[i], beta[i], g[i], lo, hi)
            A, b = np.vstack([A, box[0]]), np.concatenate([b, box[1]])
            A, b = np.vstack([A, [[0.0, 1.0], [0.0, -1.0]]]), np.concatenate([b, [0.0, 0.0]])
        else:
            A, b = _interval_rows(alpha, beta, g, lo, hi, i, delta[i])
            A, b = np.vstack([A, box[0]]), np.concatenate([b, box[1]])
            A = np.vstack([A, [[1.0, delta[i]], [-1.0, -delta[i]]]])
            b = np.concatenate([b, [K_hi[i + 1], -K_lo[i + 1]]])
        top, bottom = _lp2(A, b, np.array([1.0, 0.0])), _lp2(A, b, np.array([-1.0, 0.0]))
        if top is None or bottom is None:
            first_empty = i
            break
        K_hi[i], K_lo[i] = top[0], max(bottom[0], 0.0)
    feasible = first_empty is None and K_lo[0] <= 1e-12
    x, v = np.zeros(N), np.zeros(N)
    for i in range(N - 1):
        if not feasible:
            break
        A, b = _interval_rows(alpha, beta, g, lo, hi, i, delta[i])
        # Largest v with A [x_i, v] <= b (both ends of the interval) and x_i + v delta
        # in [K_lo, K_hi] of i + 1.
        v_hi = (K_hi[i + 1] - x[i]) / delta[i]
        v_lo = (K_lo[i + 1] - x[i]) / delta[i]
        for (a_x, a_v), bk in zip(A, b, strict=True):
            if a_v > 1e-14:
                v_hi = min(v_hi, (bk - a_x * x[i]) / a_v)
            elif a_v < -1e-14:
                v_lo = max(v_lo, (bk - a_x * x[i]) / a_v)
        v[i] = max(v_hi, v_lo) if v_hi < v_lo else v_hi
        x[i + 1] = float(np.clip(x[i] + v[i] * delta[i], 0.0, x_max))
        v[i] = (x[i + 1] - x[i]) / delta[i]
    w = np.sqrt(x)
    with np.errstate(divide="ignore"):
        dt = np.where(w[1:] + w[:-1] > 0, 2.0 * delta / (w[1:] + w[:-1]), np.inf)
    t = np.concatenate([[0.0], np.cumsum(dt)])
    return Scaling(x, v, t, feasible, first_empty)
