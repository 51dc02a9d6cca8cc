"""The planner template and the registry of planning methods.

A method is a subpackage of :mod:`mmplan.planners`: its ``settings.py`` defines the settings
model (a :class:`~mmplan.problem.PlannerSettings` subclass whose ``method`` field is a literal:
the one place a method's name is written) and its ``planner.py`` a :class:`Planner` subclass
registered with :func:`register`, which writes only :meth:`Planner._solve`.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import replace
from typing import Any, ClassVar, Generic, TypeVar, get_args, get_origin

import numpy as np
from pydantic import ValidationError

from mmplan.errors import InputError, require
from mmplan.planners import culling
from mmplan.problem import PlannerSettings, Problem, Progress
from mmplan.task import Task
from mmplan.trajectory import PlanResult, Solution

__all__ = [
    "Planner",
    "PlannerSettings",
    "Problem",
    "Progress",
    "method_of",
    "register",
    "registry",
]

SettingsT = TypeVar("SettingsT", bound=PlannerSettings)
TaskT = TypeVar("TaskT", bound=Task)


def method_of(settings_model: type[PlannerSettings]) -> str:
    """The method name a settings model declares (the default of its ``method`` field)."""
    default = settings_model.model_fields["method"].default
    if not isinstance(default, str):
        raise TypeError(f"{settings_model.__name__}.method needs a literal default")
    return default


class Planner(ABC, Generic[SettingsT, TaskT]):
    """A planning method: :meth:`plan` is the template, a method writes :meth:`_solve`.

    ``plan`` checks the settings and the goal kind, runs ``_solve``, reports progress 1.0 and
    returns a :class:`~mmplan.trajectory.PlanResult` stamped with the method name and the
    wall-clock compute time of the whole call.

    A method names its settings model and goal kind once, as the type arguments
    (``class ExtendedJacobian(Planner[ExtendedJacobianSettings, ReachPoint])``); the class
    attributes below are derived from them.

    Attributes:
        settings_model: Its settings model.
        task_type: The goal kind it plans (:mod:`mmplan.task`).
        method: The method name, the ``method`` literal of ``settings_model``.
    """

    method: ClassVar[str]
    settings_model: ClassVar[type[PlannerSettings]]
    task_type: ClassVar[type[Task]]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        for base in cls.__dict__.get("__orig_bases__", ()):
            if get_origin(base) is Planner:
                settings_model, task_type = get_args(base)
                if isinstance(settings_model, type) and isinstance(task_type, type):
                    cls.settings_model, cls.task_type = settings_model, task_type
                    cls.method = method_of(settings_model)

    def plan(self, problem: Problem, progress: Progress = None) -> PlanResult:
        """Plan ``problem``; always returns a result whose status says how it ended.

        The method's model holds only the obstacles near the region the robot can reach; the
        plan is verified against the others and planned again with any it comes near
        (:mod:`mmplan.planners.culling`; ``info`` then says how many were culled).

        Raises:
            InputError: not a Problem, settings of another method, or a goal kind this method
                does not plan, more obstacles near the reachable region than
                ``culling.MAX_NEAR_OBSTACLES``, or bad input the method detects before
                planning.
        """
        clock = time.perf_counter()
        require(problem, Problem, "problem", "a Problem (Scenario.build())")
        if progress is not None and not callable(progress):
            raise InputError("progress", f"expected a function of the fraction done or None, "
                             f"got {type(progress).__name__}")
        settings = self.settings(problem.settings)  # start: checked by Problem
        task = problem.task
        if not isinstance(task, self.task_type):
            raise InputError(
                "goal",
                f"the {self.method} planner needs {self.task_type.goal_form}, "
                f"got {type(task).__name__}",
            )
        solution, info = self._solve_culled(problem, settings, task, progress)  # type: ignore[arg-type]
        solution = _with_efforts(solution, problem)
        if progress is not None:
            progress(1.0)
        return PlanResult(
            status=solution.status,
            trajectory=solution.trajectory,
            planner=self.method,
            message=solution.message,
            compute_time_s=time.perf_counter() - clock,
            info={**solution.info, **info},
            history=solution.history,
            artifacts=solution.artifacts,
        )

    def _solve_culled(self, problem: Problem, settings: SettingsT, task: TaskT,
                      progress: Progress) -> tuple[Solution, dict[str, Any]]:
        """``_solve`` on the obstacles near the reachable region, verified against all
        (:mod:`mmplan.planners.culling`); the info says what was culled, when anything was."""
        kept = culling.kept_obstacles(problem)
        replans = 0
        while True:
            culled = problem if kept is None else culling.with_obstacles(problem, kept)
            try:
                solution = self._solve(culled, settings, task, progress)
            except InputError as err:
                if kept is None:
                    raise
                raise culling.renumbered(err, kept) from None
            if kept is None:
                break
            near = culling.came_near(problem, kept, solution.trajectory)
            if not near:
                break
            replans += 1
            kept = (None if replans > culling.MAX_REPLANS
                    else tuple(sorted({*kept, *near})))
        if kept is None and not replans:
            return solution, {}
        n = len(problem.scene.obstacles)
        modelled = n if kept is None else len(kept)
        return solution, {"obstacles_modelled": modelled, "obstacles_culled": n - modelled,
                          "obstacle_replans": replans}

    @classmethod
    def settings(cls, settings: PlannerSettings) -> SettingsT:
        """``settings`` as this method's model (validated from a plain PlannerSettings).

        Raises:
            InputError: settings of another method, or values the model rejects.
        """
        if isinstance(settings, cls.settings_model):
            return settings  # type: ignore[return-value]
        require(settings, PlannerSettings, "planner", f"settings of method {cls.method!r}")
        if settings.method != cls.method:
            raise InputError(
                "planner.method",
                f"the {cls.method} planner was given settings of method {settings.method!r}",
            )
        try:
            return cls.settings_model.model_validate(settings.model_dump())  # type: ignore[return-value]
        except ValidationError as exc:
            first = exc.errors()[0]
            key = ".".join(str(part) for part in first["loc"]) or "planner"
            raise InputError(f"planner.{key}", first["msg"]) from None

    @abstractmethod
    def _solve(
        self, problem: Problem, settings: SettingsT, task: TaskT, progress: Progress
    ) -> Solution:
        """The method itself: plan ``problem`` with checked ``settings`` and ``task``."""


def _with_efforts(solution: Solution, problem: Problem) -> Solution:
    """The solution with the model's actuator efforts of its motion as ``tau`` when the
    method writes none and the robot has effort limits: a plan for such a robot always
    carries the efforts it demands (the checker requires them and judges them)."""
    robot, trajectory = problem.robot, solution.trajectory
    if trajectory.tau is not None or not robot.limits.has_torque_limits:
        return solution
    if trajectory.samples == 0 or not trajectory.is_finite():
        return solution
    tau = np.array(
        [
            robot.actuator_efforts(q, dq, ddq)
            for q, dq, ddq in zip(trajectory.q, trajectory.dq, trajectory.ddq, strict=True)
        ]
    )
    return replace(
        solution, trajectory=replace(trajectory, actuators=robot.actuators, tau=tau)
    )


_REGISTRY: dict[str, type[Planner[Any, Any]]] = {}


def register(cls: type[Planner[Any, Any]]) -> type[Planner[Any, Any]]:
    """Class decorator adding a planner to the registry under ``cls.method``."""
    _REGISTRY[cls.method] = cls
    return cls


def registry() -> dict[str, type[Planner[Any, Any]]]:
    """Planners registered so far, by method name (see :mod:`mmplan.planners`)."""
    return dict(_REGISTRY)
