"""Input checks of the extended-Jacobian planner, run before planning (InputError, exit 2).

A start at a singularity (mu ~ 0, Jc_R or E singular), in collision or inside an obstacle's
safety margin, a goal outside the arm's vertical reach, and torque limits that cannot even
hold the robot at rest are all detectable before the first step.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from mmplan import linalg
from mmplan.arrays import Array
from mmplan.compile.disk_memo import remember
from mmplan.errors import InputError
from mmplan.planners.extended_jacobian.generator import GeneratorFunctions, ObstacleTerm
from mmplan.robot.ground import ground_sphere_indices
from mmplan.robot.robot import Robot

#: Below this manipulability the start counts as singular.
MU_MIN = 1e-4


def check_start(robot: Robot, start: ArrayLike) -> Array:
    """q0 as an array; finite, strictly inside the arm joint limits, not arm-singular."""
    q0 = np.asarray(start, dtype=float)
    if q0.shape != (robot.n,):
        raise InputError(
            "start", f"expected {robot.n} values {robot.coordinates}, got shape {q0.shape}"
        )
    if not np.all(np.isfinite(q0)):
        raise InputError("start", f"contains NaN or inf: {q0.tolist()}")
    qa = q0[list(robot.arm_indices)]
    lo, hi = robot.limits.joint_min, robot.limits.joint_max
    bad = np.flatnonzero((qa <= lo) | (qa >= hi))
    if bad.size:
        i = int(bad[0])
        name = robot.arm_coordinates[i]
        raise InputError(
            f"start[{robot.arm_indices[i]}]",
            f"{name} = {qa[i]:.4g} is not strictly inside its limits [{lo[i]:.4g}, {hi[i]:.4g}]",
        )
    mu = robot.manipulability(q0)
    if mu < MU_MIN:
        raise InputError("start", f"arm singular at the start: manipulability {mu:.3g} < {MU_MIN}")
    return q0


def check_goal(robot: Robot, p_f: Array, samples: int = 4096) -> None:
    """The goal height must lie within the arm's vertical reach (sampled over the joint limits)."""
    if p_f.shape != (3,) or not np.all(np.isfinite(p_f)):
        raise InputError("goal.position", f"expected 3 finite numbers, got {p_f.tolist()}")
    z_lo, z_hi = _vertical_reach(robot, samples)
    if not z_lo <= p_f[2] <= z_hi:
        raise InputError(
            "goal.position[2]",
            f"height {p_f[2]:.3f} m is outside the arm's reach [{z_lo:.3f}, {z_hi:.3f}] m",
        )


def _vertical_reach(robot: Robot, samples: int) -> tuple[float, float]:
    """Sampled [min, max] end-effector height over the joint limits, +-0.02 m (kept per
    robot object and on disk by the robot model's fingerprint, :mod:`mmplan.compile.disk_memo`:
    sampling costs 20-40 ms a process, the same per-process cost the compiled generator's
    disk cache removes)."""

    def sample() -> tuple[float, float]:
        rng = np.random.default_rng(0)
        lo, hi = robot.limits.joint_min, robot.limits.joint_max
        Q = np.zeros((samples, robot.n))
        Q[:, list(robot.arm_indices)] = lo + (hi - lo) * rng.random((samples, len(lo)))
        Z = np.asarray(robot.functions["ee_position"].map(samples)(Q.T), dtype=float)[2]
        return float(Z.min()) - 0.02, float(Z.max()) + 0.02

    # the fingerprint covers the joint limits and the kinematics the sample depends on
    def decode(data: list[float]) -> tuple[float, float]:
        return float(data[0]), float(data[1])

    return remember(robot, __file__, "reach", samples, sample, list, decode)


def check_start_clearance(
    robot: Robot, scene: Any, obstacles: Sequence[ObstacleTerm], q0: Array
) -> None:
    """No collision point inside an obstacle, nor inside its enlarged planner model."""
    if not obstacles:
        return
    points = robot.collision_points(q0)  # (P, 3)
    radii = np.asarray(robot.collision_radii, dtype=float)  # (P,)
    exact = np.asarray(scene.distances(points), dtype=float) - radii[:, None]  # (P, n_obs)
    if exact.size and float(exact.min()) < 0.0:
        j = int(np.unravel_index(int(np.argmin(exact)), exact.shape)[1])
        raise InputError("start", f"in collision with obstacle {j} (distance {exact.min():.3f} m)")
    for j, ob in enumerate(obstacles):
        c_min = float(np.min(ob.model.radial_distance(points) - radii))
        if c_min <= 0.0:
            raise InputError(
                "start",
                f"inside the safety margin of obstacle {j} "
                f"(radial distance {c_min:.3f} m to the enlarged model)",
            )


def check_conditioning(fns: GeneratorFunctions, q0: Array, p: Array, cond_limit: float) -> None:
    """E(q0) must be well conditioned (eq. (16) needs E^-1); p: the generator parameters."""
    E = fns.E_at(q0, p)
    cond = linalg.cond(E)
    if not np.isfinite(cond) or cond > cond_limit:
        raise InputError("start", f"E(q0) is singular (cond {cond:.3g} > {cond_limit:.3g})")


def check_gravity(robot: Robot, q0: Array, fns: GeneratorFunctions) -> None:
    """At rest (u0 = 0) only gravity acts: those efforts must lie inside the torque limits.

    The efforts come from the generator's (compiled) ``effort`` (Tg: the formula of
    :meth:`~mmplan.robot.robot.Robot.actuator_efforts` at dq = ddq = 0, equal to rounding,
    tested) without building the robot's effort function (1.5-2.4 ms of a process's first
    plan, measured).
    """
    tau = fns.gravity_efforts(q0)
    lo, hi = robot.limits.torque_min, robot.limits.torque_max
    bad = np.flatnonzero((tau < lo - 1e-9) | (tau > hi + 1e-9))
    if bad.size:
        i = int(bad[0])
        side = "min" if tau[i] < lo[i] else "max"
        raise InputError(
            f"limits.torque.{side}[{i}]",
            f"{robot.actuators[i]} needs {tau[i]:.3f} N m to hold the start at rest, "
            f"outside [{lo[i]}, {hi[i]}]: infeasible torque limits",
        )


def floor_term(
    robot: Robot, ground: float | None, influence: float, q0: Array, p_f: Array
) -> tuple[float, float] | None:
    """The floor's (h, delta) for the generator, None without a floor or without spheres it
    applies to (:mod:`mmplan.robot.ground`). delta is fitted to the goal as an obstacle's
    (:func:`fit_influence`): min(delta, max(0.05, 0.7 (z_f - h))).

    Raises:
        InputError: the goal lies below the floor, or a sphere starts below it.
    """
    spheres = list(ground_sphere_indices(robot))
    if ground is None or not spheres:
        return None
    if p_f[2] < ground:
        raise InputError(
            "goal.position[2]", f"height {p_f[2]:.3f} m is below the floor z = {ground:.3f} m"
        )
    radii = np.asarray(robot.collision_radii, dtype=float)[spheres]
    gap = float(np.min(robot.collision_points(q0)[spheres, 2] - radii)) - ground
    if gap < 0.0:
        raise InputError("start", f"below the floor z = {ground:.3f} m by {-gap:.3f} m")
    return ground, min(influence, max(0.05, 0.7 * (float(p_f[2]) - ground)))


def fit_influence(obstacles: Sequence[ObstacleTerm], p_f: Array) -> list[ObstacleTerm]:
    """Shrink each neighbourhood delta so that the goal lies outside it.

    With the goal inside an obstacle's neighbourhood the perturbation ([PajakPajak] eq. (19)) and
    the attraction reach an equilibrium short of the goal (measured: stalls 0.07-0.1 m away on
    random scenes). delta becomes min(delta, max(0.05, 0.7 C(p_f))), C the radial distance of the
    goal to the enlarged model.

    Raises:
        InputError: the goal lies inside an enlarged obstacle (unreachable without contact).
    """
    out = []
    for j, ob in enumerate(obstacles):
        c_goal = float(ob.model.radial_distance(p_f[None, :])[0])
        if c_goal <= 0.0:
            raise InputError(
                "goal.position",
                f"inside obstacle {j} or its safety margin (radial distance {c_goal:.3f} m)",
            )
        out.append(ObstacleTerm(ob.model, min(ob.influence, max(0.05, 0.7 * c_goal))))
    return out
