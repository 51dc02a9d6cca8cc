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

from importlib.metadata import PackageNotFoundError, version

from mmplan.errors import InputError, MmplanError, ModelError, PlanningError, UnknownNameError
from mmplan.io.plan_folder import read_plan, read_summary, read_trajectory_csv, write_plan
from mmplan.planners import Planner, PlannerSettings, Problem, get_planner, methods, register
from mmplan.robot import Limits, Robot, get_robot, robot_names
from mmplan.scenario.loader import (
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

# ``mmplan.check`` is the function: importing the submodule here first means no later
# import can rebind the package attribute to the module.
from mmplan.verify.check import CheckReport, check

try:
    __version__ = version("mmplan")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0+unknown"

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
