"""Built-in robots, one module each; :func:`get_robot` builds one by name.

``tiago`` and ``ur5-omni`` are loaded from the URDFs of example-robot-data (optional extra
``robots``); without it, building them raises an InputError saying ``pip install
'mmplan[robots]'``.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib import import_module

from mmplan.errors import UnknownNameError
from mmplan.robot.robot import Robot

#: Robot name -> the module (in this package) whose ``build()`` makes it; a module is imported
#: only when its robot is built (``mmplan plan`` loads one robot module, not eight).
_BUILDERS: dict[str, str] = {
    "youbot-3r": "youbot_3r",
    "youbot-4r": "youbot_4r",
    "car-rtr": "car_rtr",
    "diffdrive-3dof": "diffdrive_3dof",
    "omni-3dof": "omni_3dof",
    "base-6dof": "base_6dof",
    "tiago": "tiago",
    "ur5-omni": "ur5_omni",
}

_CACHE: dict[str, Robot] = {}


def robot_names() -> list[str]:
    """Names of the built-in robots."""
    return list(_BUILDERS)


def unavailable(name: str) -> str | None:
    """Why :func:`get_robot` cannot build the built-in robot ``name`` here (one line), None
    when it can. Builds nothing: a robot from example-robot-data (its module names its
    ``URDF``) needs that file, the others nothing.

    Raises:
        UnknownNameError: ``name`` is not a built-in robot.
    """
    from mmplan.errors import InputError
    from mmplan.robot.robot_data import robot_data_file

    if name not in _BUILDERS:
        raise UnknownNameError("robot", f"unknown robot {name!r}; choose one of {robot_names()}")
    relative = getattr(import_module(f"{__name__}.{_BUILDERS[name]}"), "URDF", None)
    if relative is None:
        return None
    try:
        robot_data_file(str(relative))
    except InputError as exc:
        return exc.problem
    return None


def get_robot(name: str) -> Robot:
    """The built-in robot ``name`` (built once per process, then shared).

    Raises:
        UnknownNameError: ``name`` is not a built-in robot.
        InputError: a robot from example-robot-data whose package is not installed.
    """
    if name not in _BUILDERS:
        raise UnknownNameError("robot", f"unknown robot {name!r}; choose one of {robot_names()}")
    if name not in _CACHE:
        build: Callable[[], Robot] = import_module(f"{__name__}.{_BUILDERS[name]}").build
        _CACHE[name] = build()
    return _CACHE[name]
