"""Generator cache of the extended-Jacobian planner: build once, plan many times (speed).

Building the generator (criterion, symbolic step, loading the compiled library) takes
0.1-0.2 s, more than a whole compiled plan. It depends on the robot, the obstacle shape
types and their slot counts and four settings, not on the scene: goal, obstacle centres,
sizes, yaw and neighbourhoods, the floor and the column partition are numbers in its
parameter vector (:mod:`~mmplan.planners.extended_jacobian.parameters`; a partition outside
the parametric family is built in and is then part of the key), so replanning with the same
robot object among moved obstacles (the use in a control loop) reuses it. The robot is compared
by identity (held weakly, :mod:`mmplan.compile.model_cache`): a rebuilt robot, or a copy with
other limits (``Robot.with_limits``: the joint limits enter the criterion), is a new key. At
most ``SIZE`` generators are kept (LRU).

On disk, a scene whose slots no compiled library has exactly is served by a library of the
same robot model and settings with at least its slots of each shape type, unused slots parked
(:func:`~mmplan.planners.extended_jacobian.compiled.wider`); else by one with fewer slots of
a type but one of each, the near obstacles in its slots
(:func:`~mmplan.planners.extended_jacobian.compiled.covering`,
:mod:`~mmplan.planners.extended_jacobian.active`); only without either is a library compiled
(docs/extended_jacobian.md: measured cost of parked slots, +11 % a plan for 4 slots a type
against 2).
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from mmplan.compile import codegen as cg
from mmplan.compile.codegen import compiler
from mmplan.compile.model_cache import ModelCache
from mmplan.planners.extended_jacobian import compiled as ej_compiled
from mmplan.planners.extended_jacobian.criterion import Partition, build_criterion
from mmplan.planners.extended_jacobian.generator import (
    AUTO_SIZE,
    GeneratorFunctions,
    build_functions,
)
from mmplan.planners.extended_jacobian.parameters import Shape
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
    slots: Sequence[tuple[Shape, int]],
    penalty_weight: float,
    varrho: float,
    arm_weight: float,
    codegen: bool | None,
    posture: tuple[float, ...] | None = None,
    heading: float | None = None,
    notify: Callable[[str], None] | None = None,
    exact: bool = False,
) -> Built:
    """The generator functions of this robot, obstacle slots, settings and criterion terms
    (posture weight, whether there is a heading term: :mod:`~mmplan.planners.
    extended_jacobian.posture`), cached; ``partition`` and ``heading`` (theta_ref) are
    values of p, except a partition the layout cannot take (then it is built in).

    A compiled library with fewer slots of some shape type than ``slots`` (but one of each)
    serves too, the near obstacles in its slots (:mod:`~mmplan.planners.extended_jacobian.
    active`), unless ``exact``: then the generator holds ``slots``."""
    model = (penalty_weight, varrho, arm_weight, posture, heading is not None)
    key = (tuple(slots), codegen, *model)
    for k in (key, (*key, tuple(partition.R))):
        hit = _CACHE.get(robot, k)
        if hit is None or not (len(k) > len(key) or hit.layout.supports(partition)):
            continue
        if not exact or all(dict(hit.layout.slots).get(e, 0) >= n for e, n in slots):
            return Built(hit, 0.0, True)
    clock = time.perf_counter()

    def symbolic(
        disk_key: str | None = None,
        compiled: bool = False,
        slots: Sequence[tuple[Shape, int]] = slots,
    ) -> GeneratorFunctions:
        crit = build_criterion(
            robot,
            partition,
            penalty_weight,
            posture=None if posture is None else np.asarray(posture),
            heading=heading,
            parametric=True,
        )
        if disk_key is not None and not crit.sel.numel():  # the partition is built in
            disk_key = ej_compiled.disk_key(robot, slots, model, partition.R)
        return build_functions(
            robot, crit, slots, varrho, arm_weight, compiled, notify, disk_key=disk_key,
            max_size=AUTO_SIZE if codegen is None else None,
        )  # fmt: skip

    fns = None
    if codegen is not False and compiler() is not None:
        # a library compiled on an earlier run: loaded without building the model
        for built_in in (None, partition.R):
            dkey = ej_compiled.disk_key(robot, slots, model, built_in)
            fns = ej_compiled.load(dkey, symbolic)
            if fns is not None and (built_in is not None or fns.layout.supports(partition)):
                break
            fns = None
        if fns is None:
            family = ej_compiled.family_key(robot, model)
            for wide, its in ej_compiled.wider(family, slots):
                # a library with more slots (or more shape types) serves this scene: no compile
                fns = ej_compiled.load(wide, functools.partial(symbolic, slots=its))
                if fns is not None and fns.layout.supports(partition):
                    break
                fns = None
            for few, its in [] if fns is not None or exact else ej_compiled.covering(family, slots):
                # fewer slots of a type than obstacles: the near ones in the slots, no compile
                fns = ej_compiled.load(few, functools.partial(symbolic, slots=its))
                if fns is not None and fns.layout.supports(partition):
                    break
                fns = None
            if fns is None:
                dkey = ej_compiled.disk_key(robot, slots, model)
                why = ej_compiled.why_compile(family, slots)
                if why and notify is not None:
                    notify(why)
                fns = symbolic(dkey, compiled=True)
                if fns.compiled and fns.layout.supports(partition):
                    ej_compiled.remember(family, slots, dkey)
    else:
        if codegen is not False and notify is not None:
            notify(f"{cg.no_compiler()}: the generator runs on CasADi's virtual machine")
        fns = symbolic()
    _CACHE.put(robot, key if fns.layout.n_arm else (*key, tuple(partition.R)), fns)
    return Built(fns, time.perf_counter() - clock, False)


def clear() -> None:
    """Forget every cached generator."""
    _CACHE.clear()
