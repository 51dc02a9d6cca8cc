"""The planner template and the registry of planning methods.

A method is a subpackage of :mod:`mmplan.planners` whose ``planner.py`` defines a settings
model (a :class:`~mmplan.problem.PlannerSettings` subclass with a literal ``method``) and a
:class:`Planner` subclass registered with :func:`register`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

from mmplan.problem import PlannerSettings, Problem, Progress
from mmplan.trajectory import PlanResult

__all__ = ["Planner", "PlannerSettings", "Problem", "Progress", "register", "registry"]


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
