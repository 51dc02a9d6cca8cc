"""Re-planning at 10 Hz among moving obstacles (extended-Jacobian generator, no compile in loop).

A simulated youBot (youbot-3r, the scenario youbot3r-obstacles-unlimited: [PajakPajak]'s
task, three obstacles, the floor) drives to its goal while a ball of 0.2 m radius crosses
its path and the scenario's sphere drifts to and fro. Every cycle (0.1 s) the loop reads
the robot's state (q, dq) and the obstacles' positions, re-plans from that state with
``Replanner.replan`` (a 2 s horizon; the generator is compiled once, before the loop: a
moved or new obstacle only changes numbers in its parameter vector), and the simulated robot
follows the first 0.1 s of the new plan. Each cycle prints the time, the distance to the
goal, the clearance to the obstacles where they are and the re-planning time.

Run: ``python examples/replan_moving_obstacle.py [--quiet]``.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np

import mmplan
from mmplan.planners.extended_jacobian.replan import Replanner
from mmplan.scene.scene import Scene
from mmplan.scene.sphere import Sphere

PERIOD = 0.1  # control cycle [s] (10 Hz)
HORIZON = 2.0  # re-planning horizon [s]


def obstacles_at(base: Scene, t: float) -> Scene:
    """The scene at time t: a ball crossing the path at 0.2 m/s, the sphere drifting."""
    crossing = Sphere((3.0 - 0.2 * t, 1.9, 0.35), 0.2, 0.2)
    drift = 0.25 * np.sin(0.5 * t)
    sphere = Sphere((1.25 + drift, 0.70, 0.45), 0.15, 0.15)
    return Scene((base.obstacles[0], sphere, base.obstacles[2], crossing), base.ground)


@dataclass(frozen=True)
class LoopResult:
    """What the loop did: reached, final error [m], smallest clearance [m], re-plan times [s]."""

    reached: bool
    error: float
    clearance: float
    crossing: float  # smallest clearance to the crossing ball alone [m]
    floor_gap: float
    replan_times: list[float]
    duration: float


def setup() -> tuple[mmplan.Problem, Replanner]:
    """The scenario and its replanner (the generator compiled or loaded here, once)."""
    problem = mmplan.load_scenario("youbot3r-obstacles-unlimited").build()
    return problem, Replanner(problem, spare=2)


def run(
    seconds: float = 40.0,
    verbose: bool = True,
    ready: tuple[mmplan.Problem, Replanner] | None = None,
) -> LoopResult:
    """Drive the simulated robot for at most ``seconds``; see the module docstring."""
    problem, replanner = ready or setup()
    robot, goal = problem.robot, np.asarray(problem.task.position, dtype=float)
    q, dq = np.asarray(problem.start, dtype=float), np.zeros(robot.n)
    clearance, crossing, floor_gap, times, t = np.inf, np.inf, np.inf, [], 0.0
    ground = problem.scene.ground if problem.scene.ground is not None else -np.inf
    error = float(np.linalg.norm(robot.ee_position(q) - goal))
    while t < seconds and error > problem.task.tolerance:
        scene = obstacles_at(problem.scene, t)
        begin = time.perf_counter()
        plan = replanner.replan(q, dq, scene, horizon=HORIZON)
        times.append(time.perf_counter() - begin)
        k = min(round(PERIOD / replanner.options.dt), len(plan.t) - 1)
        for j in range(k + 1):  # the executed stretch, against the obstacles as they move
            points = robot.collision_points(plan.q[j])
            here = obstacles_at(problem.scene, t + plan.t[j])
            clearance = min(clearance, here.clearance(points, robot.collision_radii))
            ball = Scene(here.obstacles[3:], None)
            crossing = min(crossing, ball.clearance(points, robot.collision_radii))
            floor_gap = min(floor_gap, float(np.min(points[:, 2] - robot.collision_radii)) - ground)
        q, dq = plan.q[k], plan.dq[k]
        t += plan.t[k] if k else PERIOD
        error = float(np.linalg.norm(robot.ee_position(q) - goal))
        if verbose:
            print(f"t = {t:5.1f} s  error {error:6.3f} m  clearance {clearance:6.3f} m  "
                  f"re-plan {times[-1] * 1e3:5.1f} ms")
        if k == 0:  # the plan ended at once (reached, stalled): hold the state
            break
    reached = error <= problem.task.tolerance
    return LoopResult(reached, error, clearance, crossing, floor_gap, times, t)


def main(verbose: bool) -> None:
    result = run(verbose=verbose)
    ms = np.array(result.replan_times) * 1e3
    print(f"{'reached' if result.reached else 'not reached'} after {result.duration:.1f} s, "
          f"error {result.error * 1e3:.2f} mm; smallest clearance {result.clearance:.3f} m "
          f"(to the crossing ball {result.crossing:.3f} m), floor gap {result.floor_gap:.3f} m")
    print(f"{len(ms)} re-plans: median {np.median(ms):.1f} ms, max {ms.max():.1f} ms "
          f"(cycle {PERIOD * 1e3:.0f} ms)")


if __name__ == "__main__":
    main("--quiet" not in sys.argv[1:])
