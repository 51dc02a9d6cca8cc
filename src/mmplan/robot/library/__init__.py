"""Built-in robots, one module each; :func:`get_robot` builds one by name.

``tiago`` and ``ur5-omni`` are loaded from the URDFs of example-robot-data (optional extra
``robots``); without it, building them raises an InputError saying ``pip install
'mmplan[robots]'``.
"""

from __future__ import annotations

from collections.abc import Callable

from mmplan.errors import UnknownNameError
from mmplan.robot.library import (
    base_6dof,
    car_rtr,
    diffdrive_3dof,
    omni_3dof,
    tiago,
    ur5_omni,
    youbot_3r,
    youbot_4r,
)
from mmplan.robot.robot import Robot

_BUILDERS: dict[str, Callable[[], Robot]] = {
    "youbot-3r": youbot_3r.build,
    "youbot-4r": youbot_4r.build,
    "car-rtr": car_rtr.build,
    "diffdrive-3dof": diffdrive_3dof.build,
    "omni-3dof": omni_3dof.build,
    "base-6dof": base_6dof.build,
    "tiago": tiago.build,
    "ur5-omni": ur5_omni.build,
}

_CACHE: dict[str, Robot] = {}


def robot_names() -> list[str]:
    """Names of the built-in robots."""
    return list(_BUILDERS)


def get_robot(name: str) -> Robot:
    """The built-in robot ``name`` (built once per process, then shared).

    Raises:
        UnknownNameError: ``name`` is not a built-in robot.
        InputError: a robot from example-robot-data whose package is not installed.
    """
    if name not in _BUILDERS:
        raise UnknownNameError("robot", f"unknown robot {name!r}; choose one of {robot_names()}")
    if name not in _CACHE:
        _CACHE[name] = _BUILDERS[name]()
    return _CACHE[name]
