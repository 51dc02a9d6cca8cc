"""Speed of the time-optimal scaling (time mode): compiled passes vs the NumPy reference.

Coefficients are real: the youbot3r-obstacles-torque plan is run once and the arguments of
its ``time_optimal_scaling`` call (sigma, alpha, beta, tau_g, zone; 5 actuators) are captured,
then resampled along sigma to N = 1,250 (10 ms samples of the 12.4 s generator path) and
N = 12,000. Both implementations run in the same process on the same data; the compiled one
is the best of several runs (the machine is shared), the reference one run. Also printed:
the first build (CasADi -> C -> gcc, into an empty cache) and the CasADi-VM fallback.

Run: ``python bench/bench_topp.py``.
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from mmplan.compile import codegen
from mmplan.planners.extended_jacobian import time_scaling as ej_timescale
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.scenario.loader import load_scenario
from mmplan.time_scaling.passes import passes
from mmplan.time_scaling.topp import Scaling, reference_scaling, time_optimal_scaling

REPEAT = 20


def capture() -> tuple[Any, ...]:
    """Arguments of the scaling call of the youbot3r-obstacles-torque plan."""
    seen: list[tuple[Any, ...]] = []

    def spy(*args: Any) -> Scaling:
        seen.append(args)
        return time_optimal_scaling(*args)

    original = ej_timescale.time_optimal_scaling
    ej_timescale.time_optimal_scaling = spy  # type: ignore[assignment]
    try:
        ExtendedJacobian().plan(load_scenario("youbot3r-obstacles-torque").build())
    finally:
        ej_timescale.time_optimal_scaling = original
    return seen[-1]


def resample(args: tuple[Any, ...], n: int) -> tuple[Any, ...]:
    """The captured problem on n samples equally spaced in sigma (linear interpolation)."""
    sigma, alpha, beta, g, lo, hi = args[:6]
    s = np.linspace(sigma[0], sigma[-1], n)

    def cols(m: np.ndarray) -> np.ndarray:
        return np.column_stack([np.interp(s, sigma, c) for c in m.T])

    beta_s = cols(beta)
    beta_s[0] = 0.0  # from rest, as the plan
    return s, cols(alpha), beta_s, cols(g), lo, hi


def best(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def first_build() -> float:
    """Seconds to build the library of 5 actuators into an empty cache."""
    old = os.environ.get("MMPLAN_CACHE")
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["MMPLAN_CACHE"] = tmp
        passes.cache_clear()
        t0 = time.perf_counter()
        passes(5)
        elapsed = time.perf_counter() - t0
    if old is None:
        del os.environ["MMPLAN_CACHE"]
    else:
        os.environ["MMPLAN_CACHE"] = old
    passes.cache_clear()
    return elapsed


def main() -> None:
    print("capturing the youbot3r-obstacles-torque scaling problem (one plan) ...")
    real = capture()
    print(f"captured N = {len(real[0])}, n_act = {real[1].shape[1]}")
    print(f"first build (C compile, empty cache): {first_build():.2f} s")
    for n in (1250, 12000):
        args = resample(real, n)
        time_optimal_scaling(*args)  # loads the cached library
        t_new = best(lambda a=args: time_optimal_scaling(*a), REPEAT)  # type: ignore[misc]
        t0 = time.perf_counter()
        ref = reference_scaling(*args)
        t_ref = time.perf_counter() - t0
        new = time_optimal_scaling(*args)
        diff = max(float(np.max(np.abs(new.x - ref.x))), float(np.max(np.abs(new.v - ref.v))))
        print(
            f"N = {n:6d}: compiled {t_new * 1e3:7.2f} ms ({t_new / n * 1e6:.2f} us/sample), "
            f"reference {t_ref * 1e3:8.1f} ms, ratio {t_ref / t_new:6.0f}x; "
            f"feasible {new.feasible}/{ref.feasible}, T {new.t[-1]:.4f} s, "
            f"max |x, v difference| {diff:.1e}"
        )
    compiler = codegen.compiler
    codegen.compiler = lambda: None
    passes.cache_clear()
    try:
        args = resample(real, 1250)
        t_vm = best(lambda: time_optimal_scaling(*args), 3)
        print(f"CasADi VM fallback (no compiler), N = 1250: {t_vm * 1e3:.1f} ms")
    finally:
        codegen.compiler = compiler
        passes.cache_clear()


if __name__ == "__main__":
    main()
