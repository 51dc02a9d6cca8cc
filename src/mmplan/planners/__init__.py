"""Planning methods, one module each; :func:`get_planner` looks one up by method name."""

from __future__ import annotations

from mmplan.errors import UnknownNameError
from mmplan.planners.base import Planner, register, registry

# Importing a planner module registers it.
# (planner modules are added here as they land)
from mmplan.planners.endogenous import planner as endogenous
from mmplan.planners.extended_jacobian import planner as extended_jacobian
from mmplan.planners.manipulability_area import planner as manipulability_area
from mmplan.planners.tracking import impedance, pseudoinverse
from mmplan.problem import PlannerSettings, Problem

__all__ = ["Planner", "PlannerSettings", "Problem", "get_planner", "methods", "register"]


def methods() -> list[str]:
    """Names of the available planning methods."""
    return sorted(registry())


def get_planner(method: str) -> type[Planner]:
    """The planner class for ``method``.

    Raises:
        UnknownNameError: no planner has that method name.
    """
    found = registry().get(method)
    if found is None:
        raise UnknownNameError(
            "planner.method", f"unknown method {method!r}; choose one of {methods()}"
        )
    return found
