"""Re-planning from the current state among moved or new obstacles, with no compile.

:class:`Replanner` takes one problem (robot, settings, a first scene and goal), gets its
generator once (compiled and cached: :mod:`~mmplan.planners.extended_jacobian.cache`) with
``spare`` free obstacle slots per shape type, and then :meth:`Replanner.replan` runs the
generator from any state (q, dq) for another scene and goal by changing numbers in its
parameter vector only (:mod:`~mmplan.planners.extended_jacobian.parameters`): obstacle
centres, sizes, yaw, neighbourhoods, the floor, the goal and the column partition (chosen
again at the current state). A scene with more obstacles of a shape type than the generator
has slots keeps the near ones in the slots (:mod:`~mmplan.planners.extended_jacobian.active`;
more of a type near the robot at once than slots, or a new shape type, is an ``InputError``:
make the replanner with more ``spare`` slots or ``shapes``).

A re-plan is the generator's path over ``horizon`` seconds of its own time, with the
obstacle perturbation of [PajakPajak] eq. (19), and then, when the robot has torque or rate
limits, time-scaled under them as a plan is
(:func:`~mmplan.planners.extended_jacobian.time_scaling.scale_path`, time mode). A time-scaled
plan moves along its path at the rate w (its ``u`` column) of the generator's own speed q';
a re-plan from a state of such a plan continues it when it is given that ``rate``: the
generator starts at q' = dq / w and the scaling at w_0 = w, so the re-plan starts at the
robot's velocity dq. (Started at q' = dq with w_0 = 1, the generator's path accelerates at
once towards its own speed and no w_0 near 1 holds the limits: measured from the paper plan at
t = 5 s, w_0 0.52, a step of 6 rad/s in a wheel's rate.) The generator runs without
the virtual control (whose u would restart at 0). Without the scaling (``limits=False``, or a
robot without limits) the re-plan keeps the generator's timing, which breaks real limits
(measured on youbot3r-obstacles-torque from its start: platform 2.0 m/s against 0.8, wheel
torque over by 7.7 N m). A control loop follows its first samples and re-plans
(``examples/replan_moving_obstacle.py``).

A goal inside an obstacle (an obstacle passing over it) is no error here: the re-plan holds
the given state (one sample, status ``infeasible``, the message says which obstacle), and a
later re-plan, with the obstacle gone, moves on (the example holds a cycle and re-plans). A
state of the wrong size or not finite, a rate outside [0, 1] (or 0 for a moving robot), a
horizon that is not a finite positive time, a goal that is not 3 finite numbers and a shape
type the replanner has no slot for are ``InputError``s. With ``elapsed`` (the robot follows
the last re-plan) a new path the robot cannot take at its speed, none, or a blocked goal make
it brake to rest along the plan it follows instead
(:mod:`~mmplan.planners.extended_jacobian.braking`).

Which rate: any w the limits admit at the start makes the re-plan start at dq (dq / w x w);
the rate sets the generator's path speed q' = dq / w, which the time scaling can follow from
w only when it is the path speed the robot is on: the rate of the plan it follows (a re-plan's
``u`` column; a plan's ``u`` in time mode, its ``w`` column in feedback mode). A small rate
magnifies an error in dq by 1 / w.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from mmplan import interpolant
from mmplan.arrays import Array
from mmplan.compile import codegen as cg
from mmplan.errors import InputError
from mmplan.planners.extended_jacobian import cache as ej_cache
from mmplan.planners.extended_jacobian import checks as ej_checks
from mmplan.planners.extended_jacobian.active import ActiveSlots, CrowdedError, shape_name
from mmplan.planners.extended_jacobian.braking import brake
from mmplan.planners.extended_jacobian.criterion import Partition, choose_partition
from mmplan.planners.extended_jacobian.generator import (
    GeneratorFunctions,
    ObstacleTerm,
    wheel_metric_inverse,
)
from mmplan.planners.extended_jacobian.options import RolloutOptions
from mmplan.planners.extended_jacobian.parameters import Shape, merge_slots, shape_of, slots_for
from mmplan.planners.extended_jacobian.posture import heading_reference, posture_weights
from mmplan.planners.extended_jacobian.rollout import RolloutResult, rollout
from mmplan.planners.extended_jacobian.settings import ExtendedJacobianSettings
from mmplan.planners.extended_jacobian.switching import PartitionSwitch
from mmplan.planners.extended_jacobian.time_scaling import scale_path
from mmplan.problem import Problem
from mmplan.robot.ground import ground_sphere_indices
from mmplan.task import ReachPoint
from mmplan.trajectory import Status

#: Default re-planning horizon [s].
HORIZON = 3.0
#: A time rate at or below this is the robot at rest (its path velocity dq / w undefined).
RATE_AT_REST = 1e-6
#: Largest |dq| [rad/s or m/s] of a robot counted at rest with a rate at rest: a braking plan
#: (braking.py) ends at w <= 1e-6, so the last 0.1 s before its stop hold |dq| up to ~1e-5; a
#: re-plan from there starts from rest (a step of at most this in the velocity).
STILL = 1e-3
#: Largest difference [rad or m, per second for dq] between the state given with ``elapsed``
#: and the last re-plan's state there (the robot follows that plan's samples and interpolant).
ON_PLAN = 1e-6


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
        self.limits = options  # the time scaling's: the torque zone, the rate limits
        self.limited = options.torque_control or options.rates is not None
        kinds = [ob.superellipsoid().exponents for ob in problem.scene.obstacles]
        kinds += [e for e in shapes for _ in range(spare)]
        slots = slots_for(kinds)
        self.slots = merge_slots(slots, tuple((e, k + spare) for e, k in slots))
        weights = posture_weights(self.robot, self.settings.posture_weight)
        self.posture = tuple(float(b) for b in weights)
        q0 = ej_checks.check_start(self.robot, problem.start)
        self.partition = choose_partition(self.robot, q0)
        self.heading = heading_reference(self.robot, q0, self.goal)
        self.fns = self._generator(self.partition, self.slots)
        self.winv = wheel_metric_inverse(self.robot)
        self._last: RolloutResult | None = None  # the last time-scaled plan returned

    def _generator(
        self, partition: Partition, slots: Sequence[tuple[Shape, int]], codegen: bool | None = None
    ) -> GeneratorFunctions:
        s = self.settings
        return ej_cache.generator(
            self.robot, partition, slots, s.penalty_weight, s.varrho,
            s.arm_gradient_weight, s.codegen if codegen is None else codegen, self.posture,
            self.heading, notify=cg.notice,  # a first compile says so, as plan() does
            exact=True,  # its slots (spare ones included) as asked, not a narrower library's
        ).fns  # fmt: skip

    def params(
        self, q: Array, scene: Any, goal: Array
    ) -> tuple[Array, Partition, ActiveSlots | None]:
        """p for the scene and goal, and the partition in it: chosen at q (the first one kept
        when the generator cannot take the new one); with more obstacles of a shape type than
        slots, the choice of the near ones (:mod:`~mmplan.planners.extended_jacobian.active`)."""
        s = self.settings
        models = [ob.enlarged(s.obstacle_margin).superellipsoid() for ob in scene.obstacles]
        obstacles = [
            ObstacleTerm(model, ob.influence if ob.influence is not None else s.influence)
            for model, ob in zip(models, scene.obstacles, strict=True)
        ]
        exponents = [model.exponents for model in models]
        have = dict(self.fns.layout.slots)
        if not all(have.get(shape_of(m), 0) for m in models):
            # before the goal's check: a goal under an obstacle of a new type is this error
            new = sorted({shape_name(shape_of(m)) for m in models if not have.get(shape_of(m))})
            kept = ", ".join(f"{k} {shape_name(e)}" for e, k in self.fns.layout.slots)
            raise InputError(
                "scene", f"no slot for {', '.join(new)} obstacles (slots: {kept}): make the "
                "Replanner with these shapes (its shapes argument)",
            )  # fmt: skip
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
        pairs = [(ob.model, ob.influence) for ob in obstacles]
        active = None
        if not layout.accepts(exponents):  # the near obstacles in the slots, chosen along
            active = ActiveSlots(self.robot, layout, pairs)
            pairs = []
        p = layout.pack(
            goal, self.options.gains, pairs, floor, part if layout.n_arm else None, heading
        )
        return p, part if layout.n_arm else self.partition, active

    def replan(
        self,
        q: ArrayLike,
        dq: ArrayLike,
        scene: Any,
        goal: ArrayLike | None = None,
        horizon: float = HORIZON,
        limits: bool = True,
        rate: float = 1.0,
        elapsed: float | None = None,
    ) -> RolloutResult:
        """The generator's motion from (q, dq) among ``scene``'s obstacles towards ``goal``
        (default: the problem's) over at most ``horizon`` seconds of its path, time-scaled
        under the robot's limits unless ``limits`` is False; ``rate``: the time rate w at
        (q, dq) of the time-scaled plan the robot follows (its ``u`` column; module
        docstring). ``elapsed``: the robot follows the plan this Replanner returned last,
        ``elapsed`` seconds into it (q, dq are that plan's there): when the new path cannot be
        taken at the robot's speed within the limits, the robot brakes along that plan instead
        (:mod:`~mmplan.planners.extended_jacobian.braking`; the returned plan says so)."""
        qv, dqv = self._state(q, "q"), self._state(dq, "dq")
        last, self._last = self._last, None  # set again below for a time-scaled plan
        if not (np.isfinite(rate) and 0.0 <= rate <= 1.0):
            raise InputError("rate", f"need 0 <= rate <= 1, got {rate}")
        if not (np.isfinite(horizon) and horizon > 0.0):
            raise InputError("horizon", f"need a finite time > 0 s, got {horizon}")
        if elapsed is not None and not (np.isfinite(elapsed) and elapsed >= 0.0):
            raise InputError("elapsed", f"need a finite time >= 0 s, got {elapsed}")
        target = self.goal if goal is None else np.asarray(goal, dtype=float)
        if target.shape != (3,) or not np.all(np.isfinite(target)):
            raise InputError("goal", f"need 3 finite numbers, got shape {target.shape}")
        scaled = limits and self.limited
        path_dq = dqv  # q' of the path: dq / w (w = 0: at rest)
        if scaled and rate <= RATE_AT_REST:
            fastest = float(np.max(np.abs(dqv), initial=0.0))
            if fastest > STILL:
                raise InputError(
                    "rate", f"{rate} with a moving robot (|dq| up to {fastest:.3g}): give the "
                    "rate it moves at",
                )  # fmt: skip
            path_dq = np.zeros_like(dqv)
        elif scaled:
            path_dq = dqv / rate
        try:
            p, part, active = self.params(qv, scene, target)
        except InputError as err:
            if err.field != "goal.position":
                raise
            slowed = self._brake(last, elapsed, f"goal blocked: {err.problem}", scene, qv, dqv)
            if slowed is not None and len(slowed.t) >= 2:
                return slowed
            return self._hold(qv, dqv, target, f"goal blocked: {err.problem}")
        opt = dataclasses.replace(self.options, t_max=horizon)

        def build(other: Partition) -> GeneratorFunctions:
            if self.fns.layout.supports(other):
                return self.fns
            # the VM, no compile; the slots of the generator in use (a wider library's,
            # cache.py: p keeps its layout)
            return self._generator(other, self.fns.layout.slots, codegen=False)

        switch = PartitionSwitch(self.robot, build, [part], opt.switch_cond)
        try:
            free = rollout(
                self.fns, self.robot.pfaffian, self.winv, qv, p, opt, switch, dq0=path_dq,
                active=active,
            )  # fmt: skip
        except CrowdedError as err:
            raise InputError("scene", f"{err}: make the Replanner with more spare slots") from err
        if not scaled:
            return free
        if len(free.t) < 2:  # no path: brake along the last plan; at rest, hold
            slowed = self._brake(last, elapsed, free.message, scene, qv, dqv)
            if slowed is not None and len(slowed.t) >= 2:
                return slowed
            if slowed is not None or float(np.max(np.abs(dqv), initial=0.0)) <= STILL:
                return self._hold(qv, np.zeros_like(dqv), target, f"held at rest: {free.message}")
            return dataclasses.replace(free, dq=dqv[None, :], u=np.full(1, rate))
        start = rate if rate > RATE_AT_REST else None  # at rest: as a plan starts
        res = scale_path(free, self.fns, self.limits, time_mode=True, start_rate=start)
        self._last = res
        if res.info.get("velocity_step") or res.status is Status.INFEASIBLE:
            why = "the new path cannot be taken at this speed within the limits"
            return self._brake(last, elapsed, why, scene, qv, dqv) or res
        return res

    def _brake(
        self,
        last: RolloutResult | None,
        elapsed: float | None,
        why: str,
        scene: Any,
        q: Array,
        dq: Array,
    ) -> RolloutResult | None:
        """The last plan, from ``elapsed`` on, brought to rest (:mod:`~mmplan.planners.
        extended_jacobian.braking`); None without one, for a robot at rest (it holds), or when
        its limits cannot stop it. A braking plan that meets an obstacle of ``scene`` is
        ``infeasible`` and says where (it is the old path: braking does not steer)."""
        if last is None or elapsed is None or float(np.max(np.abs(dq), initial=0.0)) <= STILL:
            return None
        if len(last.t) >= 2 and elapsed <= float(last.t[-1]):
            at_q, at_dq, _ = interpolant.evaluate(last.t, last.q, last.dq, np.array([elapsed]))
            off = max(float(np.max(np.abs(at_q[0] - q))), float(np.max(np.abs(at_dq[0] - dq))))
            if off > ON_PLAN:
                raise InputError(
                    "elapsed", f"the state is not the last re-plan's at {elapsed:g} s (off by "
                    f"{off:.3g}): pass elapsed only while following the last re-plan",
                )  # fmt: skip
        slowed = brake(last, elapsed, self.fns, self.limits, self.robot.actuator_efforts)
        if slowed is None:
            return None
        slowed.message += f": {why}"
        if scene.obstacles and self.robot.collision:
            points = np.vstack([self.robot.collision_points(q) for q in slowed.q])
            radii = np.tile(self.robot.collision_radii, len(slowed.q))
            gap, row, o = scene.nearest(points, radii)
            slowed.info["min_clearance_m"] = gap
            if gap < 0.0:
                when = float(slowed.t[row // len(self.robot.collision)])
                slowed.status = Status.INFEASIBLE
                slowed.message += f"; it meets obstacles[{o}] at t = {when:.3f} s ({gap:.3f} m)"
        self._last = slowed
        return slowed

    def _state(self, x: ArrayLike, name: str) -> Array:
        v = np.asarray(x, dtype=float)
        if v.shape != (self.robot.n,):
            raise InputError(name, f"need {self.robot.n} finite numbers, got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            bad = int(np.flatnonzero(~np.isfinite(v))[0])
            raise InputError(f"{name}[{bad}]", f"need a finite number, got {v[bad]}")
        return v

    def _hold(self, q: Array, dq: Array, goal: Array, message: str) -> RolloutResult:
        """One sample: the state (dq as given; ddq, tau and u zero: a state, not a command),
        with status infeasible and ``message``."""
        n, a = self.robot.n, len(self.robot.actuators)
        one = np.zeros((1, n))
        return RolloutResult(
            Status.INFEASIBLE, message, np.zeros(1), q[None, :], dq[None, :], one,
            np.zeros((1, a)), np.zeros(1), np.ones(1),
            np.array([float(np.linalg.norm(self.robot.ee_position(q) - goal))]),
        )  # fmt: skip
