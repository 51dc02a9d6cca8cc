"""Re-planning at 10 Hz among moving obstacles (extended-Jacobian generator, no compile in loop).

A simulated youBot (youbot-3r, the scenario youbot3r-obstacles-unlimited: [PajakPajak]'s task,
three obstacles, the floor, no torque or rate limits) drives to its goal while a ball of
0.2 m radius crosses its path (timed to meet the robot) and the scenario's sphere drifts to
and fro. Every cycle (0.1 s) the loop reads the robot's state (q, dq, and the time rate w of
the plan it follows, 1 without limits) and the obstacles' positions, re-plans from that state
with ``Replanner.replan`` (a 2 s horizon; the generator is compiled once, before the loop: a
moved or new obstacle only changes numbers in its parameter vector), and the simulated robot
follows the first 0.1 s of the new plan (its samples and the cubic interpolant between them,
the trajectory's meaning, :mod:`mmplan.interpolant`). Each cycle prints the time, the
distance to the goal, the clearance to the obstacles where they are now, the smallest so far,
and the re-planning time.

With the youBot's limits (``SCENARIO = "youbot3r-obstacles-torque"``) each re-plan is
time-scaled under them; the loop reaches the goal (13.7 s), but the ball, timed for the
unlimited robot, never comes near the slower one. Timed to meet it (``MEET = (2.08, 2.11)``,
``MEET_TIME = 5.5``) the ball appears in the robot's way with a path it cannot follow from its
speed within the limits: the re-plans started slower than the robot moved (a step in the
velocity; measured: w 0.43 to 0.32, 0.31 to 0.13, 0.13 to 0.009 in three cycles) and near rest
the generator diverged. Now the loop passes ``elapsed`` (how long the robot has followed the
last plan), and such a re-plan brakes along the plan the robot follows instead
(:mod:`mmplan.planners.extended_jacobian.braking`). Measured with the limits, the ball's
neighbourhood 0.5 m (``influence``; 0.2 here: a fast robot among moving obstacles needs a wide
one) and ten ball timings (``MEET_TIME`` 4.5-6.5 s, two crossing points): 8 runs reached the
goal, 7 of them without touching the ball (one touched it by 1 mm); 2 ended at 5.7 s with
neither a new path nor a braking plan (the generator diverged at once and no stretch of the
plan it followed stopped within its limits, 10 s and the dq-consistency tolerance: the loop
stops on a one-sample re-plan); a velocity step in one cycle of each of 2 runs, where braking
could not stop in time. Not solved: avoiding an obstacle that moves into a slow robot needs
more than a goal-directed generator.

Run: ``python examples/replan_moving_obstacle.py [--quiet]``.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np

import mmplan
from mmplan import interpolant
from mmplan.arrays import Array
from mmplan.planners.extended_jacobian.replan import Replanner
from mmplan.scene.scene import Scene
from mmplan.scene.sphere import Sphere

SCENARIO = "youbot3r-obstacles-unlimited"
PERIOD = 0.1  # control cycle [s] (10 Hz)
HORIZON = 2.0  # re-planning horizon [s]


#: The crossing ball: where and when it meets the path the robot takes when it does not see
#: the ball (its platform at t = MEET_TIME), its speed across that path [m/s], its direction.
MEET, MEET_TIME, BALL_SPEED = np.array([2.0, 2.05]), 2.75, 0.3
BALL_DIRECTION = np.array([-1.0, 1.0]) / np.sqrt(2.0)


def obstacles_at(base: Scene, t: float) -> Scene:
    """The scene at time t: a ball of 0.2 m radius crossing the robot's path at 0.3 m/s (a
    re-planner that ignores it collides, tests/planners/extended_jacobian/test_replan.py), the
    scenario's sphere drifting to and fro."""
    x, y = MEET + (t - MEET_TIME) * BALL_SPEED * BALL_DIRECTION
    crossing = Sphere((float(x), float(y), 0.35), 0.2, 0.2)
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
    states: list[tuple[float, Array, Array]]  # (t, q, dq) of the executed samples


def setup() -> tuple[mmplan.Problem, Replanner]:
    """The scenario and its replanner (the generator compiled or loaded here, once)."""
    problem = mmplan.load_scenario(SCENARIO).build()
    return problem, Replanner(problem, spare=2)


def run(
    seconds: float = 40.0,
    verbose: bool = True,
    ready: tuple[mmplan.Problem, Replanner] | None = None,
) -> LoopResult:
    """Drive the simulated robot for at most ``seconds``; see the module docstring."""
    problem, replanner = ready or setup()
    robot, goal = problem.robot, np.asarray(problem.task.position, dtype=float)
    q, dq, rate = np.asarray(problem.start, dtype=float), np.zeros(robot.n), 0.0
    clearance, crossing, floor_gap, times, t = np.inf, np.inf, np.inf, [], 0.0
    ground = problem.scene.ground if problem.scene.ground is not None else -np.inf
    error = float(np.linalg.norm(robot.ee_position(q) - goal))
    states = [(t, q, dq)]
    elapsed: float | None = None  # how long the robot has followed the last plan
    while t < seconds and error > problem.task.tolerance:
        scene = obstacles_at(problem.scene, t)
        begin = time.perf_counter()
        # elapsed: the robot follows the last plan, so with limits it can brake along it
        plan = replanner.replan(q, dq, scene, horizon=HORIZON, rate=rate, elapsed=elapsed)
        times.append(time.perf_counter() - begin)
        if len(plan.t) < 2:  # no motion: the goal blocked (hold a cycle) or reached, stalled
            if plan.status.value != "infeasible":
                break
            t, dq, rate = t + PERIOD, np.zeros(robot.n), 0.0  # held (no limits: stops at once)
            elapsed = None
            continue
        step = min(PERIOD, float(plan.t[-1]))
        when = np.append(plan.t[plan.t < step], step)  # the executed stretch
        qs, dqs, _ = interpolant.evaluate(plan.t, plan.q, plan.dq, when)
        now = np.inf
        for j, tj in enumerate(when):  # against the obstacles as they move
            points = robot.collision_points(qs[j])
            here = obstacles_at(problem.scene, t + tj)
            now = min(now, here.clearance(points, robot.collision_radii))
            ball = Scene(here.obstacles[3:], None)
            crossing = min(crossing, ball.clearance(points, robot.collision_radii))
            floor_gap = min(floor_gap, float(np.min(points[:, 2] - robot.collision_radii)) - ground)
        clearance = min(clearance, now)
        states += [(t + tj, qs[j], dqs[j]) for j, tj in enumerate(when) if j]
        q, dq, rate = qs[-1], dqs[-1], float(np.interp(step, plan.t, plan.u))
        t, elapsed = t + step, step
        error = float(np.linalg.norm(robot.ee_position(q) - goal))
        if verbose:
            print(f"t = {t:5.1f} s  error {error:6.3f} m  clearance {now:6.3f} m "
                  f"(smallest {clearance:6.3f} m)  re-plan {times[-1] * 1e3:5.1f} ms")
    reached = error <= problem.task.tolerance
    return LoopResult(reached, error, clearance, crossing, floor_gap, times, t, states)


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
