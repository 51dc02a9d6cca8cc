r"""Time-optimal scaling of a path under effort, velocity and acceleration limits.

A path q(sigma) (e.g. the extended-Jacobian generator's, sigma its own time;
docs/extended_jacobian.md) with q' = dq/dsigma and q'' = F is traversed with the time rate
w = dsigma/dt <= w_max. Then dq/dt = w q', ddq = w^2 F + dw/dt q' and, with x = w^2 and
v = dx/dsigma (so dw/dt = v/2), efforts are affine in (x, v) ([PajakPajak] eq. (22);
c(q, w q') = w^2 (c(q, q') - g) + g without friction):

.. math::

    \tau_i = \alpha_i x_i + \tfrac12 \beta_i v_i + \tau_{g,i},\quad
    \alpha_i = \tau_{F,i} - \tau_{g,i},\ \beta_i = T_{m,i} q'_i,\quad x_{i+1} = x_i + v_i \Delta_i.

Any constraint of this form is a "row" (alpha, beta, g) with bounds [lo, hi]: an
acceleration limit |ddq_j| <= a_j is the row alpha = q''_j, beta = q'_j, g = 0 (exact), a side
of the polygon that approximates a planar acceleration limit from inside another
(:mod:`.rates`). A velocity limit |q'_j| w <= v_j bounds x alone, x <= v_j^2 / q'_j^2 (exact):
all of them, and w_max^2, make the per-sample bound ``x_upper``.

Every sample must keep each row in its zone (for efforts [PajakPajak] eq. (25)), and on each
interval
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
largest admissible v and keeps x_{i+1} in K_{i+1} (roundoff can leave x_i a hair outside
K_i, where no v is admissible; unclipped, the excess grew geometrically). If x_0 is not
controllable the limits are infeasible on this path ([PajakPajak] eq. (30) generalized) and the
first sample where a controllable set is empty is reported. The geometric path and hence the
clearance are those of the unconstrained plan.

Between samples the limits hold only approximately: x is linear in sigma on an interval while
q', q'' and the effort coefficients change; tests/time_scaling/test_rates.py measures the
excess on a dense resampling.

:func:`time_optimal_scaling` runs both passes compiled (:mod:`.passes`, :mod:`.native`:
about 1.7 us a sample with 15 rows); :func:`reference_scaling` is the plain NumPy version it
reproduces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mmplan.arrays import Array
from mmplan.time_scaling import passes
from mmplan.time_scaling.passes import BIG, TOL


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
        t: Real time of each sample (N,). feasible: x_0 was controllable.
        first_empty: Last sample (counting backwards from the end, the first found) with an
            empty controllable set (None when every set is non-empty).
    """

    x: Array
    v: Array
    t: Array
    feasible: bool
    first_empty: int | None

    @property
    def v_at_samples(self) -> Array:
        """dx/dsigma at each sample, for the accelerations and efforts there: v, with the last
        interval's value at the last sample (the derivative from the left; the rows hold there
        with it, the first-order discretization keeps them at both ends of an interval). With
        0 there a plan cut short while moving (a timeout) ended with an acceleration its last
        step does not have: the checker's ddq consistency failed by 0.19 (new-user trial)."""
        if len(self.v) < 2:
            return self.v
        out = self.v.copy()
        out[-1] = self.v[-2]
        return out


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


def reference_scaling(
    sigma: Array,
    alpha: Array,
    beta: Array,
    g: Array,
    lo: Array,
    hi: Array,
    w_max: float = 1.0,
    x_upper: Array | None = None,
    x_start: float | None = 0.0,
) -> Scaling:
    """Plain NumPy TOPP-RA (vertex-enumeration LPs, one interval at a time): the reference
    that :func:`time_optimal_scaling` reproduces (same arguments; about 0.3 ms a sample)."""
    N = len(sigma)
    delta = np.diff(sigma)
    x_up = _upper(N, w_max, x_upper)
    K_lo, K_hi = np.zeros(N), np.zeros(N)
    first_empty: int | None = None
    for i in range(N - 1, -1, -1):
        box = (
            np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]),
            np.array([x_up[i], 0.0, 1e6, 1e6]),
        )
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
    x0, feasible = _start(x_start, K_lo[0], K_hi[0], first_empty)
    x, v = np.zeros(N), np.zeros(N)
    x[0] = x0 if feasible else 0.0
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
        # Roundoff can leave x_i a hair outside K_i, where no v is admissible (v_hi < v_lo);
        # without the clip into K_{i+1} the excess grew ~1.3x a step (8e-3 N m over the
        # limit after 67 steps on a seeded random problem, tests/time_scaling/test_topp.py).
        x_next = np.clip(x[i] + v[i] * delta[i], K_lo[i + 1], K_hi[i + 1])
        x[i + 1] = float(np.clip(x_next, 0.0, x_up[i + 1]))
        v[i] = (x[i + 1] - x[i]) / delta[i]
    return Scaling(x, v, _times(x, delta), feasible, first_empty)


def _upper(N: int, w_max: float, x_upper: Array | None) -> Array:
    """Per-sample bound of x: w_max^2 and ``x_upper`` (N,), finite (ValueError otherwise)."""
    up = np.full(N, float(w_max) ** 2)
    if x_upper is not None:
        given = np.asarray(x_upper, dtype=float)
        if given.shape != (N,) or np.isnan(given).any():
            raise ValueError(f"x_upper: expected {N} values (not NaN), got shape {given.shape}")
        up = np.minimum(up, given)
    if not (np.all(np.isfinite(up)) and np.all(up >= 0.0)):
        raise ValueError(
            "the time rate is unbounded (or x_upper < 0) at some sample: give a finite w_max"
        )
    return up


def _start(
    x_start: float | None, k_lo: float, k_hi: float, first_empty: int | None
) -> tuple[float, bool]:
    """x_0 and whether it is controllable: ``x_start`` (None: the largest controllable,
    K_hi of sample 0) must lie in [K_lo, K_hi] of sample 0 (x_start = 0 needs K_lo <= 1e-12,
    the slack of the original rest start)."""
    if first_empty is not None:
        return 0.0, False
    x0 = k_hi if x_start is None else float(x_start)
    return x0, bool(k_lo <= x0 + 1e-12 and x0 <= k_hi + TOL * (1.0 + abs(k_hi)))


def _times(x: Array, delta: Array) -> Array:
    """Real time of each sample: trapezoid in w = sqrt(x) (inf once w stays 0)."""
    w = np.sqrt(x)
    with np.errstate(divide="ignore"):
        dt = np.where(w[1:] + w[:-1] > 0, 2.0 * delta / (w[1:] + w[:-1]), np.inf)
    return np.concatenate([[0.0], np.cumsum(dt)])


def _last_set(a: Array, c_lo: Array, c_hi: Array, x_max: float) -> tuple[float, float] | None:
    """Controllable set [K_lo, K_hi] of the last sample (v = 0: c_lo <= a x <= c_hi, 0 <= x
    <= x_max), None when empty; the reference's vertex rule (|a| > 1e-14) and slack."""
    ok = np.abs(a) > 1e-14
    safe = np.where(ok, a, 1.0)
    r1, r2 = c_lo / safe, c_hi / safe
    x_lo = max(0.0, float(np.max(np.where(ok, np.minimum(r1, r2), -BIG), initial=-BIG)))
    x_hi = min(x_max, float(np.min(np.where(ok, np.maximum(r1, r2), BIG), initial=BIG)))
    if np.any(~ok & ((c_lo > TOL) | (c_hi < -TOL))) or x_lo > x_hi + TOL * (1.0 + abs(x_hi)):
        return None
    return max(min(x_lo, x_hi), 0.0), x_hi


def time_optimal_scaling(
    sigma: Array,
    alpha: Array,
    beta: Array,
    g: Array,
    lo: Array,
    hi: Array,
    w_max: float = 1.0,
    x_upper: Array | None = None,
    x_start: float | None = 0.0,
) -> Scaling:
    """TOPP-RA on the sampled path (module docstring), with compiled passes.

    The controllable set of the last sample is a closed form here; the recursions
    K_i = f(K_{i+1}) and x_{i+1} = f(x_i) run in C (:mod:`~mmplan.time_scaling.passes`,
    the CasADi VM without a compiler). Same results as :func:`reference_scaling` (bit for
    bit on the youbot3r-obstacles-torque path, x within one ulp on random problems).

    Args:
        sigma: Path parameter at the samples (N,), increasing.
        alpha, beta, g: Row coefficients (N, n): efforts, accelerations (:mod:`.rates`).
        lo, hi: Zone of each row (n,); infinite entries are no limit.
        w_max: Largest time rate (1: never faster than the path's own parametrization).
        x_upper: Further bound of x = w^2 at each sample (N,) (velocity limits); inf: none.
        x_start: x at sample 0 (0: from rest; None: the largest controllable value, for a
            path whose first q' is zero).

    Raises:
        ValueError: x is unbounded at some sample (infinite w_max and x_upper).
    """
    return scaling_with_sets(sigma, alpha, beta, g, lo, hi, w_max, x_upper, x_start)[0]


def scaling_with_sets(
    sigma: Array,
    alpha: Array,
    beta: Array,
    g: Array,
    lo: Array,
    hi: Array,
    w_max: float = 1.0,
    x_upper: Array | None = None,
    x_start: float | None = 0.0,
    reuse: tuple[Array, Array, int] | None = None,
) -> tuple[Scaling, Array, Array]:
    """:func:`time_optimal_scaling` and its controllable sets (K_lo, K_hi).

    Args:
        reuse: (K_lo, K_hi, m) of an earlier call on a feasible problem (every set non-empty)
            whose inputs equal these at every sample after m: K_i depends only on the
            samples i .. N - 1, so the sets after m are taken as they are and the backward
            pass starts at interval m (same values as a full pass, to the bit).
    """
    sigma = np.ascontiguousarray(sigma, dtype=float)
    alpha, beta, g = (np.ascontiguousarray(m, dtype=float) for m in (alpha, beta, g))
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    N = len(alpha)
    if N < 2:
        sc = reference_scaling(sigma, alpha, beta, g, lo, hi, w_max, x_upper, x_start)
        return sc, np.zeros(N), np.zeros(N)
    delta = np.diff(sigma)
    x_up = np.ascontiguousarray(_upper(N, w_max, x_upper))
    zone_lo = np.where(np.isfinite(lo), lo, -BIG)
    zone_hi = np.where(np.isfinite(hi), hi, BIG)
    zone = np.concatenate([zone_lo, zone_hi])
    K_lo, K_hi = np.zeros(N), np.zeros(N)
    first_empty: int | None = N - 1
    top = N - 2  # first interval of the backward pass
    if reuse is not None and reuse[2] < N - 2:
        top = max(reuse[2], 0)
        K_lo[top + 1 :], K_hi[top + 1 :] = reuse[0][top + 1 :], reuse[1][top + 1 :]
        last: tuple[float, float] | None = (float(K_lo[top + 1]), float(K_hi[top + 1]))
    else:
        last = _last_set(alpha[-1], zone_lo - g[-1], zone_hi - g[-1], float(x_up[-1]))
        if last is not None:
            K_lo[-1], K_hi[-1] = last
    if last is not None:
        lo_sets, hi_sets, empty = passes.backward(alpha, beta, g, sigma, x_up, zone, last, top)
        where = np.flatnonzero(empty > 0.5)
        first_empty = int(where[-1]) if len(where) else None
        start = 0 if first_empty is None else first_empty + 1
        K_lo[start : top + 1], K_hi[start : top + 1] = lo_sets[start:], hi_sets[start:]
    x0, feasible = _start(x_start, K_lo[0], K_hi[0], first_empty)
    x, v = np.zeros(N), np.zeros(N)
    if feasible:
        x[0] = x0
        x[1:] = passes.forward(alpha, beta, g, sigma, x_up, zone, K_lo, K_hi, x0)
        v[:-1] = (x[1:] - x[:-1]) / delta
    return Scaling(x, v, _times(x, delta), feasible, first_empty), K_lo, K_hi
