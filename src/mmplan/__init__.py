"""mmplan: whole-body trajectory planning for mobile manipulators.

Data flow: a scenario file is validated into a :class:`Scenario`, which builds a
:class:`Problem` (robot with limits, scene, task, start, planner settings); a planner from
:func:`get_planner` turns it into a :class:`PlanResult` holding a :class:`Trajectory`;
:func:`check` verifies any trajectory independently; :func:`write_plan` / :func:`read_plan`
store and load plan directories.

Example::

    import mmplan
    scenario = mmplan.load_scenario("youbot3r-obstacles")
    problem = scenario.build()
    result = mmplan.get_planner(scenario.method)().plan(problem)
    print(mmplan.check(result.trajectory, problem, status=result.status).summary(
        status=result.status, planner=result.planner, compute_time_s=result.compute_time_s))
    mmplan.write_plan("run1", result, problem, scenario)
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mmplan._lazy import lazy_exports

if TYPE_CHECKING:
    from mmplan.errors import InputError, MmplanError, ModelError, PlanningError, UnknownNameError
    from mmplan.io.plan_folder import read_plan, read_summary, read_trajectory_csv, write_plan
    from mmplan.planners import Planner, PlannerSettings, Problem, get_planner, methods, register
    from mmplan.robot import Limits, Robot, get_robot, robot_names
    from mmplan.scenario import (
        Scenario,
        ScenarioError,
        builtin_scenarios,
        load_scenario,
        scenario_header,
    )
    from mmplan.scene import Scene, obstacle_from_dict
    from mmplan.task import (
        DrawSegment,
        LinePath,
        PolynomialPath,
        ReachPoint,
        Task,
        TrackPath,
        WaypointPath,
        completion_time,
    )
    from mmplan.trajectory import PlanResult, Status, Trajectory
    from mmplan.verify.check import CheckReport, check

#: Public name -> the module that defines it. ``import mmplan`` loads none of them: each is
#: imported on first use (``mmplan.check`` is always the checker function).
_LAZY: dict[str, str] = {
    **dict.fromkeys(
        ["InputError", "MmplanError", "ModelError", "PlanningError", "UnknownNameError"],
        "mmplan.errors",
    ),
    **dict.fromkeys(
        ["read_plan", "read_summary", "read_trajectory_csv", "write_plan"], "mmplan.io.plan_folder"
    ),
    **dict.fromkeys(
        ["Planner", "PlannerSettings", "Problem", "get_planner", "methods", "register"],
        "mmplan.planners",
    ),
    **dict.fromkeys(["Limits", "Robot", "get_robot", "robot_names"], "mmplan.robot"),
    **dict.fromkeys(
        ["Scenario", "ScenarioError", "builtin_scenarios", "load_scenario", "scenario_header"],
        "mmplan.scenario",
    ),
    **dict.fromkeys(["Scene", "obstacle_from_dict"], "mmplan.scene"),
    **dict.fromkeys(
        [
            "DrawSegment",
            "LinePath",
            "PolynomialPath",
            "ReachPoint",
            "Task",
            "TrackPath",
            "WaypointPath",
            "completion_time",
        ],
        "mmplan.task",
    ),
    **dict.fromkeys(["PlanResult", "Status", "Trajectory"], "mmplan.trajectory"),
    **dict.fromkeys(["CheckReport", "check"], "mmplan.verify.check"),
}


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("mmplan")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "0+unknown"


_get, __dir__ = lazy_exports(__name__, _LAZY)


def __getattr__(name: str) -> Any:
    """Import a public name on first use (keeps ``import mmplan`` and ``mmplan --help`` light)."""
    if name == "__version__":
        globals()[name] = _version()
        return globals()[name]
    return _get(name)


__all__ = [
    "CheckReport",
    "DrawSegment",
    "InputError",
    "Limits",
    "LinePath",
    "MmplanError",
    "ModelError",
    "PlanResult",
    "Planner",
    "PlannerSettings",
    "PlanningError",
    "PolynomialPath",
    "Problem",
    "ReachPoint",
    "Robot",
    "Scenario",
    "ScenarioError",
    "Scene",
    "Status",
    "Task",
    "TrackPath",
    "Trajectory",
    "UnknownNameError",
    "WaypointPath",
    "__version__",
    "builtin_scenarios",
    "check",
    "completion_time",
    "get_planner",
    "get_robot",
    "load_scenario",
    "methods",
    "obstacle_from_dict",
    "read_plan",
    "read_summary",
    "read_trajectory_csv",
    "register",
    "robot_names",
    "scenario_header",
    "write_plan",
]
