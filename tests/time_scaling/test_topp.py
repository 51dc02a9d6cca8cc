"""Time-optimal scaling of the time mode (topp.py) against a closed form (issue 7, random-6).

Path from rest with a constant generator acceleration: q(sigma) = -a sigma^2 / 2, so
q' = -a sigma, q'' = -a, and one actuator with tau = m ddq = m (x q'' + v q' / 2). Under
|tau| <= tau_max the time-optimal motion is the constant acceleration -tau_max / m, i.e. the
constant rate x = w^2 = c = tau_max / (m a) for sigma > 0, real time t = sigma / sqrt(c).
Regression for random-6 of the random set: the collocation discretization (zone checked only
at the start of each interval) let the first intervals zig-zag (x = 0, 0.0045, 0, 0.0022 here,
torque 3x the limit on arrival), so q was not the integral of dq.
"""

from __future__ import annotations

import numpy as np
import pytest

from mmplan.compile import codegen
from mmplan.time_scaling import native
from mmplan.time_scaling import passes as ej_topp_passes
from mmplan.time_scaling.passes import passes
from mmplan.time_scaling.topp import Scaling, reference_scaling, time_optimal_scaling

M, A, TAU_MAX, DELTA = 1.0, 600.0, 1.35, 0.005


def _scaled() -> tuple[np.ndarray, np.ndarray, np.ndarray, Scaling]:
    sigma = np.arange(0.0, 0.5 + DELTA / 2, DELTA)
    qp = -A * sigma
    alpha = np.full((len(sigma), 1), -M * A)
    beta = (M * qp)[:, None]
    sc = time_optimal_scaling(
        sigma, alpha, beta, np.zeros_like(alpha), np.array([-TAU_MAX]), np.array([TAU_MAX])
    )
    return sigma, alpha, beta, sc


def test_torque_in_zone_at_both_ends_of_every_interval() -> None:
    """The constant v_i of an interval keeps tau in the zone at its start and at its end."""
    _, alpha, beta, sc = _scaled()
    assert sc.feasible
    start = alpha[:-1, 0] * sc.x[:-1] + 0.5 * beta[:-1, 0] * sc.v[:-1]
    end = alpha[1:, 0] * sc.x[1:] + 0.5 * beta[1:, 0] * sc.v[:-1]
    assert np.abs(start).max() <= TAU_MAX * (1 + 1e-9)
    assert np.abs(end).max() <= TAU_MAX * (1 + 1e-9)


def test_rate_rises_monotonically_to_the_closed_form() -> None:
    """No zig-zag: x never drops while the limit binds, and tends to c = tau_max / (m a)."""
    sigma, _, _, sc = _scaled()
    c = TAU_MAX / (M * A)
    assert np.all(np.diff(sc.x[:-1]) >= -1e-12)
    assert np.allclose(sc.x[20:-1], c, rtol=0.05)
    assert abs(sc.t[-1] - sigma[-1] / np.sqrt(c)) < 0.03 * sigma[-1] / np.sqrt(c)


def test_q_is_the_integral_of_dq() -> None:
    """dq = w q' integrates (trapezoid, on the scaled times) to q(sigma), as the checker asks.

    Per-step residual |dq| scale is 14 rad/s; the zig-zag gave 0.05 rad/s on the second and
    third intervals, the first (w from 0 at rest) is 0.03 rad/s with or without it.
    """
    sigma, _, _, sc = _scaled()
    q = -A * sigma**2 / 2
    dq = np.sqrt(sc.x) * (-A * sigma)
    dt = np.diff(sc.t)
    residual = np.abs(np.diff(q) - 0.5 * dt * (dq[1:] + dq[:-1])) / dt
    assert residual.max() < 1e-2 * np.abs(dq).max()
    assert residual[1:].max() < 0.01


# --- compiled passes against the NumPy reference (vertex-enumeration LPs) -------------------


def _random_problem(rng: np.random.Generator, N: int, n: int) -> tuple:
    """Smooth random coefficients; zone from tight (infeasible) to loose, some limits
    infinite, half of the paths from rest (beta_0 = 0), w_max 0.7, 1 or 2."""
    sigma = np.concatenate([[0.0], np.cumsum(rng.uniform(0.5, 1.5, N - 1) * 2.0 / N)])

    def smooth(scale: float) -> np.ndarray:
        freq, phase = rng.uniform(0.5, 4.0, (3, n)), rng.uniform(0.0, 2 * np.pi, (3, n))
        amp = rng.normal(0.0, scale, (3, n))
        return np.einsum("kn,skn->sn", amp, np.sin(sigma[:, None, None] * freq + phase))

    alpha, beta, g = smooth(3.0), smooth(1.0), smooth(2.0)
    if rng.random() < 0.5:
        beta[0] = 0.0
    margin = rng.uniform(-0.3, 2.0, n) * np.abs(alpha).max(axis=0)
    hi = g.max(axis=0) + margin * rng.uniform(0.1, 1.0, n)
    lo = g.min(axis=0) - margin * rng.uniform(0.1, 1.0, n)
    lo[rng.random(n) < 0.2] = -np.inf
    hi[rng.random(n) < 0.2] = np.inf
    return sigma, alpha, beta, g, lo, hi, float(rng.choice([0.7, 1.0, 2.0]))


def _assert_same(args: tuple, **kwargs: object) -> Scaling:
    new, ref = time_optimal_scaling(*args, **kwargs), reference_scaling(*args, **kwargs)
    assert (new.feasible, new.first_empty) == (ref.feasible, ref.first_empty)
    np.testing.assert_allclose(new.x, ref.x, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(new.v, ref.v, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(new.t, ref.t, rtol=1e-9, atol=1e-12)
    return new


def test_compiled_passes_match_the_reference_on_random_problems() -> None:
    """60 seeded problems, 2-300 samples (and the chunk edges 257, 258), 1, 2 or 5
    actuators: same feasibility, first empty set and x, v, t (to 1e-9; measured 1e-14)."""
    rng = np.random.default_rng(7)
    sizes = [2, 3, 257, 258] + [int(s) for s in rng.integers(4, 300, 56)]
    feasible = empty = 0
    for N in sizes:
        sc = _assert_same(_random_problem(rng, N, int(rng.choice([1, 2, 5]))))
        feasible, empty = feasible + sc.feasible, empty + (sc.first_empty is not None)
    assert feasible >= 20 and empty >= 5, (feasible, empty)


def test_start_not_controllable_and_zero_rows_match_the_reference() -> None:
    """x_0 = 0 not controllable with every set non-empty (the zone needs x >= 0.1); an
    actuator with alpha = beta = 0 (rows parallel to every other) whose gravity is 1e-12
    over its limit (inside the slack: feasible), then 0.5 over it at samples 20-25 (the
    sets there are empty)."""
    sigma = np.linspace(0.0, 1.0, 50)
    ones = np.ones((50, 1))
    sc = _assert_same((sigma, ones, 0 * ones, 0 * ones, np.array([0.1]), np.array([1.0])))
    assert not sc.feasible and sc.first_empty is None
    alpha = np.hstack([ones * -5.0, 0 * ones])
    beta = np.hstack([-np.linspace(0.0, 3.0, 50)[:, None], 0 * ones])
    g = np.hstack([0 * ones, (2.0 + 1e-12) * ones])
    zone = (np.array([-1.0, -1.0]), np.array([1.0, 2.0]))
    sc = _assert_same((sigma, alpha, beta, g, *zone))
    assert sc.feasible and sc.x.max() > 0.1
    g[20:26, 1] = 2.5
    sc = _assert_same((sigma, alpha, beta, g, *zone))
    assert not sc.feasible and sc.first_empty == 25


def test_torques_stay_in_the_zone_at_both_ends_of_every_interval() -> None:
    """tau = alpha x + beta v / 2 + tau_g at sample i and i + 1 with the v of interval i.

    Regression: without the clip of x_{i+1} into K_{i+1} the 14th problem here broke the
    zone by 8e-3 N m (x a roundoff outside K_i, excess growing 1.3x a step from sample 128).
    """
    rng = np.random.default_rng(11)
    checked = 0
    while checked < 15:
        sigma, alpha, beta, g, lo, hi, w_max = _random_problem(rng, int(rng.integers(50, 400)), 5)
        sc = time_optimal_scaling(sigma, alpha, beta, g, lo, hi, w_max)
        if not sc.feasible:
            continue
        checked += 1
        v = sc.v[:-1, None]
        for tau in (alpha[:-1] * sc.x[:-1, None] + 0.5 * beta[:-1] * v + g[:-1],
                    alpha[1:] * sc.x[1:, None] + 0.5 * beta[1:] * v + g[1:]):  # fmt: skip
            assert np.all(tau <= hi + 1e-9) and np.all(tau >= lo - 1e-9)
        assert np.all(sc.x >= 0) and np.all(sc.x <= w_max**2)


def test_each_step_is_the_largest_with_a_feasible_completion() -> None:
    """Greedy maximality, by an independent LP (HiGHS) over the whole profile: with x_0..x_i
    fixed, the largest x_{i+1} of any profile meeting every interval's zone (both ends), the
    rest condition at the last sample and 0 <= x <= w_max^2 is the one taken."""
    from scipy.optimize import linprog

    rng = np.random.default_rng(3)
    done = 0
    while done < 3:
        sigma, alpha, beta, g, lo, hi, w_max = _random_problem(rng, 30, 3)
        sc = time_optimal_scaling(sigma, alpha, beta, g, lo, hi, w_max)
        if not sc.feasible:
            continue
        done += 1
        N, n = alpha.shape
        rows, lhs, rhs = [], [], []
        for i in range(N - 1):
            d = sigma[i + 1] - sigma[i]
            for k in range(n):  # tau at i and at i + 1 as rows on (x_i, x_{i+1})
                for j, (ax, bv) in enumerate([(alpha[i, k], beta[i, k]),
                                              (alpha[i + 1, k], beta[i + 1, k])]):  # fmt: skip
                    row = np.zeros(N)
                    row[i] -= 0.5 * bv / d
                    row[i + 1] += 0.5 * bv / d
                    row[i + j] += ax
                    rows.append(row)
                    lhs.append(lo[k] - g[i + j, k])
                    rhs.append(hi[k] - g[i + j, k])
        for k in range(n):
            row = np.zeros(N)
            row[-1] = alpha[-1, k]
            rows.append(row)
            lhs.append(lo[k] - g[-1, k])
            rhs.append(hi[k] - g[-1, k])
        A, lo_b, hi_b = np.array(rows), np.array(lhs), np.array(rhs)
        up, down = np.isfinite(hi_b), np.isfinite(lo_b)
        A_ub = np.vstack([A[up], -A[down]])
        b_ub = np.concatenate([hi_b[up], -lo_b[down]]) + 1e-9
        for i in range(N - 1):
            bounds = [(x - 1e-10, x + 1e-10) for x in sc.x[: i + 1]]
            bounds += [(0.0, w_max**2)] * (N - i - 1)
            c = np.zeros(N)
            c[i + 1] = -1.0
            res = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=bounds, method="highs")
            assert res.status == 0
            assert abs(res.x[i + 1] - sc.x[i + 1]) < 1e-6


def test_casadi_vm_fallback_matches_the_reference(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without a C compiler the passes run in the CasADi VM, with the same results."""
    monkeypatch.setattr(codegen, "compiler", lambda: None)
    passes.cache_clear()
    native.kernels.cache_clear()
    try:
        assert isinstance(passes(5)[0], ej_topp_passes._VMChunk)
        assert native.kernels() is None
        rng = np.random.default_rng(5)
        outcomes = [_assert_same(_random_problem(rng, N, 5)).feasible for N in (40, 300)]
        assert outcomes == [False, True]  # an empty set, and both passes over two chunks
    finally:
        passes.cache_clear()
        native.kernels.cache_clear()


def test_many_rows_use_the_mapped_backward_step_and_match_the_reference() -> None:
    """Above MAPPED_ABOVE rows (efforts plus acceleration rows) the pair projections run as one
    mapped function: same results as the reference (feasible and empty cases, two chunks)."""
    assert ej_topp_passes.MAPPED_ABOVE < 12
    rng = np.random.default_rng(12)
    outcomes = []
    for N in (40, 300, 257, 120):
        sc = _assert_same(_random_problem(rng, N, 12))
        outcomes.append(sc.feasible)
    assert True in outcomes and False in outcomes
