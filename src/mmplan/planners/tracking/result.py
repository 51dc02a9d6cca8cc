"""Results of the path-tracking rollouts ([AbdessemedDjebrani]): trajectory, status, info, history.

The trajectory's ddq is the central difference of dq; the clearance is measured exactly
against the scene's (original) obstacles at the robot's collision spheres.

Rate limits (``robot.limits.rates``): a tracker follows a path given in time, so it cannot
slow down; a plan whose velocities or accelerations exceed a limit, at a sample or on the
cubic Hermite interpolant between samples (:mod:`mmplan.interpolant`, the trajectory's meaning
there; :meth:`~mmplan.time_scaling.rates.RateModel.first_violation`, slack 1e-6), is
``infeasible`` and the message names the quantity, the time and the limit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.planners.tracking.active import TrackerSlots
from mmplan.planners.tracking.rollout import Rollout, StopRules, rollout
from mmplan.planners.tracking.settings import TrackingSettings
from mmplan.problem import Problem, Progress
from mmplan.robot.robot import Robot
from mmplan.scene.scene import Scene
from mmplan.task import TrackPath, completion_time
from mmplan.time_scaling.rates import RateModel
from mmplan.trajectory import Solution, Status, Trajectory


def differentiate(dq: Array, dt: float) -> Array:
    """ddq by central differences of dq (one-sided at the ends; zeros for one sample), (N, n)."""
    if len(dq) < 2:
        return np.zeros_like(dq)
    return np.asarray(np.gradient(dq, dt, axis=0), dtype=float)


def clearance_series(robot: Robot, scene: Scene, q: Array) -> Array | None:
    """Exact clearance of the collision spheres at each sample (N,); None without obstacles."""
    if not scene.obstacles:
        return None
    P = len(robot.collision)
    pts = robot.collision_points_at(q).reshape(-1, 3)  # (N P, 3), compiled when on disk
    nearest = np.full(len(pts), np.inf)  # obstacle by obstacle: no (N P, n_obs) matrix
    for obstacle in scene.obstacles:
        np.minimum(nearest, obstacle.distance(pts), out=nearest)
    d = nearest.reshape(len(q), P) - robot.collision_radii[None, :]
    return np.asarray(d.min(axis=1), dtype=float)


def finish(
    run: Rollout,
    robot: Robot,
    scene: Scene,
    task: TrackPath,
    dt: float,
    settle_time: float,
    timed_out: bool,
    info: Mapping[str, Any],
) -> Solution:
    """Trajectory, status and info of a finished rollout.

    Status: the rollout's own stop status when it stopped early; otherwise ``timeout`` when
    ``t_max`` cut the path short, ``reached`` when the tracking error stays below the task
    tolerance until the end, ``stalled`` when it does not.
    """
    ddq = differentiate(run.dq, dt)
    trajectory = Trajectory(robot.coordinates, run.t, run.q, run.dq, ddq, run.ee)
    clearance = clearance_series(robot, scene, run.q)
    settled = run.t >= settle_time - 1e-9
    max_err_settled = float(run.error[settled].max()) if settled.any() else None
    t_tol = completion_time(run.t, run.error, task.tolerance)
    full_info: dict[str, Any] = {
        "max_error_after_settle_m": max_err_settled,
        "settle_time_s": settle_time,
        "final_error_m": float(run.error[-1]),
        "min_clearance_m": None if clearance is None else float(clearance.min()),
        "min_singular_value_bound": float(np.nanmin(run.sigma))
        if np.isfinite(run.sigma).any()
        else None,
        "steps": len(run.t),
        **info,
    }
    if run.status is not None:
        status, message = run.status, run.message
    elif timed_out:
        status = Status.TIMEOUT
        message = f"t_max reached at t = {run.t[-1]:.3f} s before the path end"
    elif t_tol is None:
        status = Status.STALLED
        message = (
            f"tracking error {run.error[-1]:.2e} m at the path end exceeds {task.tolerance:g} m"
        )
    else:
        status = Status.REACHED
        message = (
            f"tracked {run.t[-1]:.2f} s; error below {task.tolerance:g} m from t = {t_tol:.2f} s"
        )
    if robot.limits.rates.any:
        broken = RateModel.of(robot).first_violation(run.t, run.dq, ddq, run.q)
        full_info["rate_limits_held"] = broken is None
        if broken is not None:
            full_info["rate_violation"] = broken.message
            if status is not Status.DIVERGED:
                status = Status.INFEASIBLE
            message = f"the path needs more than the rate limits: {broken.message}; {message}"
    if clearance is not None and clearance.min() < 0:
        k = int(np.argmin(clearance))
        message += f"; the robot collides (clearance {clearance[k]:.3f} m at t = {run.t[k]:.2f} s)"
    history: dict[str, Array] = {
        "t": run.t,
        "tracking_error_m": run.error,
        "sigma_bound": run.sigma,
    }
    if clearance is not None:
        history["clearance_m"] = clearance
    return Solution(status, trajectory, message, full_info, history)


def track(
    problem: Problem,
    settings: TrackingSettings,
    task: TrackPath,
    step: ca.Function,
    state0: Array,
    reference: Callable[[float], Array],
    exact_sigma: Callable[[Array], float],
    progress: Progress,
    info: Callable[[Rollout], Mapping[str, Any]] = lambda run: {},
    params: Array | None = None,
    active: TrackerSlots | None = None,
) -> Solution:
    """Roll a compiled tracking step along ``task`` and finish the result.

    Shared by both trackers: the horizon is min(path duration, t_max) at ``settings.dt``;
    ``info(run)`` adds method-specific numbers; ``params``: the step's parameters (the
    obstacles' numbers, :mod:`.slots`); ``active``: which obstacles p holds, chosen along the
    run (:mod:`.active`).
    """
    t_end = min(task.duration, settings.t_max)
    steps = math.ceil(t_end / settings.dt - 1e-9)  # t[-1] covers t_end
    run = rollout(
        step,
        state0,
        reference,
        problem.robot,
        settings.dt,
        steps,
        StopRules.of(settings),
        exact_sigma,
        progress,
        params,
        active,
    )
    return finish(
        run,
        problem.robot,
        problem.scene,
        task,
        settings.dt,
        settings.settle_time,
        task.duration > settings.t_max,
        info(run),
    )
