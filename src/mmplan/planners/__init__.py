"""Planning methods, one module each; :func:`get_planner` looks one up by method name."""

from __future__ import annotations

from mmplan.errors import UnknownNameError

# Importing a planner module registers it.
# (planner modules are added here as they land)
from mmplan.planners import (
    endogenous,  # noqa: F401
    extended_jacobian,  # noqa: F401
    impedance,  # noqa: F401
    manipulability_area,  # noqa: F401
    pseudoinverse,  # noqa: F401
)
from mmplan.planners.base import Planner, PlannerSettings, Problem, register, registry

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
