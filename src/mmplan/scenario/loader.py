"""Scenario files: loading, validation against the robot and planner, building a Problem.

A scenario file (YAML, docs/conventions.md; schema in :mod:`mmplan.scenario.schema`) names a
built-in robot, a start configuration, a goal, obstacles, the floor height (``ground``),
optional limits (joint ranges,
efforts, velocities and accelerations: :mod:`mmplan.scenario.rates`) and the planner
settings. :func:`load_scenario` validates everything that can be known before planning and
raises :class:`ScenarioError` (an :class:`~mmplan.errors.InputError`, exit code 2) whose
message is one line ``<source>: <key path>: <problem>``, e.g.
``scenario.yaml: limits.torque.min[2]: min 1 > max 0``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from pydantic import ValidationError

from mmplan.arrays import Array
from mmplan.errors import InputError, MmplanError, path_argument, require
from mmplan.planners import methods, settings_model
from mmplan.problem import PlannerSettings, Problem
from mmplan.robot import Limits, Robot
from mmplan.scenario.parse import ScenarioError, parse_yaml, read_text, validation_error
from mmplan.scenario.rates import rates_dict, resolve_rates
from mmplan.scenario.robot_entry import build_robot, record_robot
from mmplan.scenario.schema import GoalSpec, LimitsSpec, ScenarioSpec
from mmplan.scenario.start import check_start_pose, resolve_start
from mmplan.scene import Obstacle, Scene, obstacle_from_dict
from mmplan.task import DrawSegment, LinePath, PolynomialPath, ReachPoint, Task, WaypointPath

#: libyaml's emitter when PyYAML has it (the same text as ``yaml.safe_dump``, ~15x faster:
#: 12 ms -> 0.8 ms for a built-in scenario), else the pure-Python one.
_DUMPER: type[yaml.SafeDumper] = getattr(yaml, "CSafeDumper", yaml.SafeDumper)


def builtin_scenarios() -> dict[str, Path]:
    """Built-in scenarios (``src/mmplan/scenario/builtin/*.yaml``), name -> file, sorted by name."""
    folder = resources.files("mmplan.scenario") / "builtin"
    found = {Path(str(p)).stem: Path(str(p)) for p in folder.iterdir() if p.name.endswith(".yaml")}
    return dict(sorted(found.items()))


def load_scenario(name_or_path: str | Path, *, require_planner: bool = True,
                  check_start: bool = True) -> Scenario:
    """Load and validate a scenario from a file path or a built-in scenario name.

    An existing file wins over a built-in scenario of the same name.

    Args:
        name_or_path: File path or built-in name (see :func:`builtin_scenarios`).
        require_planner: When False, a method that is not installed is accepted and its
            settings are kept unvalidated (for checking plans made elsewhere).
        check_start: When False, a start outside the joint limits or in collision is
            accepted (``mmplan check`` then reports it as a failed check instead).

    Raises:
        ScenarioError: the file is missing, larger than 10 MB, not YAML, or fails validation.
    """
    path = path_argument(name_or_path, "scenario")
    require(require_planner, bool, "require_planner", "True or False")
    require(check_start, bool, "check_start", "True or False")
    source = str(name_or_path)
    if not _is_file(path):
        builtins = builtin_scenarios()
        if source not in builtins:
            import difflib

            close = difflib.get_close_matches(source, list(builtins), n=1)
            hint = f"did you mean {close[0]}? " if close else ""
            raise ScenarioError(source, "", "no such file and no built-in scenario of that name; "
                                f"{hint}built-ins: {', '.join(builtins) or 'none'}")
        path = builtins[source]
    text = read_text(path, source)  # at most MAX_FILE_BYTES, UTF-8
    return Scenario.from_dict(parse_yaml(text, source), source, require_planner=require_planner,
                              check_start=check_start, base_dir=path.resolve().parent)


def _header_data(name_or_path: str | Path) -> tuple[str, dict[str, Any]]:
    """(source, the parsed YAML) of a scenario file or built-in name, not validated."""
    source = str(path_argument(name_or_path, "scenario"))
    path = builtin_scenarios().get(source, Path(name_or_path))
    return source, parse_yaml(read_text(path, source), source)


def scenario_header(name_or_path: str | Path) -> tuple[str, str]:
    """(robot, planner method) of a scenario file, read without full validation (for listings).

    Raises:
        ScenarioError: missing file, malformed YAML, or no robot / planner.method.
    """
    source, data = _header_data(name_or_path)
    planner = data.get("planner")
    method = planner.get("method") if isinstance(planner, dict) else None
    robot = data.get("robot")
    if isinstance(robot, dict):  # a URDF robot: its name, else its file's name
        urdf = robot.get("urdf")
        robot = robot.get("name") or (Path(urdf).name if isinstance(urdf, str) else None)
    if not isinstance(robot, str) or not isinstance(method, str):
        raise ScenarioError(source, "", "needs robot and planner.method")
    return robot, method


def robot_unavailable(name_or_path: str | Path) -> str | None:
    """Why the robot of a scenario file cannot be built here (one line: a built-in robot's
    or a URDF robot's files or Pinocchio missing), None when nothing is seen missing. Builds
    nothing (for listings).

    Raises:
        ScenarioError: as :func:`scenario_header`.
    """
    from mmplan.robot.library import robot_names, unavailable
    from mmplan.scenario.robot_entry import urdf_unavailable

    robot = _header_data(name_or_path)[1].get("robot")
    if isinstance(robot, str):
        return unavailable(robot) if robot in robot_names() else None
    return urdf_unavailable(robot)


def _is_file(path: Path) -> bool:
    """``path.is_file()``, False for a name the system refuses (too long, bad bytes)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


class Scenario:
    """A validated scenario: robot (with limits), scene, task, start and planner settings.

    Build one with :func:`load_scenario`, :meth:`Scenario.from_dict` or
    :func:`~mmplan.scenario.from_problem.scenario_from_problem`; everything is checked on
    construction, so :meth:`build` cannot fail.

    Args:
        spec: The validated scenario.
        source: File or built-in name (for messages).
        require_planner: See :func:`load_scenario`.
        check_start: See :func:`load_scenario`.
        base_dir: Folder that relative paths in ``robot`` are relative to (the scenario
            file's folder; default: the working directory).
        robot: The robot ``spec.robot`` names, already built (not built again).
    """

    def __init__(self, spec: ScenarioSpec, source: str = "<scenario>", *,
                 require_planner: bool = True, check_start: bool = True,
                 base_dir: Path | None = None, robot: Robot | None = None) -> None:
        self.spec = spec
        self.source = source
        try:
            base = robot if robot is not None else build_robot(spec.robot, base_dir or Path.cwd())
            #: The robot as built, before the scenario's limits (recorded by resolved_dict).
            self.base_robot = base
            self.robot: Robot = base.with_limits(_limits(spec.limits, base))
            self.start = resolve_start(spec.start, self.robot)
            self.settings: PlannerSettings = _settings(spec.planner, source, require_planner)
            #: False when the method is not installed and its settings were not validated.
            self.planner_validated = str(spec.planner["method"]) in methods()
            self.task: Task = _task(spec.goal)
            self.scene = Scene(tuple(_obstacle(o.model_dump(exclude_none=True), i)
                                     for i, o in enumerate(spec.obstacles)), spec.ground)
            if check_start:
                check_start_pose(self.robot, self.scene, self.start,
                                 by_name=isinstance(spec.start, dict))
        except ScenarioError:
            raise
        except InputError as exc:
            raise ScenarioError(source, exc.field, exc.problem) from None

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "<scenario>", *,
                  require_planner: bool = True, check_start: bool = True,
                  base_dir: Path | None = None, robot: Robot | None = None) -> Scenario:
        """Validate a scenario given as a mapping (the parsed YAML); see :func:`load_scenario`
        and the constructor."""
        try:
            spec = ScenarioSpec.model_validate(dict(data))
        except ValidationError as exc:
            raise validation_error(exc, dict(data), source, model=ScenarioSpec) from None
        return cls(spec, source, require_planner=require_planner, check_start=check_start,
                   base_dir=base_dir, robot=robot)

    @property
    def name(self) -> str:
        """Scenario name."""
        return self.spec.name

    @property
    def method(self) -> str:
        """Planner method name."""
        return self.settings.method

    def build(self) -> Problem:
        """The planning problem (robot with the scenario's limits, scene, task, start, settings)."""
        return Problem(self.robot, self.scene, self.task, self.start.copy(), self.settings)

    def resolved_dict(self) -> dict[str, Any]:
        """The scenario with every default filled in (written as scenario.yaml)."""
        return {
            "name": self.spec.name,
            "robot": record_robot(self.base_robot, self.spec.robot),
            "start": _floats(self.start),
            "goal": self.spec.goal.model_dump(mode="python", exclude_none=True),
            "obstacles": [_shape_first(o.model_dump(mode="python", exclude_none=True))
                          for o in self.spec.obstacles],
            "ground": self.scene.ground,
            "limits": limits_dict(self.robot),
            "planner": (self.settings.model_dump(mode="json") if self.planner_validated
                        else dict(self.spec.planner)),
        }

    def to_yaml(self) -> str:
        """:meth:`resolved_dict` as YAML text."""
        text = yaml.dump(self.resolved_dict(), Dumper=_DUMPER, sort_keys=False,
                         default_flow_style=None)
        return f"# Resolved scenario: every default filled in (written by mmplan).\n{text}"

    def __repr__(self) -> str:
        return f"Scenario({self.name!r}, robot={self.robot.name!r}, method={self.method!r})"


def _shape_first(data: dict[str, Any]) -> dict[str, Any]:
    """Obstacle form in reading order: shape, its geometry, then influence."""
    tail = {"influence": data.pop("influence")} if "influence" in data else {}
    return {"shape": data.pop("shape"), **data, **tail}


def _floats(values: Array) -> list[float]:
    return [float(v) for v in values]


def limits_dict(robot: Robot) -> dict[str, Any]:
    """The robot's effective limits in the scenario ``limits:`` form, every value given (so
    that it reloads to the same limits whatever the robot's defaults)."""
    lim = robot.limits
    torque: Any = "unlimited"
    if lim.has_torque_limits:
        torque = {"min": _floats(lim.torque_min), "max": _floats(lim.torque_max)}
    return {"joints": {"min": _floats(lim.joint_min), "max": _floats(lim.joint_max)},
            "torque": torque, **rates_dict(lim.rates, robot)}


def _limits(spec: LimitsSpec | None, robot: Robot) -> Limits:
    lim = robot.limits
    jmin, jmax, tmin, tmax = lim.joint_min, lim.joint_max, lim.torque_min, lim.torque_max
    n_arm, n_act = len(robot.arm_coordinates), len(robot.actuators)

    def vector(key: str, values: list[float] | None, default: Array, n: int,
               names: Sequence[str]) -> Array:
        if values is None:
            return np.asarray(default, dtype=float)
        if len(values) != n:
            raise InputError(key, f"expected {n} values ({', '.join(names)}), got {len(values)}")
        return np.asarray(values, dtype=float)

    if spec is not None and spec.joints is not None:
        arm = robot.arm_coordinates
        jmin = vector("limits.joints.min", spec.joints.min, jmin, n_arm, arm)
        jmax = vector("limits.joints.max", spec.joints.max, jmax, n_arm, arm)
    if spec is not None and spec.torque is not None:
        if spec.torque.unlimited:
            tmin, tmax = np.full(n_act, -np.inf), np.full(n_act, np.inf)
        else:
            tmin = vector("limits.torque.min", spec.torque.min, tmin, n_act, robot.actuators)
            tmax = vector("limits.torque.max", spec.torque.max, tmax, n_act, robot.actuators)
    for key, lo, hi in (("limits.joints", jmin, jmax), ("limits.torque", tmin, tmax)):
        bad = np.flatnonzero(lo > hi)
        if bad.size:
            i = int(bad[0])
            raise InputError(f"{key}.min[{i}]", f"min {lo[i]:g} > max {hi[i]:g}")
    return Limits(jmin, jmax, tmin, tmax, resolve_rates(spec, robot))


def _settings(planner: Mapping[str, Any], source: str, required: bool) -> PlannerSettings:
    method = str(planner["method"])
    if not required and method not in methods():
        # Unvalidated record of the settings (extra keys kept) for a method not installed here.
        return PlannerSettings.model_construct(**dict(planner))
    model = settings_model(method)
    try:
        return model.model_validate(dict(planner))
    except ValidationError as exc:
        raise validation_error(exc, dict(planner), source, prefix="planner",
                               model=model) from None


def _task(goal: GoalSpec) -> Task:
    tol = goal.tolerance
    if goal.position is not None:
        return ReachPoint(_vec3(goal.position), tol)
    if goal.segment is not None:
        s = goal.segment
        return DrawSegment(_vec3(s.start), _vec3(s.end), _vec3(s.normal), tol)
    path = goal.path
    if path is None:  # excluded by GoalSpec's validator
        raise InputError("goal", "expected exactly one of position, path, segment")
    if path.kind == "line":
        return LinePath(_vec3(path.start), _vec3(path.velocity), path.duration, tol)
    if path.kind == "waypoints":
        return WaypointPath(tuple(_vec3(p) for p in path.points), tuple(path.times), tol)
    return PolynomialPath(tuple(_vec3(c) for c in path.coefficients), path.duration, tol)


def _vec3(values: Sequence[float]) -> tuple[float, float, float]:
    return (float(values[0]), float(values[1]), float(values[2]))


def _obstacle(data: dict[str, Any], index: int) -> Obstacle:
    try:
        return obstacle_from_dict(data)
    except InputError as exc:
        raise InputError(f"obstacles[{index}].{exc.field}".rstrip("."), exc.problem) from None
    except MmplanError as exc:
        raise InputError(f"obstacles[{index}]", str(exc)) from None


__all__ = ["Scenario", "ScenarioError", "builtin_scenarios", "load_scenario", "scenario_header"]
