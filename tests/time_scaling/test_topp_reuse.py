"""Re-using the controllable sets of an earlier scaling (``topp.scaling_with_sets(reuse=...)``,
used by the tightening rounds of :func:`mmplan.time_scaling.retime.retime_path`): tighten the
rows at samples <= m, and the scaling that starts its backward pass at interval m from the
earlier sets equals the full scaling of the tightened problem, bit for bit."""

from __future__ import annotations

import numpy as np

from mmplan.time_scaling.topp import scaling_with_sets

from .test_topp import _random_problem


def _tightened(args: tuple, m: int, factor: float) -> tuple:
    """``args`` with the zone rows and the x bound at samples <= m scaled (changed data)."""
    sigma, alpha, beta, g, lo, hi, w_max = args
    alpha, beta = alpha.copy(), beta.copy()
    alpha[: m + 1] *= factor
    beta[: m + 1] *= factor
    up = np.full(len(sigma), w_max**2)
    up[: m + 1] /= factor**2
    return sigma, alpha, beta, g, lo, hi, w_max, up


def _scale(args: tuple, reuse: tuple | None = None) -> tuple:
    sigma, alpha, beta, g, lo, hi, w_max, up = args
    return scaling_with_sets(sigma, alpha, beta, g, lo, hi, w_max, up, reuse=reuse)


def test_reused_sets_give_the_full_scaling_bit_for_bit() -> None:
    """Seeded problems over one and several compiled chunks (64 intervals), changes ending
    at the first, a middle and the last-but-one sample: same x, v, t, K and verdicts."""
    rng = np.random.default_rng(3)
    checked = 0
    for N in (30, 150, 300):
        for _ in range(6):
            args = _random_problem(rng, N, 5)
            first, k_lo, k_hi = scaling_with_sets(*args)
            if first.first_empty is not None:
                continue
            for m in (0, N // 2, N - 3):
                changed = _tightened(args, m, 1.3)
                full, f_lo, f_hi = _scale(changed)
                part, p_lo, p_hi = _scale(changed, (k_lo, k_hi, m))
                assert (part.feasible, part.first_empty) == (full.feasible, full.first_empty)
                for a, b in ((part.x, full.x), (part.v, full.v), (part.t, full.t),
                             (p_lo, f_lo), (p_hi, f_hi)):  # fmt: skip
                    np.testing.assert_array_equal(a, b)
                checked += 1
    assert checked >= 20


def test_a_too_late_restart_would_be_wrong() -> None:
    """The test above can fail: restarting after the last changed sample (m + 1) misses the
    change at m and gives other sets on some problem."""
    rng = np.random.default_rng(3)
    differ = False
    for _ in range(10):
        args = _random_problem(rng, 150, 5)
        first, k_lo, k_hi = scaling_with_sets(*args)
        if first.first_empty is not None:
            continue
        changed = _tightened(args, 75, 1.3)
        _, f_lo, f_hi = _scale(changed)
        _, p_lo, p_hi = _scale(changed, (k_lo, k_hi, 74))
        differ = differ or not (np.array_equal(p_lo, f_lo) and np.array_equal(p_hi, f_hi))
    assert differ
