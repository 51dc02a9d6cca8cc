"""A scenario from a planning problem built in Python (no scenario file).

:func:`scenario_from_problem` records what ``mmplan check`` needs to rebuild the problem: the
robot (a built-in robot's name, or the arguments a URDF robot was loaded with:
:func:`~mmplan.scenario.robot_entry.record_robot`), its effective limits, the start, the task
as a goal, the obstacles, the floor height and the planner settings.
:func:`~mmplan.io.plan_folder.write_plan` uses it when it is given no scenario.
"""

from __future__ import annotations

from typing import Any

from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.problem import Problem
from mmplan.scenario.loader import Scenario, limits_dict
from mmplan.scenario.robot_entry import record_robot
from mmplan.task import DrawSegment, LinePath, PolynomialPath, ReachPoint, Task, WaypointPath


def goal_dict(task: Task) -> dict[str, Any]:
    """The scenario ``goal:`` form of a task.

    Raises:
        InputError: a task kind scenario files cannot state.
    """
    tol = float(task.tolerance)
    if isinstance(task, ReachPoint):
        return {"position": _list(task.position), "tolerance": tol}
    if isinstance(task, LinePath):
        return {"path": {"kind": "line", "start": _list(task.start),
                         "velocity": _list(task.speed), "duration": float(task.duration)},
                "tolerance": tol}
    if isinstance(task, WaypointPath):
        return {"path": {"kind": "waypoints", "points": [_list(p) for p in task.points],
                         "times": [float(t) for t in task.times]}, "tolerance": tol}
    if isinstance(task, PolynomialPath):
        return {"path": {"kind": "polynomial",
                         "coefficients": [_list(c) for c in task.coefficients],
                         "duration": float(task.duration)}, "tolerance": tol}
    if isinstance(task, DrawSegment):
        return {"segment": {"start": _list(task.start), "end": _list(task.end),
                            "normal": _list(task.normal)}, "tolerance": tol}
    raise InputError("task", f"a {type(task).__name__} cannot be written as a scenario goal "
                     "(position, path or segment)")


def scenario_from_problem(problem: Problem, name: str = "python",
                          source: str = "<python>") -> Scenario:
    """The scenario of a problem built in Python (robot, limits, start, task, scene, settings).

    The problem's robot is used as it is (not built again); the start is not checked (a start
    outside the limits or in collision is a failed check of the plan, not bad input).

    Raises:
        InputError: a robot that cannot be recorded (neither built in nor loaded from a URDF
            file or text by :func:`~mmplan.robot.urdf.load_urdf_robot`) or a task kind that no
            goal form states.
    """
    robot = problem.robot
    data = {
        "name": name,
        "robot": record_robot(robot),
        "start": _list(problem.start),
        "goal": goal_dict(problem.task),
        "obstacles": [o.to_dict() for o in problem.scene.obstacles],
        "ground": problem.scene.ground,
        "limits": limits_dict(robot),
        "planner": problem.settings.model_dump(mode="json"),
    }
    return Scenario.from_dict(data, source, require_planner=False, check_start=False,
                              robot=robot)


def _list(values: Array | tuple[float, ...]) -> list[float]:
    return [float(v) for v in values]


__all__ = ["goal_dict", "scenario_from_problem"]
