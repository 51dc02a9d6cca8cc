"""Built-in robots for parametrized tests: robots from example-robot-data skip without it."""

from __future__ import annotations

import pytest

from mmplan.errors import InputError, UnknownNameError
from mmplan.robot import Robot, get_robot


def robot_or_skip(name: str) -> Robot:
    """``get_robot(name)``; a robot whose URDF package is not installed skips, saying so."""
    try:
        return get_robot(name)
    except UnknownNameError:
        raise
    except InputError as exc:
        if "[robots]" not in exc.problem:
            raise
        pytest.skip(f"{name}: {exc.problem}")
