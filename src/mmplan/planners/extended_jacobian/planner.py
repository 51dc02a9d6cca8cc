r"""Extended-Jacobian planner ([PajakPajak], [Pajak]; see docs/extended_jacobian.md).

A second-order trajectory generator drives the task error e_I = [k(q) - p_f; g(q)] and the
Pfaffian error e_II = A(q) dq to zero ([PajakPajak] eq. (16), [Pajak] eq. (12)), maximizing the
arm's manipulability through the transversality condition g = 0 (eq. (11) / (9)), avoiding obstacles
by a perturbation in the null space of A (eqs. (17)-(19)) and keeping actuator efforts inside their
limits by the virtual control ([PajakPajak] eqs. (20)-(31), [Pajak] eqs. (13)-(22)).

Torque limits, two formulations (``virtual_control.mode``):

* ``feedback``: [PajakPajak] eq. (23), [Pajak] eq. (17), u scales v2 (cases (a)-(d), growth
  laws of both papers, u0 = 0); the obstacle perturbation gets its own factor fitted to the
  torque budget (so that it cannot drive the robot into an obstacle or break a limit). Smooth torque
  start; used by youbot4r-reach-smooth.
* ``time``: the unconstrained generator fixes a collision-free path and a time-optimal time
  scaling w in [0, 1] keeps every effort in the safety zone (a true time scaling, which
  also slows the velocity terms); default when the scene has obstacles.

Velocity and acceleration limits (``robot.limits.rates``): the plan is always re-timed under
them (:mod:`~mmplan.planners.extended_jacobian.time_scaling`): in time mode, and without torque
control, the free generator path is scaled under efforts and rates together; in feedback mode
the virtual-control plan is re-timed afterwards. The online step does not hold rate limits.

Step refinement. Where the generator's path turns sharply within one RK4 step (the extended
Jacobian near-singular: cond(E) ~ 4e3 on a measured youbot-3r scene), the path's own samples
miss their motion (trapezoid residual of q against q' up to 1.1/s at w = 1, against the
checker's 0.08/s), and the re-timing's consistency rounds
(:mod:`~mmplan.planners.extended_jacobian.time_scaling`) walk from step to step without
converging (measured: 8 rounds, residual 0.30/s, a 15 s path stretched to 96 s). The plan is
then made again with half the step, down to ``MIN_DT``, when the residual is above the
checker's tolerance (``CHECK_RATIO`` x the rounds' target: below it the plan passes the check,
and a refined plan can be slower; measured on a random scene, 51.7 against 40.6 s):
that scene at 10 ms takes 2 rounds and passes the check; ``planner_info.refined_dt`` says so,
and the message says when the samples still miss their motion at ``MIN_DT``.

The modules this planner runs, in data-flow order, are listed in
:mod:`mmplan.planners.extended_jacobian`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Hashable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mmplan.compile import codegen as cg
from mmplan.errors import InputError
from mmplan.planners.base import Planner, register
from mmplan.planners.extended_jacobian import cache as ej_cache
from mmplan.planners.extended_jacobian import checks as ej_checks
from mmplan.planners.extended_jacobian import prefetch as ej_prefetch
from mmplan.planners.extended_jacobian.active import ActiveSlots, CrowdedError
from mmplan.planners.extended_jacobian.criterion import (
    Partition,
    build_criterion,
    choose_partition,
)
from mmplan.planners.extended_jacobian.generator import (
    GeneratorFunctions,
    ObstacleTerm,
    build_functions,
    wheel_metric_inverse,
)
from mmplan.planners.extended_jacobian.online import OnlineGenerator
from mmplan.planners.extended_jacobian.options import RolloutOptions
from mmplan.planners.extended_jacobian.parameters import shape_of, slots_for
from mmplan.planners.extended_jacobian.posture import heading_reference, posture_weights
from mmplan.planners.extended_jacobian.replan import Replanner
from mmplan.planners.extended_jacobian.rollout import RolloutResult, rollout
from mmplan.planners.extended_jacobian.settings import ExtendedJacobianSettings
from mmplan.planners.extended_jacobian.switching import PartitionSwitch
from mmplan.planners.extended_jacobian.time_scaling import (
    CHECK_RATIO,
    DQ_STEP_TOL,
    retime,
    rollout_time_scaled,
)
from mmplan.planners.near_slots import capped
from mmplan.problem import Problem, Progress
from mmplan.task import ReachPoint, completion_time
from mmplan.time_scaling import passes as topp_passes
from mmplan.trajectory import Solution, Status, Trajectory

#: Smallest RK4 step [s] the planner halves its step to (module docstring, step refinement).
MIN_DT = 0.005


@dataclass(frozen=True)
class _Prepared:
    """A checked problem with its compiled generator."""

    q0: NDArray[np.float64]
    p_f: NDArray[np.float64]
    params: NDArray[np.float64]  # p of the generator (parameters.py)
    fns: GeneratorFunctions
    options: RolloutOptions
    partition: Partition
    tolerance: float
    build_time: float
    time_scaling: bool
    switch: PartitionSwitch
    active: ActiveSlots | None = None  # more obstacles than slots (active.py)
    cap: dict[Hashable, int] | None = None  # slots a type was compiled with at most


@register
class ExtendedJacobian(Planner[ExtendedJacobianSettings, ReachPoint]):
    """Extended-Jacobian trajectory generator with virtual control ([PajakPajak], [Pajak])."""

    def _solve(
        self,
        problem: Problem,
        settings: ExtendedJacobianSettings,
        task: ReachPoint,
        progress: Progress,
    ) -> Solution:
        """Plan a point-to-point motion; see the module docstring.

        Raises:
            InputError: bad input detectable before planning (see :mod:`checks`).
        """
        prep = self._prepare(problem, guess=True)
        robot = problem.robot
        prep, res, _ = self._grown_run(problem, prep, prep.options, prep.switch)
        refined = prep.options
        while res.info.get("step_residual_ratio", 0.0) > CHECK_RATIO and refined.dt / 2 >= MIN_DT:
            # the samples miss their motion where the generator's path turns within a step
            # (module docstring): the same plan with half the step
            refined = dataclasses.replace(refined, dt=refined.dt / 2)
            switch = dataclasses.replace(prep.switch, partitions=[prep.partition])
            prep, res, switch = self._grown_run(problem, prep, refined, switch)
            res.info["refined_dt"] = refined.dt
            prep = dataclasses.replace(prep, switch=switch)
        if res.info.get("step_residual_ratio", 0.0) > CHECK_RATIO:
            res.message += (
                f"; the samples miss their motion by {res.info['step_residual_ratio']:.3g} x "
                f"{DQ_STEP_TOL:g} of the peak |dq| per step at dt = {refined.dt:g} s"
            )
        ee = prep.fns.ee_positions(res.q)
        if ee is None:  # the virtual machine
            ee = np.asarray(robot.functions["ee_position"].map(len(res.t))(res.q.T), float).T
        trajectory = Trajectory(
            coordinates=robot.coordinates,
            t=res.t,
            q=res.q,
            dq=res.dq,
            ddq=res.ddq,
            ee=ee,
            actuators=robot.actuators,
            tau=res.tau,
            u=res.u,
            extra={} if res.w is None else {"w": res.w},
        )
        r_names, f_names = prep.switch.partitions[-1].names(robot)
        info = dict(res.info)
        info.update(
            {
                "partition_R": list(r_names),
                "partition_F": list(f_names),
                "torque_control": prep.options.torque_control,
                "compiled": prep.fns.compiled,
                "build_time_s": prep.build_time,
            }
        )
        status, message = final_status(res.status, res.message, task, trajectory)
        return Solution(
            status=status,
            trajectory=trajectory,
            message=message,
            info=info,
            history={"error": res.error, "perturbation_scale": res.s},
        )

    @classmethod
    def _grown_run(
        cls, problem: Problem, prep: _Prepared, options: RolloutOptions, switch: PartitionSwitch
    ) -> tuple[_Prepared, RolloutResult, PartitionSwitch]:
        """:meth:`_run`; where more obstacles of a type come near the robot at once than the
        generator's slots, again with a generator of more slots of that type (its own switch),
        until they hold them (at most the scene's count: then no obstacle is left out)."""
        while True:
            try:
                return prep, cls._run(prep, problem.robot, options, switch), switch
            except CrowdedError as crowd:
                cap = crowd.grown(prep.cap or {})
                cg.notice(f"{crowd}: a generator with {cap[crowd.kind]} of them")
                prep = cls._prepare(problem, guess=True, cap=cap)
                switch = dataclasses.replace(prep.switch, partitions=[prep.partition])

    @staticmethod
    def _run(
        prep: _Prepared, robot: Any, options: RolloutOptions, switch: PartitionSwitch
    ) -> RolloutResult:
        """The generator's rollout with ``options`` (time-scaled, or re-timed for rates)."""
        run = rollout_time_scaled if prep.time_scaling else rollout
        res = run(
            prep.fns, robot.pfaffian, wheel_metric_inverse(robot), prep.q0, prep.params,
            options, switch, active=prep.active,
        )  # fmt: skip
        if not prep.time_scaling and options.rates is not None:
            res = retime(res, prep.fns, options)
        return res

    def online(self, problem: Problem) -> OnlineGenerator:
        """The generator as an online step for a control loop (state in; ddq, tau, u out)."""
        prep = self._prepare(problem, whole=True)  # p is fixed: every obstacle in a slot
        return OnlineGenerator(prep.fns, prep.params, prep.options)

    def replanner(self, problem: Problem, spare: int = 2) -> Replanner:
        """Re-planning from a moving state among moved or new obstacles with one compiled
        generator (:mod:`~mmplan.planners.extended_jacobian.replan`):
        ``replanner(problem).replan(q, dq, scene)``."""
        return Replanner(problem, spare)

    @classmethod
    def _prepare(
        cls,
        problem: Problem,
        guess: bool = False,
        whole: bool = False,
        cap: dict[Hashable, int] | None = None,
    ) -> _Prepared:
        """Checks, the compiled generator and the run options of ``problem`` (``guess``: start
        the rollout's first compiled chunk meanwhile, :meth:`GeneratorFunctions.guess_chunk`).
        ``whole``: a generator holding every obstacle (fixed parameters); else one compiled with
        at most ``cap`` slots of a type (None: :data:`~mmplan.planners.near_slots.SLOT_CAP`, and
        a narrower library on disk serves too), the near obstacles in them
        (:mod:`~mmplan.planners.extended_jacobian.active`)."""
        settings = cls.settings(problem.settings)
        robot, task = problem.robot, problem.task
        if not isinstance(task, ReachPoint):
            raise InputError("goal", f"the {cls.method} planner needs {ReachPoint.goal_form}")
        q0 = ej_checks.check_start(robot, problem.start)
        p_f = np.asarray(task.position, dtype=float)
        ej_checks.check_goal(robot, p_f)
        terms = [
            ObstacleTerm(
                ob.enlarged(settings.obstacle_margin).superellipsoid(),
                ob.influence if ob.influence is not None else settings.influence,
            )
            for ob in problem.scene.obstacles
        ]
        ej_checks.check_start_clearance(robot, problem.scene, terms, q0)
        obstacles = ej_checks.fit_influence(terms, p_f)
        floor = getattr(problem.scene, "ground", None)  # a duck-typed scene may have none
        ground = ej_checks.floor_term(robot, floor, settings.influence, q0, p_f)
        partition = choose_partition(robot, q0)
        posture = tuple(float(b) for b in posture_weights(robot, settings.posture_weight))
        heading = heading_reference(robot, q0, p_f)
        slots = slots_for([ob.model.exponents for ob in obstacles])  # type: ignore[attr-defined]
        if not whole:
            slots = capped(slots, cap or {})  # type: ignore[assignment]
        options = RolloutOptions.from_settings(settings, robot, task.tolerance)
        mode = settings.virtual_control.mode
        if mode == "auto":
            mode = "time" if obstacles else "feedback"
        # Rate limits without torque control: the free path, scaled (time mode).
        time_scaling = (options.torque_control and mode == "time") or (
            options.rates is not None and not options.torque_control
        )
        scaled = time_scaling or options.rates is not None
        if scaled:  # loaded while a chunk computes, or compiled alongside the generator
            ej_prefetch.while_waiting(topp_passes.load_passes)
            ej_prefetch.while_waiting(topp_passes.load_peaks)

        def before_build(message: str) -> None:  # a build: the passes compile alongside
            if scaled:
                topp_passes.prefetch()
            cg.notice(message)

        built = ej_cache.generator(
            robot,
            partition,
            slots,
            settings.penalty_weight,
            settings.varrho,
            settings.arm_gradient_weight,
            settings.codegen,
            posture,
            heading,
            notify=before_build,
            exact=whole or cap is not None,  # grown for a crowded scene: no narrower library
        )
        fns, build_time = built.fns, built.build_time
        pairs = [(ob.model, ob.influence) for ob in obstacles]
        active = None
        if not fns.layout.accepts([shape_of(m) for m, _ in pairs]):
            # a library with fewer slots of a type: the near obstacles in its slots
            active = ActiveSlots(robot, fns.layout, pairs)
            pairs = []
        params = fns.layout.pack(
            p_f, options.gains, pairs, ground, partition if fns.layout.n_arm else None, heading
        )
        if active is not None:
            try:
                params = active.start(params, q0)
            except CrowdedError as crowd:
                grown = crowd.grown(cap or {})
                cg.notice(f"{crowd}: a generator with {grown[crowd.kind]} of them")
                return cls._prepare(problem, guess, cap=grown)
        if guess and (not options.torque_control or time_scaling):  # from rest, no feedback:
            # its first chunks start meanwhile (each ends by t_max, as the rollout's)
            chunks = int(np.ceil(options.t_max / options.dt)) // fns.chunk_steps
            fns.guess_chunk(q0, params, options.dt, chunks, options.stop_error)
        try:
            ej_checks.check_conditioning(fns, q0, params, settings.cond_limit)
            if options.torque_control:
                ej_checks.check_gravity(robot, q0, fns)
        except BaseException:  # no plan: its guessed chunks would hold the worker thread
            fns.settle_guesses()
            raise

        def build(other: Partition) -> GeneratorFunctions:
            if fns.layout.supports(other):  # a value of p: the same (compiled) functions
                return fns
            # Another partition mid-run uses the SX virtual machine (no C build).
            crit = build_criterion(
                robot, other, settings.penalty_weight, posture=np.asarray(posture),
                heading=heading, parametric=True,
            )  # fmt: skip
            # the slots of the generator in use (a wider library's, cache.py): p keeps its
            # layout and the switched generator reads the same slots (retarget)
            return build_functions(
                robot, crit, fns.layout.slots, settings.varrho, settings.arm_gradient_weight
            )

        switch = PartitionSwitch(robot, build, [partition], options.switch_cond)
        return _Prepared(
            q0,
            p_f,
            params,
            fns,
            options,
            partition,
            task.tolerance,
            build_time,
            time_scaling,
            switch,
            active,
            cap,
        )


def final_status(
    status: Status, message: str, task: ReachPoint, trajectory: Trajectory
) -> tuple[Status, str]:
    """The run's status judged on its final (re-timed) trajectory, as the checker judges it.

    The rollout stops at half the tolerance (``stop_error``), so a run cut by ``t_max`` or a
    stall verdict may end inside the tolerance: that run completed the task and is
    ``reached`` (seen: a ``timeout`` whose final error was 0.68 mm of 1 mm). A run
    ``reached`` whose trajectory ends outside the tolerance is ``stalled``. Other statuses
    (a broken limit, a divergence) stand.
    """
    errors = task.errors(trajectory.t, trajectory.ee)
    done = completion_time(trajectory.t, errors, float(task.tolerance)) is not None
    final = f"final error {float(errors[-1]):.3g} m, tolerance {float(task.tolerance):g} m"
    if status in (Status.TIMEOUT, Status.STALLED) and done:
        return Status.REACHED, f"goal reached ({final}) when the run ended: {message}"
    if status is Status.REACHED and not done:
        return Status.STALLED, f"the trajectory ends outside the tolerance ({final}): {message}"
    return status, message
