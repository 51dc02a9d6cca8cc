"""Result of the manipulability-area planner: trajectory, summary scalars, report data.

Turns a base path (one base position per layer) into the whole-body trajectory (arm joints
by exact IK at each layer), verifies it (exact w against the threshold, task error of the
robot model's FK) and packs the data of [Nagatani]'s figures 3, 4, 5 and 8 as artifacts.
"""

from __future__ import annotations

import numpy as np

from mmplan.arrays import Array, BoolArray
from mmplan.planners.manipulability_area import grid as lma_grid
from mmplan.planners.manipulability_area import path as lma_path
from mmplan.planners.manipulability_area.arms import Arm
from mmplan.problem import Problem
from mmplan.robot.ground import floor_clearances
from mmplan.robot.robot import Robot
from mmplan.trajectory import Solution, Status, Trajectory


def _ee(problem: Problem, q: Array) -> Array:
    """End-effector positions from the robot model's FK, (N, 3)."""
    fn = problem.robot.functions["ee_position"].map(len(q))
    return np.asarray(fn(q.T), dtype=float).T.reshape(len(q), 3)


def _trajectory(problem: Problem, s: Array, q: Array, dq: Array | None = None,
                ddq: Array | None = None) -> Trajectory:
    """Rows at layer parameters s; dq, ddq are d/ds (zeros for a single row)."""
    zeros = np.zeros_like(q)
    return Trajectory(problem.robot.coordinates, s, q, zeros if dq is None else dq,
                      zeros if ddq is None else ddq, _ee(problem, q))


def platform_motion(robot: Robot, xy: Array, v_base: Array, a_base: Array, heading: float,
                    s: Array) -> tuple[Array, Array, Array, float]:
    """Platform columns (N, n_platform) of q, d/ds, d2/ds2 along the base path (x, y at a
    fixed heading), and the largest Pfaffian residual |A(q) dq| of that motion.

    Wheel coordinates (a differential drive) roll with the base: their rates solve
    A(q) dq = 0 for the given (dx, dy, 0) in the least-squares sense, their angles are the
    trapezoid integral of the rates in s (what the checker compares) and their second
    derivative the central difference of the rates. A base that moves sideways to its heading
    leaves a residual (a differential drive cannot): the caller reports it."""
    N, n_p = len(xy), robot.n_platform
    qp = np.zeros((N, n_p))
    dqp, ddqp = np.zeros((N, n_p)), np.zeros((N, n_p))
    qp[:, :2], qp[:, 2] = xy, heading
    dqp[:, :2], ddqp[:, :2] = v_base, a_base
    if robot.h == 0:
        return qp, dqp, ddqp, 0.0
    q = np.zeros(robot.n)
    residual = 0.0
    for k in range(N):
        q[:n_p] = qp[k]
        A = robot.pfaffian(q)[:, :n_p]
        if n_p > 3:
            rhs = -A[:, :3] @ dqp[k, :3]
            dqp[k, 3:] = np.linalg.lstsq(A[:, 3:], rhs, rcond=None)[0]
        residual = max(residual, float(np.abs(A @ dqp[k]).max()))
    ds = np.diff(s)[:, None]
    qp[1:, 3:] = np.cumsum(0.5 * ds * (dqp[:-1, 3:] + dqp[1:, 3:]), axis=0)
    if N > 1:
        ddqp[:, 3:] = np.gradient(dqp[:, 3:], s, axis=0)
    return qp, dqp, ddqp, residual


def failure(problem: Problem, message: str) -> Solution:
    """An infeasible result holding the start configuration as its only row."""
    q = np.asarray(problem.start, dtype=float)[None, :]
    traj = _trajectory(problem, np.zeros(1), q)
    return Solution(Status.INFEASIBLE, traj, message)


def _limit_violation(problem: Problem, q_arm: Array) -> float:
    """Largest joint-limit violation [rad] after shifting angles by 2 pi where that helps."""
    lo, hi = problem.robot.limits.joint_min, problem.robot.limits.joint_max
    q, _ = lma_grid.fit_joint_limits(q_arm, lo, hi)
    return float(np.max(np.maximum(0.0, np.maximum(lo - q, q - hi))))


def assemble(
    problem: Problem,
    stack: lma_grid.LayerStack,
    masks: BoolArray,
    threshold: float,
    poses: lma_grid.ToolPoses,
    way_xy: Array,
    keep: list[int],
    arm: Arm,
    *,
    kind: str,
    straight_groups: int,
) -> Solution:
    """Trajectory through the sub-goals ``way_xy`` (K, 2) at layers ``keep`` (K,), sampled at
    the (dense) ``poses``, and the result: reached unless the exact manipulability or the task
    error says otherwise. Corners get parabolic blends over half a layer interval when the
    exact w stays above the threshold with them
    (:func:`mmplan.planners.manipulability_area.path.blended_polyline`)."""
    L = len(stack.poses.s)
    m = (len(poses.s) - 1) // (L - 1)
    way_s = stack.poses.s[keep]
    for half in ([0.5 / (L - 1), 0.0] if len(keep) > 2 else [0.0]):
        xy, v_base, a_base = lma_path.blended_polyline(way_s, way_xy, poses.s, half)
        q_arm, w, ok = arm.along(problem.robot, poses, xy)
        if ok.all() and w.min() >= threshold:
            break
    qp, dqp, ddqp, pfaffian = platform_motion(problem.robot, xy, v_base, a_base,
                                              poses.heading, poses.s)
    q = np.column_stack([qp, q_arm])
    rates: tuple[Array | None, Array | None] = (None, None)
    if ok.all():
        dq_arm, ddq_arm = arm.arm_rates(poses, q_arm, v_base, a_base)
        rates = (np.column_stack([dqp, dq_arm]), np.column_stack([ddqp, ddq_arm]))
    traj = _trajectory(problem, poses.s, q, *rates)
    err = problem.task.errors(traj.t, traj.ee)
    steps = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    floor_gaps = floor_clearances(problem.robot, q, problem.scene.ground or 0.0)  # (N, G)
    floor_gap = (float(floor_gaps.min()) if problem.scene.ground is not None and floor_gaps.size
                 else None)
    info = {
        "manipulability_threshold": float(threshold),
        "manipulability_min": float(w.min()),
        "manipulability_max_lma": float(stack.w.max()),
        "path_length_m": float(steps.sum()),
        "path_kind": kind,
        "start_xy": [float(v) for v in xy[0]],
        "end_xy": [float(v) for v in xy[-1]],
        "heading_rad": float(poses.heading),
        "subgoal_layers": list(keep),
        "subgoal_xy": way_xy.tolist(),
        "corner_blend_half_width": float(half),
        "rows_per_layer": int(m),
        "straight_lengths_checked": int(straight_groups),
        "layers": L,
        "cells_per_layer": int(stack.w[0].size),
        "ma_cells_min": int(masks.sum(axis=(1, 2)).min()),
        "max_task_error_m": float(err.max()),
        "max_joint_limit_violation_rad": _limit_violation(problem, q_arm),
        "min_floor_clearance_m": floor_gap,
    }
    layer_xy = xy[::m]
    cells = (layer_xy - np.array([stack.grid.xs[0], stack.grid.ys[0]])) / stack.grid.resolution
    artifacts = {
        "grid_x": stack.grid.xs,
        "grid_y": stack.grid.ys,
        "layer_s": stack.poses.s,
        "tool_positions": stack.poses.positions,
        "manipulability_first": stack.w[0],
        "manipulability_last": stack.w[-1],
        "manipulability_max_per_layer": stack.w.max(axis=(1, 2)),
        "ma_masks": masks.astype(float),
        "path_xy": layer_xy,
        "path_cells": cells,
        "path_s": poses.s,
        "path_xy_rows": xy,
        "path_manipulability": w,
        "subgoal_layers": np.asarray(keep, dtype=float),
        "threshold": np.array([threshold]),
    }
    if pfaffian > 1e-9:
        status = Status.INFEASIBLE
        platform = type(problem.robot.platform).__name__
        message = (f"the base path moves sideways to the heading {poses.heading:.4g} rad, "
                   f"which a {platform} platform cannot (|A(q) dq| up to {pfaffian:.3g})")
    elif not ok.all():
        k = int(np.flatnonzero(~ok)[0])
        status = Status.INFEASIBLE
        message = f"s={poses.s[k]:.3f} (layer {k / m:g}): no IK solution on the planned path"
    elif w.min() < threshold:
        k = int(np.argmin(w))
        status = Status.INFEASIBLE
        message = (f"s={poses.s[k]:.3f} (layer {k / m:g}): w {w[k]:.5g} < threshold "
                   f"{threshold:.5g} on the planned path")
    elif err.max() >= problem.task.tolerance:
        status = Status.INFEASIBLE
        message = f"task error {err.max():.3g} m >= tolerance {problem.task.tolerance} m"
    elif floor_gap is not None and floor_gap < 0:  # the IK arm reaches through the floor
        k = int(np.argmin(floor_gaps.min(axis=1)))
        status = Status.INFEASIBLE
        message = (f"s={poses.s[k]:.3f} (layer {k / m:g}): the arm reaches {-floor_gap:.4g} m "
                   f"below the floor z = {problem.scene.ground:g} on the planned path")
    elif info["max_joint_limit_violation_rad"] > 1e-9:
        # The path ignores the limits (as [Nagatani] does, respect_joint_limits false), but a
        # plan that breaks the robot's limits is not one it can execute: never "reached".
        status = Status.INFEASIBLE
        message = (
            f"the arm leaves its joint limits by up to "
            f"{info['max_joint_limit_violation_rad']:.4g} rad; set planner.respect_joint_limits: "
            "true to plan inside them"
        )
    else:
        status = Status.REACHED
        message = (
            f"{kind} base path, {info['path_length_m']:.3f} m, w min "
            f"{info['manipulability_min']:.5f} >= threshold {threshold:.5f} m^3"
        )
    return Solution(status, traj, message, info, artifacts=artifacts)
