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
from mmplan.problem import Problem
from mmplan.robot.library import base_6dof_ik as puma_ik
from mmplan.robot.library.base_6dof_ik import PumaGeometry
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


def _rates(geom: PumaGeometry, poses: lma_grid.ToolPoses, q_arm: Array, v_base: Array,
           a_base: Array) -> tuple[Array, Array]:
    """Exact d/ds and d2/ds2 of q along the planned motion, (N, 9) each: base velocity and
    acceleration given, the tool along the segment at constant orientation; the arm rates
    solve J dq = (v_tool - v_base, 0) in the arm frame
    (:func:`mmplan.robot.library.base_6dof_ik.joint_rates`)."""
    N = len(poses.s)
    c, s = np.cos(poses.heading), np.sin(poses.heading)
    Rz_T = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    v_tool = (poses.positions[-1] - poses.positions[0]) / (poses.s[-1] - poses.s[0])
    v_rel = (v_tool[None] - np.column_stack([v_base, np.zeros(N)])) @ Rz_T.T
    a_rel = -np.column_stack([a_base, np.zeros(N)]) @ Rz_T.T
    dq_arm, ddq_arm = puma_ik.joint_rates(geom, q_arm, v_rel, a_rel)
    dq = np.column_stack([v_base, np.zeros(N), dq_arm])
    ddq = np.column_stack([a_base, np.zeros(N), ddq_arm])
    return dq, ddq


def _along(geom: PumaGeometry, problem: Problem, poses: lma_grid.ToolPoses, xy: Array,
           branch: lma_grid.Branch,
           limits: tuple[Array, Array] | None) -> tuple[Array, Array, BoolArray]:
    """Arm joints (N, 6) by exact IK at bases ``xy`` (N, 2) (angles shifted by 2 pi into the
    robot's limits where that helps), exact w (N,) and the valid mask (N,)."""
    N = len(poses.s)
    q_arm, ok = np.zeros((N, 6)), np.zeros(N, dtype=bool)
    robot_limits = (problem.robot.limits.joint_min, problem.robot.limits.joint_max)
    for k in range(N):
        qk, okk = lma_grid.configurations(geom, poses, k, xy[k][None], branch)
        qk, inside = lma_grid.fit_joint_limits(qk, *robot_limits)
        q_arm[k], ok[k] = qk[0], okk[0] and (limits is None or inside[0])
    return q_arm, np.where(ok, puma_ik.manipulability(geom, q_arm), 0.0), ok


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
    branch: lma_grid.Branch,
    limits: tuple[Array, Array] | None,
    *,
    kind: str,
    straight_groups: int,
) -> Solution:
    """Trajectory through the sub-goals ``way_xy`` (K, 2) at layers ``keep`` (K,), sampled at
    the (dense) ``poses``, and the result: reached unless the exact manipulability or the task
    error says otherwise. Corners get parabolic blends over half a layer interval when the
    exact w stays above the threshold with them
    (:func:`mmplan.planners.manipulability_area.path.blended_polyline`)."""
    geom = PumaGeometry.base_6dof()
    L = len(stack.poses.s)
    m = (len(poses.s) - 1) // (L - 1)
    way_s = stack.poses.s[keep]
    for half in ([0.5 / (L - 1), 0.0] if len(keep) > 2 else [0.0]):
        xy, v_base, a_base = lma_path.blended_polyline(way_s, way_xy, poses.s, half)
        q_arm, w, ok = _along(geom, problem, poses, xy, branch, limits)
        if ok.all() and w.min() >= threshold:
            break
    N = len(poses.s)
    q = np.column_stack([xy, np.full(N, poses.heading), q_arm])
    rates = _rates(geom, poses, q_arm, v_base, a_base) if ok.all() else (None, None)
    traj = _trajectory(problem, poses.s, q, *rates)
    err = problem.task.errors(traj.t, traj.ee)
    steps = np.linalg.norm(np.diff(xy, axis=0), axis=1)
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
    if not ok.all():
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
