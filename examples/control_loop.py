"""The extended-Jacobian generator as an online step inside a control loop.

Each cycle the loop reads the state (q, dq), asks the generator for (ddq, tau, u) and applies
it. Here the "robot" is a simulation: it integrates ddq (semi-implicit Euler, one generator
call per cycle of the scenario's dt) and keeps the wheels rolling by projecting dq into
ker A(q) (wheel metric, as the planner does). The scenario is [Pajak]'s run,
youbot4r-reach-smooth-unlimited: wheel torques limited to +-0.2 N m, virtual control u
starting at 0, no velocity or acceleration limits (the online step does not hold those: the
planner holds them by re-timing a whole plan, docs/extended_jacobian.md).

Run: ``python examples/control_loop.py [SECONDS] [--compiled]`` (``--compiled`` generates C
for the step: a one-time build of a few seconds, then about 8 us a call instead of ~100 us).
"""

from __future__ import annotations

import dataclasses
import sys
import time

import numpy as np

import mmplan
from mmplan.planners.extended_jacobian.generator import wheel_metric_inverse


def main(seconds: float, compiled: bool) -> None:
    problem = mmplan.load_scenario("youbot4r-reach-smooth-unlimited").build()
    settings = problem.settings.model_copy(update={"codegen": compiled})
    problem = dataclasses.replace(problem, settings=settings)
    robot, goal = problem.robot, np.asarray(problem.task.position, dtype=float)
    online = mmplan.get_planner("extended-jacobian")().online(problem)
    dt = float(settings.dt)
    winv = wheel_metric_inverse(robot)
    q, dq = np.asarray(problem.start, dtype=float), np.zeros(robot.n)
    lo, hi = robot.limits.torque_min, robot.limits.torque_max
    start_error = float(np.linalg.norm(robot.ee_position(q) - goal))
    worst_tau, worst_pfaffian, u_min, u_max, clock = 0.0, 0.0, 1.0, 0.0, 0.0
    steps = round(seconds / dt)
    for _ in range(steps):
        begin = time.perf_counter()
        ddq, tau, u = online.step(q, dq)  # the controller's call
        clock += time.perf_counter() - begin
        worst_tau = max(worst_tau, float(np.max(np.maximum(tau - hi, lo - tau))))
        u_min, u_max = min(u_min, u), max(u_max, u)
        dq = dq + dt * ddq  # the simulated robot
        q = q + dt * dq
        A = robot.pfaffian(q)
        WA = winv[:, None] * A.T
        dq = dq - WA @ np.linalg.solve(A @ WA, A @ dq)  # wheels roll without slipping
        worst_pfaffian = max(worst_pfaffian, float(np.linalg.norm(robot.pfaffian(q) @ dq)))
    end_error = float(np.linalg.norm(robot.ee_position(q) - goal))
    print(f"online step: {'compiled C' if online.compiled else 'CasADi VM'}, {steps} calls "
          f"of dt = {dt * 1e3:.0f} ms, {clock / steps * 1e6:.1f} us per call")
    print(f"distance to goal: {start_error:.4f} m -> {end_error:.4f} m after {seconds:g} s")
    print(f"virtual control u in [{u_min:.3f}, {u_max:.3f}]; torque limits exceeded by at most "
          f"{max(worst_tau, 0.0):.3g} N m (safety zone eps 0.1 inside them)")
    print(f"max |A(q) dq| = {worst_pfaffian:.2g} m/s; NumPy fallbacks: {online.fallbacks}")


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    main(float(args[0]) if args else 3.0, "--compiled" in sys.argv)
