"""Seeded random TIAGo scenes for the extended-Jacobian planner (test_random_tiago.py).

Goals all around the robot (the heading stratified over the full circle), 1-2.5 m from the
start, low (0.3-0.6 m) and high (0.8-1.3 m); 1-4 obstacles: every third scene a table
with its goal over the top (within reach of the near edge), the others cylinders (pillars,
bins), boxes (crates) and spheres near the straight line to the goal, never within
``START_GAP`` of the start's collision spheres nor within ``GOAL_GAP`` of the goal. The
robot's own torque and rate limits (from its URDF) apply.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mmplan.robot.library import get_robot
from mmplan.scene.scene import Scene

SEED = 20261124
COUNT = 30
#: A mid-range "ready" posture (torso 0.1 m, the arm bent in front of the body).
START = [0.0, 0.0, 0.0, 0.0, 0.0, 0.1, 0.5, -0.5, -1.5, 1.8, 0.5, 0.8, 0.0]
#: Obstacles keep this clearance [m] from the start's collision spheres and from the goal.
START_GAP, GOAL_GAP = 0.3, 0.45
#: Planner settings of the set (dt measured on TIAGo: see the test module).
PLANNER: dict[str, Any] = {"method": "extended-jacobian", "t_max": 30.0, "dt": 0.02}


def _table(rng: np.random.Generator, heading: float, dist: float) -> tuple[dict[str, Any], Any]:
    """A table across the line to the goal at ``dist``, and a goal over its near part."""
    depth, width = rng.uniform(0.5, 0.8), rng.uniform(0.8, 1.4)
    height = rng.uniform(0.6, 0.78)
    u = np.array([np.cos(heading), np.sin(heading)])
    centre = (dist + depth / 2) * u  # near edge at ``dist`` from the start
    over = rng.uniform(0.1, 0.25)  # goal this far beyond the near edge
    side = rng.uniform(-0.3, 0.3) * np.array([-u[1], u[0]])
    goal_xy = (dist + over) * u + side
    # the hand's spheres reach 0.34 m beyond the flange (the end-effector point): room for them
    goal = np.array([goal_xy[0], goal_xy[1], height + rng.uniform(0.3, 0.4)])
    table = {
        "shape": "box",
        "center": [float(centre[0]), float(centre[1]), height / 2],
        "size": [float(depth), float(width), float(height)],
        "yaw": float(heading),
    }
    return table, goal


def _obstacle(rng: np.random.Generator, goal: np.ndarray) -> dict[str, Any]:
    """One cylinder, box or sphere near the straight start -> goal line (or anywhere near)."""
    along = rng.uniform(0.25, 0.8)
    normal = np.array([-goal[1], goal[0]]) / np.hypot(goal[0], goal[1])
    c = goal[:2] * along + normal * rng.normal(0.0, 0.6)
    kind = str(rng.choice(["cylinder", "box", "sphere"]))
    if kind == "cylinder":
        return {
            "shape": "cylinder",
            "base_center": [float(c[0]), float(c[1]), 0.0],
            "radius": float(rng.uniform(0.1, 0.25)),
            "height": float(rng.uniform(0.4, 1.5)),
        }
    if kind == "sphere":
        return {
            "shape": "sphere",
            "center": [float(c[0]), float(c[1]), float(rng.uniform(0.3, 1.2))],
            "radius": float(rng.uniform(0.08, 0.2)),
        }
    h = float(rng.uniform(0.2, 0.8))
    return {
        "shape": "box",
        "center": [float(c[0]), float(c[1]), h / 2],
        "size": [float(rng.uniform(0.2, 0.5)), float(rng.uniform(0.2, 0.5)), h],
        "yaw": float(rng.uniform(-np.pi, np.pi)),
    }


def _clear(data: dict[str, Any], start_spheres: tuple[np.ndarray, np.ndarray], goal: np.ndarray,
           goal_gap: float = GOAL_GAP) -> bool:
    scene = Scene.from_dicts([data])
    centres, radii = start_spheres
    return bool(
        float((scene.distances(centres)[:, 0] - radii).min()) > START_GAP
        and float(scene.distances(goal[None, :]).min()) > goal_gap
    )


def random_scenario(rng: np.random.Generator, index: int, count: int = COUNT) -> dict[str, Any]:
    """Scenario ``index`` of ``count`` in the YAML form (docs/conventions.md)."""
    robot = get_robot("tiago")
    start = np.asarray(START)
    spheres = (robot.collision_points(start), np.asarray(robot.collision_radii))
    heading = 2.0 * np.pi * (index + rng.uniform(0.0, 1.0)) / count - np.pi
    obstacles: list[dict[str, Any]] = []
    if index % 3 == 0:
        table, goal = _table(rng, heading, rng.uniform(1.0, 1.8))
        obstacles.append(table)
    else:
        dist = rng.uniform(1.0, 2.5)
        height = rng.uniform(0.3, 0.6) if index % 3 == 1 else rng.uniform(0.8, 1.3)
        goal = np.array([dist * np.cos(heading), dist * np.sin(heading), height])
    wanted = int(rng.integers(1, 5))
    for _ in range(200):
        if len(obstacles) == wanted:
            break
        data = _obstacle(rng, goal)
        if _clear(data, spheres, goal) and all(
            float(Scene.from_dicts([other]).distances(np.array([_centre(data)])).min()) > 0.3
            for other in obstacles
        ):
            obstacles.append(data)
    return {
        "name": f"tiago-random-{index}",
        "robot": "tiago",
        "start": START,
        "goal": {"position": [float(v) for v in goal], "tolerance": 0.001},
        "obstacles": obstacles,
        "planner": dict(PLANNER),
    }


def _centre(data: dict[str, Any]) -> list[float]:
    if "center" in data:
        return [float(v) for v in data["center"]]
    base = data["base_center"]
    return [float(base[0]), float(base[1]), float(data["height"]) / 2]


def scenarios(seed: int = SEED, count: int = COUNT) -> list[dict[str, Any]]:
    """The seeded set."""
    rng = np.random.default_rng(seed)
    return [random_scenario(rng, i, count) for i in range(count)]
