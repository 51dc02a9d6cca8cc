"""Re-planning from the current state among moved or new obstacles, with no compile.

:class:`Replanner` takes one problem (robot, settings, a first scene and goal), gets its
generator once (compiled and cached: :mod:`~mmplan.planners.extended_jacobian.cache`) with
``spare`` free obstacle slots per shape type, and then :meth:`Replanner.replan` runs the
generator from any state (q, dq) for another scene and goal by changing numbers in its
parameter vector only (:mod:`~mmplan.planners.extended_jacobian.parameters`): obstacle
centres, sizes, yaw, neighbourhoods, the floor, the goal and the column partition (chosen
again at the current state). A scene needing more slots of a shape type than the generator
has, or a new shape type, is an ``InputError`` (make the replanner with more ``spare`` slots
or ``shapes``).

A re-plan is the generator's motion over ``horizon`` seconds at its own timing, with the
obstacle perturbation of [PajakPajak] eq. (19), started at the given velocity: it is not
re-timed (a time scaling from a moving start is not defined by
:mod:`~mmplan.planners.extended_jacobian.time_scaling`) and runs without the virtual
control, whose u would restart at 0. A control loop follows its first samples and re-plans
(``examples/replan_moving_obstacle.py``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from mmplan.arrays import Array
from mmplan.compile import codegen as cg
from mmplan.errors import InputError
from mmplan.planners.extended_jacobian import cache as ej_cache
from mmplan.planners.extended_jacobian import checks as ej_checks
from mmplan.planners.extended_jacobian.criterion import Partition, choose_partition
from mmplan.planners.extended_jacobian.generator import (
    GeneratorFunctions,
    ObstacleTerm,
    wheel_metric_inverse,
)
from mmplan.planners.extended_jacobian.options import RolloutOptions
from mmplan.planners.extended_jacobian.parameters import Shape, merge_slots, slots_for
from mmplan.planners.extended_jacobian.posture import heading_reference, posture_weights
from mmplan.planners.extended_jacobian.rollout import RolloutResult, rollout
from mmplan.planners.extended_jacobian.settings import ExtendedJacobianSettings
from mmplan.planners.extended_jacobian.switching import PartitionSwitch
from mmplan.problem import Problem
from mmplan.robot.ground import ground_sphere_indices
from mmplan.task import ReachPoint

#: Default re-planning horizon [s].
HORIZON = 3.0


class Replanner:
    """Re-planning with one generator (module docstring).

    Args:
        problem: Robot, settings, first scene, goal (``ReachPoint``) and start.
        spare: Free obstacle slots per shape type beyond the first scene's.
        shapes: Further shape types (superellipsoid exponents (e1, e2)) to keep slots for.
    """

    def __init__(self, problem: Problem, spare: int = 2, shapes: Sequence[Shape] = ()) -> None:
        if not isinstance(problem.task, ReachPoint):
            raise InputError("goal", f"re-planning needs {ReachPoint.goal_form}")
        self.robot = problem.robot
        self.settings = ExtendedJacobianSettings.model_validate(problem.settings.model_dump())
        self.tolerance = float(problem.task.tolerance)
        self.goal = np.asarray(problem.task.position, dtype=float)
        options = RolloutOptions.from_settings(self.settings, self.robot, self.tolerance)
        self.options = dataclasses.replace(options, torque_control=False)
        kinds = [ob.superellipsoid().exponents for ob in problem.scene.obstacles]
        kinds += [e for e in shapes for _ in range(spare)]
        slots = slots_for(kinds)
        self.slots = merge_slots(slots, tuple((e, k + spare) for e, k in slots))
        weights = posture_weights(self.robot, self.settings.posture_weight)
        self.posture = tuple(float(b) for b in weights)
        q0 = ej_checks.check_start(self.robot, problem.start)
        self.partition = choose_partition(self.robot, q0)
        self.heading = heading_reference(self.robot, q0, self.goal)
        self.fns = self._generator(self.partition)
        self.winv = wheel_metric_inverse(self.robot)

    def _generator(self, partition: Partition, codegen: bool | None = None) -> GeneratorFunctions:
        s = self.settings
        return ej_cache.generator(
            self.robot, partition, self.slots, s.penalty_weight, s.varrho,
            s.arm_gradient_weight, s.codegen if codegen is None else codegen, self.posture,
            self.heading, notify=cg.notice,  # a first compile says so, as plan() does
        ).fns  # fmt: skip

    def params(self, q: Array, scene: Any, goal: Array) -> tuple[Array, Partition]:
        """p for the scene and goal, and the partition in it: chosen at q (the first one kept
        when the generator cannot take the new one)."""
        s = self.settings
        obstacles = [
            ObstacleTerm(
                ob.enlarged(s.obstacle_margin).superellipsoid(),
                ob.influence if ob.influence is not None else s.influence,
            )
            for ob in scene.obstacles
        ]
        obstacles = ej_checks.fit_influence(obstacles, goal)
        ground = getattr(scene, "ground", None)
        floor = None
        if ground is not None and ground_sphere_indices(self.robot):
            floor = (ground, min(s.influence, max(0.05, 0.7 * (float(goal[2]) - ground))))
        try:
            part = choose_partition(self.robot, q)
        except InputError:
            part = self.partition
        layout = self.fns.layout
        part = part if layout.supports(part) else self.partition
        heading = heading_reference(self.robot, q, goal) if layout.heading else None
        try:
            p = layout.pack(
                goal, self.options.gains, [(ob.model, ob.influence) for ob in obstacles], floor,
                part if layout.n_arm else None, heading,
            )  # fmt: skip
            return p, part if layout.n_arm else self.partition
        except ValueError as err:
            raise InputError("scene", f"{err}: make the Replanner with more spare slots") from err

    def replan(
        self,
        q: ArrayLike,
        dq: ArrayLike,
        scene: Any,
        goal: ArrayLike | None = None,
        horizon: float = HORIZON,
    ) -> RolloutResult:
        """The generator's motion from (q, dq) among ``scene``'s obstacles towards ``goal``
        (default: the problem's) for at most ``horizon`` seconds (module docstring)."""
        qv, dqv = np.asarray(q, dtype=float), np.asarray(dq, dtype=float)
        target = self.goal if goal is None else np.asarray(goal, dtype=float)
        p, part = self.params(qv, scene, target)
        opt = dataclasses.replace(self.options, t_max=horizon)

        def build(other: Partition) -> GeneratorFunctions:
            if self.fns.layout.supports(other):
                return self.fns
            return self._generator(other, codegen=False)  # built in: the VM, no compile

        switch = PartitionSwitch(self.robot, build, [part], opt.switch_cond)
        return rollout(self.fns, self.robot.pfaffian, self.winv, qv, p, opt, switch, dq0=dqv)
