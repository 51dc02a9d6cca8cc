"""Generator cache of the extended-Jacobian planner: build once, plan many times (speed).

Building the generator (criterion, symbolic step, loading the compiled library) takes
0.1-0.2 s, more than a whole compiled plan. It depends on the robot, the column partition,
the obstacle models with their (goal-fitted) neighbourhoods and four settings, not on the
start or the goal position (p_f is a parameter of the generator), so replanning with the
same robot object and scene (the use in a control loop) reuses it. The robot is compared
by identity (held weakly, :mod:`mmplan.compile.model_cache`): a rebuilt robot, or a copy with
other limits (``Robot.with_limits``: the joint limits enter the criterion), is a new key. At
most ``SIZE`` generators are kept (LRU).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mmplan.compile.model_cache import ModelCache
from mmplan.planners.extended_jacobian.criterion import Partition, build_criterion
from mmplan.planners.extended_jacobian.generator import (
    GeneratorFunctions,
    ObstacleTerm,
    build_functions,
)
from mmplan.robot.robot import Robot

SIZE = 8


@dataclass(frozen=True)
class Built:
    """A generator and how it was obtained: build time [s] (0 when cached), cache hit."""

    fns: GeneratorFunctions
    build_time: float
    cached: bool


_CACHE: ModelCache[GeneratorFunctions] = ModelCache(SIZE)


def generator(
    robot: Robot,
    partition: Partition,
    obstacles: Sequence[ObstacleTerm],
    penalty_weight: float,
    varrho: float,
    arm_weight: float,
    codegen: bool,
    posture: tuple[float, ...] | None = None,
    heading: float | None = None,
) -> Built:
    """The generator functions of this robot, partition, obstacles, settings and criterion
    terms (posture weight, heading reference: :mod:`~mmplan.planners.extended_jacobian.
    posture`), cached."""
    key = (tuple(partition.R), tuple(obstacles), penalty_weight, varrho, arm_weight, codegen,
           posture, heading)
    hit = _CACHE.get(robot, key)
    if hit is not None:
        return Built(hit, 0.0, True)
    clock = time.perf_counter()
    crit = build_criterion(
        robot,
        partition,
        penalty_weight,
        posture=None if posture is None else np.asarray(posture),
        heading=heading,
    )
    fns = build_functions(robot, crit, obstacles, varrho, arm_weight, codegen=codegen)
    _CACHE.put(robot, key, fns)
    return Built(fns, time.perf_counter() - clock, False)


def clear() -> None:
    """Forget every cached generator."""
    _CACHE.clear()
