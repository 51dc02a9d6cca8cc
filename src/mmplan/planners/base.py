"""What every planner shares: settings base class, the planning problem, the registry.

A planner is one module under :mod:`mmplan.planners` that defines a settings model
(a :class:`PlannerSettings` subclass with a literal ``method``) and a class with
``plan(problem, progress) -> PlanResult``, and registers it with :func:`register`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field

from mmplan.robot.robot import Robot
from mmplan.scene.scene import Scene
from mmplan.task import Task
from mmplan.trajectory import PlanResult

#: Called with the fraction done (0..1) while planning; may be None.
Progress = Callable[[float], None] | None


class PlannerSettings(BaseModel):
    """Settings every method accepts; a method's model adds its own fields.

    Unknown keys are errors (``extra="forbid"``), values are validated on construction.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    method: str
    t_max: float = Field(
        120.0,
        gt=0,
        allow_inf_nan=False,
        description="simulated seconds (or iterations budget) before giving up",
    )


@dataclass(frozen=True)
class Problem:
    """A fully resolved planning problem: robot (with limits), scene, task, start, settings."""

    robot: Robot
    scene: Scene
    task: Task
    start: NDArray[np.float64]
    settings: PlannerSettings


class Planner(ABC):
    """A planning method."""

    method: ClassVar[str]
    settings_model: ClassVar[type[PlannerSettings]]

    @abstractmethod
    def plan(self, problem: Problem, progress: Progress = None) -> PlanResult:
        """Plan ``problem``; always returns a result whose status says how it ended."""


_REGISTRY: dict[str, type[Planner]] = {}


def register(cls: type[Planner]) -> type[Planner]:
    """Class decorator adding a planner to the registry under ``cls.method``."""
    _REGISTRY[cls.method] = cls
    return cls


def registry() -> dict[str, type[Planner]]:
    """Registered planners by method name."""
    return dict(_REGISTRY)
