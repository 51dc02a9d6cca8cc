"""Planning methods, one subpackage each, found by method name without importing them all.

Each method package has a light ``settings.py`` (its settings models: the method names) and a
``planner.py`` (the :class:`Planner` subclasses). :func:`methods` and :func:`settings_model`
read only the settings modules; :func:`get_planner` imports the one planner module it needs.
Planners registered at run time with :func:`register` (e.g. a user's own) are found too.
"""

from __future__ import annotations

from functools import cache
from importlib import import_module

from mmplan.errors import UnknownNameError
from mmplan.planners.base import Planner, method_of, register, registry
from mmplan.problem import PlannerSettings, Problem

__all__ = [
    "PACKAGES",
    "Planner",
    "PlannerSettings",
    "Problem",
    "builtin_methods",
    "get_planner",
    "methods",
    "register",
    "settings_model",
]

#: The built-in method packages under :mod:`mmplan.planners`.
PACKAGES = ("extended_jacobian", "tracking", "endogenous", "manipulability_area")
#: Built-in method name -> its package, so that one method's settings load without the others'
#: (building every settings model cost ~15 ms a command); tests check it against the scan.
METHOD_PACKAGES = {
    "extended-jacobian": "extended_jacobian",
    "pseudoinverse": "tracking",
    "impedance": "tracking",
    "endogenous": "endogenous",
    "manipulability-area": "manipulability_area",
}


@cache
def _builtin() -> dict[str, tuple[str, type[PlannerSettings]]]:
    """Method name -> (package, settings model), from the packages' settings modules."""
    found: dict[str, tuple[str, type[PlannerSettings]]] = {}
    for package in PACKAGES:
        found.update(_package_settings(package))
    return found


@cache
def _package_settings(package: str) -> dict[str, tuple[str, type[PlannerSettings]]]:
    """Method name -> (package, settings model) of one package's settings module."""
    module = import_module(f"mmplan.planners.{package}.settings")
    found: dict[str, tuple[str, type[PlannerSettings]]] = {}
    for value in vars(module).values():
        if (
            isinstance(value, type)
            and issubclass(value, PlannerSettings)
            and value.__module__ == module.__name__
            and isinstance(value.model_fields["method"].default, str)
        ):
            found[method_of(value)] = (package, value)
    return found


def builtin_methods() -> list[str]:
    """Names of the methods shipped with mmplan (one per settings model of :data:`PACKAGES`)."""
    return sorted(_builtin())


def methods() -> list[str]:
    """Names of the available planning methods (built-in and registered)."""
    return sorted(set(_builtin()) | set(registry()))


def settings_model(method: str) -> type[PlannerSettings]:
    """The settings model of ``method`` (imports no planner).

    Raises:
        UnknownNameError: no planner has that method name.
    """
    package = METHOD_PACKAGES.get(method)
    known = _package_settings(package).get(method) if package else _builtin().get(method)
    if known is not None:
        return known[1]
    return get_planner(method).settings_model


def get_planner(method: str) -> type[Planner]:
    """The planner class for ``method`` (imports its package's planner module).

    Raises:
        UnknownNameError: no planner has that method name.
    """
    found = registry().get(method)
    if found is None and method in _builtin():
        import_module(f"mmplan.planners.{_builtin()[method][0]}.planner")
        found = registry().get(method)
    if found is None:
        raise UnknownNameError(
            "planner.method", f"unknown method {method!r}; choose one of {methods()}"
        )
    return found
