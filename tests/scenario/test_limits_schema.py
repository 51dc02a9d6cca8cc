"""Limit ranges that admit no value are rejected with one line naming the entry (issue 16).

An upper limit of -inf (or a lower one of +inf) leaves no admissible value; before this
check a range with both sides at -inf (or +inf) was accepted, and a lone -inf upper limit
was reported as ``min ... > max -inf`` on the other side.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from mmplan.errors import InputError
from mmplan.robot.library import get_robot
from mmplan.scenario.loader import Scenario

BUILTIN = Path(__file__).parents[2] / "src/mmplan/scenario/builtin"
INF = math.inf
N_ACT, N_ARM = 5, 3  # youbot-3r: two wheels and three arm joints; three arm coordinates


def _scenario(limits: dict[str, Any]) -> dict[str, Any]:
    data = yaml.safe_load((BUILTIN / "youbot3r-obstacles-torque.yaml").read_text())
    data["limits"] = limits
    return dict(data)


CASES = [
    ({"torque": {"min": [-INF] * N_ACT, "max": [-INF] * N_ACT}}, "limits.torque.max[0]", "-inf"),
    ({"torque": {"min": [INF] * N_ACT, "max": [INF] * N_ACT}}, "limits.torque.min[0]", "+inf"),
    ({"torque": {"max": [1.0, -INF, 1.0, 1.0, 1.0]}}, "limits.torque.max[1]", "-inf"),
    ({"torque": {"min": [-1.0, -1.0, INF, -1.0, -1.0]}}, "limits.torque.min[2]", "+inf"),
    ({"torque": {"min": [2.0] * N_ACT, "max": [1.0] * N_ACT}}, "limits.torque.min[0]", "min 2"),
    ({"torque": {"max": [math.nan] * N_ACT}}, "limits.torque.max[0]", "NaN"),
    ({"joints": {"min": [-INF] * N_ARM, "max": [-INF] * N_ARM}}, "limits.joints.max[0]", "-inf"),
    ({"joints": {"min": [INF] * N_ARM, "max": [INF] * N_ARM}}, "limits.joints.min[0]", "+inf"),
    ({"joints": {"min": [0.0, 1.0, 0.0], "max": [0.5, 0.5, 0.5]}}, "limits.joints.min[1]",
     "min 1"),
]


@pytest.mark.parametrize(("limits", "key", "word"), CASES)
def test_empty_ranges_are_rejected(limits: dict[str, Any], key: str, word: str) -> None:
    with pytest.raises(InputError) as info:
        Scenario.from_dict(_scenario(limits), "limits-test").build()
    message = str(info.value)
    assert "\n" not in message and len(message) < 300
    assert f"{key}:" in message and word in message, message


def test_one_sided_infinite_limits_stay_valid() -> None:
    """-inf below and +inf above mean 'no limit' on that side and remain accepted."""
    limits = {"torque": {"min": [-INF] * N_ACT, "max": [INF] * N_ACT},
              "joints": {"min": [-INF] * N_ARM, "max": [INF] * N_ARM}}
    problem = Scenario.from_dict(_scenario(limits), "ok").build()
    assert not problem.robot.limits.has_torque_limits


def test_robot_rejects_empty_ranges_built_in_python() -> None:
    robot = get_robot("youbot-3r")
    lim = robot.limits
    with pytest.raises(InputError, match=r"limits\.torque\.max\[0\]"):
        robot.with_limits(replace(lim, torque_min=np.full(N_ACT, -INF),
                                  torque_max=np.full(N_ACT, -INF)))
    with pytest.raises(InputError, match=r"limits\.joints\.min\[0\]"):
        robot.with_limits(replace(lim, joint_min=np.full(N_ARM, INF),
                                  joint_max=np.full(N_ARM, INF)))
