"""What the figures and the animation draw, derived once from a plan directory.

Rebuilds the robot (built-in, with the scenario's limits) and the obstacles from
scenario.yaml, then evaluates along the trajectory (decimated to at most ``max_samples``
samples): body origins, collision points, arm manipulability, exact clearance per obstacle and
the task error. Nothing here plots.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.report.plan_data import PlanData
from mmplan.robot import Limits, Robot
from mmplan.scenario.robot_entry import robot_of_entry
from mmplan.task import (
    DrawSegment,
    LinePath,
    PolynomialPath,
    ReachPoint,
    Task,
    WaypointPath,
)

#: Planner-setting keys that may hold the obstacle enlargement eps [m] (docs/conventions.md).
MARGIN_KEYS = ("margin", "obstacle_margin", "enlargement", "safety_margin")


@dataclass(frozen=True)
class ObstacleView:
    """One obstacle as the report draws it.

    Attributes:
        label: e.g. ``"1 cylinder"`` (1-based, scenario order).
        obstacle: The scene obstacle (exact distance, superellipsoid model).
        influence: Neighbourhood size [m] from the scenario, or None.
    """

    label: str
    obstacle: Any
    influence: float | None


@dataclass(frozen=True)
class ReportContext:
    """Plan data plus everything derived from the robot and scene models.

    Attributes:
        plan: The plan directory's data.
        robot: Built-in robot with the scenario's limits.
        obstacles: Obstacles in scenario order.
        margin: Obstacle enlargement eps [m] from the planner settings (0 if not set).
        index: Indices of the decimated samples (K,).
        manipulability: mu(q) at the decimated samples (K,).
        clearance: Exact distance of the robot's collision spheres to each original
            obstacle (K, n_obs) [m].
        task_error: Task error norm at every sample (N,) [m] (None if the goal is unknown).
        task_kind: ``"reach"``, ``"path"`` or ``"segment"`` (or ``""``).
        tolerance: Goal tolerance [m].
        task: The scenario's task (None if the goal form is unknown).
    """

    plan: PlanData
    robot: Robot
    obstacles: tuple[ObstacleView, ...]
    margin: float
    index: NDArray[np.intp]
    manipulability: Array
    clearance: Array
    task_error: Array | None
    task_kind: str
    tolerance: float
    task: Task | None = None

    @property
    def t_dec(self) -> Array:
        """Times of the decimated samples (K,)."""
        return np.asarray(self.plan.t[self.index], dtype=float)

    @property
    def timed(self) -> bool:
        """False when ``t`` is the segment parameter s in [0, 1] (a segment task), not time."""
        return self.task_kind != "segment"

    @property
    def t_label(self) -> str:
        """Axis label of ``t``: ``t [s]``, or ``s [-]`` for the segment parameter."""
        return "t [s]" if self.timed else "segment parameter s [-]"


def decimation(samples: int, max_samples: int) -> NDArray[np.intp]:
    """At most ``max_samples`` evenly spread indices of ``samples``, first and last included."""
    if samples <= max_samples:
        return np.arange(samples, dtype=np.intp)
    return np.unique(np.linspace(0, samples - 1, max_samples).round().astype(np.intp))


def _vector(values: Any, n: int, default: Array) -> Array:
    if values is None:
        return np.asarray(default, dtype=float)
    arr = np.asarray([float(v) for v in values], dtype=float)
    return arr if arr.shape == (n,) else np.asarray(default, dtype=float)


def scenario_limits(scenario: Mapping[str, Any], robot: Robot) -> Limits:
    """The robot's limits overridden by the resolved scenario's ``limits`` section."""
    lim = robot.limits
    section = scenario.get("limits") or {}
    joints = section.get("joints") or {}
    n_arm, n_act = len(robot.arm_coordinates), len(robot.actuators)
    jmin = _vector(joints.get("min"), n_arm, lim.joint_min)
    jmax = _vector(joints.get("max"), n_arm, lim.joint_max)
    torque = section.get("torque")
    if torque == "unlimited":
        tmin, tmax = np.full(n_act, -np.inf), np.full(n_act, np.inf)
    else:
        torque = torque or {}
        tmin = _vector(torque.get("min"), n_act, lim.torque_min)
        tmax = _vector(torque.get("max"), n_act, lim.torque_max)
    return Limits(jmin, jmax, tmin, tmax)


def build_obstacles(
    dicts: Sequence[Mapping[str, Any]], default_influence: Any = None
) -> tuple[ObstacleView, ...]:
    """Obstacles from the scenario's obstacle dicts (scene package).

    An obstacle without its own ``influence`` takes the planner's ``influence`` setting
    (``default_influence``) when that is a number.
    """
    fallback = (
        float(default_influence)
        if isinstance(default_influence, int | float) and not isinstance(default_influence, bool)
        else None
    )
    if not dicts:
        return ()
    from mmplan.scene import obstacle_from_dict

    views = []
    for i, data in enumerate(dicts):
        try:
            obstacle = obstacle_from_dict(dict(data))
        except InputError as exc:
            raise InputError(f"scenario.yaml:obstacles[{i}].{exc.field}", exc.problem) from None
        influence = getattr(obstacle, "influence", None)
        influence = fallback if influence is None else influence
        views.append(ObstacleView(f"{i + 1} {data.get('shape', '?')}", obstacle, influence))
    return tuple(views)


def build_task(goal: Mapping[str, Any]) -> Task | None:
    """The task of the scenario's ``goal`` section (docs/conventions.md forms), None if unknown."""

    def v3(values: Sequence[float]) -> tuple[float, float, float]:
        return (float(values[0]), float(values[1]), float(values[2]))

    tol = float(goal.get("tolerance", 1e-3))
    if "position" in goal:
        return ReachPoint(v3(goal["position"]), tol)
    if "segment" in goal:
        s = goal["segment"]
        return DrawSegment(v3(s["start"]), v3(s["end"]), v3(s["normal"]), tol)
    path = goal.get("path")
    if not isinstance(path, Mapping):
        return None
    kind = path.get("kind")
    if kind == "line":
        return LinePath(v3(path["start"]), v3(path["velocity"]), float(path["duration"]), tol)
    if kind == "waypoints":
        points = tuple(v3(p) for p in path["points"])
        return WaypointPath(points, tuple(float(t) for t in path["times"]), tol)
    if kind == "polynomial":
        coefficients = tuple(v3(c) for c in path["coefficients"])
        return PolynomialPath(coefficients, float(path["duration"]), tol)
    return None


def _margin(planner: Mapping[str, Any]) -> float:
    for key in MARGIN_KEYS:
        value = planner.get(key)
        if isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
    return 0.0


def build_context(plan: PlanData, max_samples: int = 1000) -> ReportContext:
    """Derive robot, obstacles and series along the trajectory from ``plan``.

    Raises:
        InputError: unknown robot, coordinates that do not match it, or a bad obstacle.
    """
    scenario = plan.scenario
    base = robot_of_entry(scenario["robot"], plan.directory)  # a name or a URDF robot
    if tuple(plan.coordinates) != tuple(base.coordinates):
        raise InputError(
            "trajectory.csv:q.*",
            f"coordinates {plan.coordinates} do not match robot {base.name} {base.coordinates}",
        )
    robot = base.with_limits(scenario_limits(scenario, base))
    planner = scenario.get("planner") or {}
    planner = planner if isinstance(planner, Mapping) else {}
    obstacles = build_obstacles(scenario.get("obstacles") or [], planner.get("influence"))
    index = decimation(plan.samples, max_samples)
    q_dec = np.ascontiguousarray(plan.q[index].T)  # (n, K): every sample in one call
    K = len(index)
    mu = np.asarray(robot.functions["manipulability"].map(K)(q_dec), dtype=float).reshape(K)
    clearance = np.full((K, len(obstacles)), np.nan)
    if obstacles and robot.collision:
        P = len(robot.collision)
        points = np.asarray(robot.functions["collision_points"].map(K)(q_dec), dtype=float)
        points = np.ascontiguousarray(points.T)  # (K * P, 3), sample-major
        radii = np.tile(robot.collision_radii, K)
        for j, view in enumerate(obstacles):
            gap = np.asarray(view.obstacle.distance(points), dtype=float) - radii
            clearance[:, j] = gap.reshape(K, P).min(axis=1)
    goal = scenario.get("goal") or {}
    task = build_task(goal) if isinstance(goal, Mapping) else None
    kind = ""
    errors = None
    if task is not None:
        errors = task.errors(plan.t, plan.ee)
        kind = {ReachPoint: "reach", DrawSegment: "segment"}.get(type(task), "path")
    return ReportContext(
        plan=plan,
        robot=robot,
        obstacles=obstacles,
        margin=_margin(planner),
        index=index,
        manipulability=mu,
        clearance=clearance,
        task_error=errors,
        task_kind=kind,
        tolerance=float(goal.get("tolerance", 1e-3)) if isinstance(goal, Mapping) else 1e-3,
        task=task,
    )
