"""Speed of the time-optimal scaling (time mode): compiled passes vs the NumPy reference.

Coefficients are real: two plans are run once and the arguments of their first
``time_optimal_scaling`` call are captured: youbot3r-obstacles-torque-unlimited (the papers'
robot: sigma, alpha, beta, tau_g, zone of 5 actuators) and youbot3r-obstacles-torque (the
youBot's rate limits: 14 rows = 5 efforts, 2 wheel accelerations, 6 sides of the platform
acceleration polygon, the yaw acceleration, and per-sample velocity bounds x_upper). Each is
resampled along sigma to N = 1,250 (10 ms samples of the 12.4 s generator path) and N = 12,000.
Both implementations run in the same process on the same data; the compiled one (the C loops
of ``time_scaling/native.py``) is the best of several runs (the machine is shared), the
reference one run. Also printed: the first build (gcc, into an empty cache) and the CasADi-VM
fallback.

Last: ours against toppra on the problem the tests compare them on (same duration to 1e-5 s),
both from the same inverse-dynamics function to the scaling.

Run: ``python bench/bench_topp.py``.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from collections.abc import Callable
from importlib.metadata import version
from pathlib import Path
from typing import Any

import numpy as np

from mmplan.compile import codegen
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.scenario.loader import load_scenario
from mmplan.time_scaling import native, retime
from mmplan.time_scaling.passes import passes
from mmplan.time_scaling.topp import (
    Scaling,
    reference_scaling,
    scaling_with_sets,
    time_optimal_scaling,
)

REPEAT = 20
Call = tuple[tuple[Any, ...], dict[str, Any]]


def capture(name: str) -> Call:
    """Arguments of the first scaling call of the plan of scenario ``name`` (the re-timing
    calls ``time_optimal_scaling`` without rate limits, ``scaling_with_sets`` with them)."""
    seen: list[Call] = []

    def spy(*args: Any, **kwargs: Any) -> Scaling:
        seen.append((args, kwargs))
        return time_optimal_scaling(*args, **kwargs)

    def spy_sets(*args: Any, **kwargs: Any) -> tuple[Scaling, np.ndarray, np.ndarray]:
        seen.append((args, {k: v for k, v in kwargs.items() if k != "reuse"}))
        return scaling_with_sets(*args, **kwargs)

    originals = retime.time_optimal_scaling, retime.scaling_with_sets
    retime.time_optimal_scaling = spy  # type: ignore[assignment]
    retime.scaling_with_sets = spy_sets  # type: ignore[assignment]
    try:
        ExtendedJacobian().plan(load_scenario(name).build())
    finally:
        retime.time_optimal_scaling, retime.scaling_with_sets = originals
    return seen[0]


def resample(call: Call, n: int) -> Call:
    """The captured problem on n samples equally spaced in sigma (linear interpolation)."""
    args, kwargs = call
    sigma, alpha, beta, g, lo, hi = args[:6]
    s = np.linspace(sigma[0], sigma[-1], n)

    def cols(m: np.ndarray) -> np.ndarray:
        return np.column_stack([np.interp(s, sigma, c) for c in m.T])

    beta_s = cols(beta)
    beta_s[0] = 0.0  # from rest, as the plan
    new = dict(kwargs)
    if kwargs.get("x_upper") is not None:
        new["x_upper"] = np.interp(s, sigma, np.minimum(kwargs["x_upper"], 1.0))
    return (s, cols(alpha), beta_s, cols(g), lo, hi, *args[6:]), new


def best(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def first_build() -> float:
    """Seconds to build the C loops of the passes into an empty cache."""
    old = os.environ.get("MMPLAN_CACHE")
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["MMPLAN_CACHE"] = tmp
        native.kernels.cache_clear()
        t0 = time.perf_counter()
        native.kernels()
        elapsed = time.perf_counter() - t0
    if old is None:
        del os.environ["MMPLAN_CACHE"]
    else:
        os.environ["MMPLAN_CACHE"] = old
    native.kernels.cache_clear()
    return elapsed


def main() -> None:
    print(f"first build (C compile, empty cache, any row count): {first_build():.2f} s")
    for name in ("youbot3r-obstacles-torque-unlimited", "youbot3r-obstacles-torque"):
        print(f"capturing the {name} scaling problem (one plan) ...")
        real = capture(name)
        print(f"captured N = {len(real[0][0])}, rows = {real[0][1].shape[1]}, "
              f"velocity bounds: {real[1].get('x_upper') is not None}")  # fmt: skip
        for n in (1250, 12000):
            args, kw = resample(real, n)
            time_optimal_scaling(*args, **kw)  # loads (or builds) the cached library
            t_new = best(lambda a=args, k=kw: time_optimal_scaling(*a, **k), REPEAT)  # type: ignore[misc]
            t0 = time.perf_counter()
            ref = reference_scaling(*args, **kw)
            t_ref = time.perf_counter() - t0
            new = time_optimal_scaling(*args, **kw)
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
    native.kernels.cache_clear()
    try:
        args, kw = resample(capture("youbot3r-obstacles-torque-unlimited"), 1250)
        t_vm = best(lambda: time_optimal_scaling(*args, **kw), 3)
        print(f"CasADi VM fallback (no compiler), N = 1250, 5 rows: {t_vm * 1e3:.1f} ms")
    finally:
        codegen.compiler = compiler
        passes.cache_clear()
        native.kernels.cache_clear()
    for n in (201, 1001):
        against_toppra(n)


def against_toppra(n: int) -> None:
    """Ours and toppra (seidel solver, first-order interpolation) on the same 3-dof spline
    with joint velocity, acceleration and torque limits (the problem of
    tests/time_scaling/test_rates.py, where the durations agree to 1e-5 s). Two timings, best
    of several: the solve alone (coefficients made: ours as arrays, toppra's solver wrapper
    built) and from the inverse-dynamics function (a Python callback per grid point, which
    both pay) to the scaling."""
    try:
        from toppra import algorithm, constraint
    except ImportError:
        print("toppra not installed: comparison skipped (pip install toppra)")
        return
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests.time_scaling import test_rates as problem

    path = problem._spline()
    grid = np.linspace(0.0, 1.0, n)
    interp = constraint.DiscretizationType.Interpolation

    def setup() -> Any:
        cons = [
            constraint.JointVelocityConstraint(problem.VLIM),
            constraint.JointAccelerationConstraint(problem.ALIM, discretization_scheme=interp),
            constraint.JointTorqueConstraint(
                problem._inv_dyn, np.column_stack([-problem.TLIM, problem.TLIM]), np.zeros(3),
                discretization_scheme=interp,
            ),
        ]  # fmt: skip
        return algorithm.TOPPRA(cons, path, gridpoints=grid, solver_wrapper="seidel")

    alg = setup()
    captured: list[Call] = []
    scaled = problem.time_optimal_scaling

    def spy(*a: Any, **k: Any) -> Scaling:
        captured.append((a, k))
        return scaled(*a, **k)

    problem.time_optimal_scaling = spy
    try:
        ours = problem._ours(path, grid)
    finally:
        problem.time_optimal_scaling = scaled
    args, kwargs = captured[0]
    solve_ours = best(lambda: time_optimal_scaling(*args, **kwargs), REPEAT)
    solve_theirs = best(lambda: alg.compute_parameterization(0.0, 0.0), 5)
    full_ours = best(lambda: problem._ours(path, grid), 5)
    full_theirs = best(lambda: setup().compute_parameterization(0.0, 0.0), 5)
    _, sd, _ = alg.compute_parameterization(0.0, 0.0)
    t_theirs = float(np.sum(2.0 * np.diff(grid) / (sd[1:] + sd[:-1])))
    print(f"vs toppra {version('toppra')}, N = {n}: solve {solve_ours * 1e3:.3f} ms vs "
          f"{solve_theirs * 1e3:.2f} ms ({solve_theirs / solve_ours:.0f}x); from the inverse "
          f"dynamics {full_ours * 1e3:.2f} vs {full_theirs * 1e3:.2f} ms "
          f"({full_theirs / full_ours:.1f}x); durations {ours.t[-1]:.6f} / {t_theirs:.6f} s")


if __name__ == "__main__":
    main()
