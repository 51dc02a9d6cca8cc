"""Per-step time of the path-tracking planners of [AbdessemedDjebrani] against a NumPy baseline.

The compiled step (one CasADi call: kinematics, closed-form weighted pseudoinverse or J_t
solve, potential gradients, Heun integration) is timed against a NumPy implementation of the
same step in the same run: the robot's compiled kinematics called function by function,
eq. (27) through ``numpy.linalg.svd`` (pseudoinverse) or ``numpy.linalg.solve`` (impedance),
and the same Heun integration. Prints microseconds per step and the ratio.

Run: ``python bench/bench_tracking.py``
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from mmplan.planners.tracking.impedance import VirtualImpedance
from mmplan.planners.tracking.planner import ImpedancePlanner, PseudoinversePlanner
from mmplan.planners.tracking.pseudoinverse import WeightedPseudoinverse
from mmplan.planners.tracking.rollout import BufferedStep
from mmplan.planners.tracking.settings import ImpedanceSettings, PseudoinverseSettings
from mmplan.problem import Problem
from mmplan.robot.library import get_robot
from mmplan.scene import Scene, obstacle_from_dict
from mmplan.task import LinePath

Array = np.ndarray


def per_call_us(fn: Callable[[], object], repeat: int) -> float:
    """Best of 3 rounds of ``repeat`` calls, in microseconds per call."""
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        for _ in range(repeat):
            fn()
        best = min(best, (time.perf_counter() - t0) / repeat)
    return best * 1e6


def report(
    title: str,
    fused: Callable[[], Array],
    plain: Callable[[], Array],
    baseline: Callable[[], Array],
    ns: int,
    repeat: int,
) -> None:
    """Check that the three give the same next state, then time them and print ratios."""
    if not (
        np.allclose(fused()[:ns], baseline(), atol=1e-12)
        and np.allclose(plain()[:ns], baseline(), atol=1e-12)
    ):
        raise SystemExit(f"{title}: fused step and NumPy baseline disagree")
    a, p, b = (per_call_us(f, repeat) for f in (fused, plain, baseline))
    print(
        f"{title}\n  fused CasADi (buffer) {a:7.1f} us = {1e3 / a:5.1f} kHz | "
        f"fused, plain call {p:7.1f} us | NumPy baseline {b:7.1f} us | "
        f"baseline / fused = {b / a:.1f}"
    )


def bench_pseudoinverse(repeat: int) -> None:
    robot = get_robot("diffdrive-3dof")
    scene = Scene(
        (
            obstacle_from_dict(
                {
                    "shape": "cylinder",
                    "base_center": [2.0, 0.05, 0.0],
                    "radius": 0.15,
                    "height": 0.5,
                }
            ),
        )
    )
    settings = PseudoinverseSettings()
    model = WeightedPseudoinverse(robot, scene.obstacles, settings)
    task = LinePath((0.5, 0.0, 0.7), (0.1, 0.0, 0.0), 30.0)
    q = np.array([1.5, -0.1, 0.2, 0.1, -0.6, 1.4])
    dt, t = settings.dt, 15.0

    def ref(s: float) -> Array:
        return np.concatenate([task.position(s), task.velocity(s)])

    call = BufferedStep(model.step)

    def fused() -> Array:  # as in the rollout loop: pack, one CasADi call, copy out
        return call(np.concatenate([q, ref(t), ref(t + dt)])).copy()

    def fused_plain() -> Array:  # the same function through the ordinary call
        return np.asarray(model.step(np.concatenate([q, ref(t), ref(t + dt)]))).ravel()

    def numpy_step() -> Array:
        r0, r1 = ref(t), ref(t + dt)
        k1 = model.svd_velocity(q, r0[:3], r0[3:])
        k2 = model.svd_velocity(q + dt * k1, r1[:3], r1[3:])
        return q + 0.5 * dt * (k1 + k2)

    report(
        "pseudoinverse step (diffdrive-3dof, 1 obstacle, Heun)",
        fused,
        fused_plain,
        numpy_step,
        6,
        repeat,
    )
    problem = Problem(robot, scene, task, np.array([0, 0, 0, 0, -np.pi / 4, np.pi / 2]), settings)
    t0 = time.perf_counter()
    result = PseudoinversePlanner().plan(problem)
    wall = time.perf_counter() - t0
    n = result.trajectory.samples
    print(
        f"  diffdrive3-track plan: {wall:.3f} s for {n} steps = {wall / n * 1e6:.1f} us/step "
        f"(incl. model build, loop, clearance); status {result.status.value}"
    )


def bench_impedance(repeat: int) -> None:
    robot = get_robot("omni-3dof")
    robot = robot.with_limits(
        replace(
            robot.limits,
            joint_min=np.array([-2 * np.pi, -np.pi, -2.5]),
            joint_max=np.array([2 * np.pi, np.pi / 2, 2.5]),
        )
    )
    scene = Scene(
        (
            obstacle_from_dict(
                {
                    "shape": "cylinder",
                    "base_center": [0.35, 0.0, 0.0],
                    "radius": 0.01,
                    "height": 0.4,
                }
            ),
        )
    )
    settings = ImpedanceSettings()
    model = VirtualImpedance(robot, tuple(scene.obstacles), settings)
    task = LinePath((0.0, 0.0, 1.0), (0.1, 0.1, 0.1), 2.5, 5e-3)
    state = np.array([0.15, 0.2, 0.8, 3.3, -1.4, 0.5, 0.05, -0.02])
    dt, t = settings.dt, 1.5
    E = np.eye(3, 6)

    call = BufferedStep(model.step)

    def fused() -> Array:
        return call(
            np.concatenate([state, model.reference(task, t), model.reference(task, t + dt)])
        ).copy()

    def fused_plain() -> Array:
        v = np.concatenate([state, model.reference(task, t), model.reference(task, t + dt)])
        return np.asarray(model.step(v)).ravel()

    def rate(s: Array, r: Array) -> Array:
        q, delta = s[:6], s[6:]
        F = np.asarray(model.force(q)[0]).ravel()
        ddelta = F - delta  # B_d = K_d = 1
        J_t = np.vstack([robot.jacobian(q), E])
        xi = np.concatenate([robot.ee_position(q), q[:3]])
        xi_ref = np.concatenate([r[:3], r[6:9] + np.append(delta, 0.0)])
        dxi_ref = np.concatenate([r[3:6], r[9:12] + np.append(ddelta, 0.0)])
        u = np.linalg.solve(J_t, dxi_ref + settings.gain * (xi_ref - xi))
        return np.concatenate([u, ddelta])

    def numpy_step() -> Array:
        r0, r1 = model.reference(task, t), model.reference(task, t + dt)
        k1 = rate(state, r0)
        k2 = rate(state + dt * k1, r1)
        return state + 0.5 * dt * (k1 + k2)

    report(
        "impedance step (omni-3dof, 1 obstacle, Heun)", fused, fused_plain, numpy_step, 8, repeat
    )
    problem = Problem(
        robot,
        scene,
        task,
        np.array([0.1, 0.1, np.pi / 6, np.pi / 4, -np.pi / 2, np.pi / 4]),
        settings,
    )
    t0 = time.perf_counter()
    result = ImpedancePlanner().plan(problem)
    wall = time.perf_counter() - t0
    n = result.trajectory.samples
    print(
        f"  omni3-impedance plan: {wall:.3f} s for {n} steps = {wall / n * 1e6:.1f} us/step "
        f"(incl. model build, loop, clearance); status {result.status.value}"
    )


if __name__ == "__main__":
    bench_pseudoinverse(2000)
    bench_impedance(2000)
