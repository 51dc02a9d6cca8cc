r"""The arm's inverse kinematics for the manipulability-area planner ([Nagatani]).

The planner needs, for a tool pose and many base positions, the arm configuration there and
its manipulability :math:`w = \sqrt{\det(J J^T)}` (J the 6-row tool Jacobian of the arm,
[Nagatani] eq. (1)). Two sources:

* :class:`PumaArm` -- base-6dof's scaled PUMA 560: closed-form IK, one configuration per base
  position and IK branch (:mod:`mmplan.planners.manipulability_area.grid`,
  :mod:`mmplan.robot.library.base_6dof_ik`);
* :class:`NumericArm` -- any other arm of >= 6 joints (TIAGo's 7): numeric IK on the robot's
  own kinematics (:class:`~mmplan.robot.numeric_ik.ArmIK`, joint limits always respected).
  The tool axis (``tool_axis`` of the end-effector body's frame) points into the surface; the
  roll about it is free. A redundant arm has many configurations per base position; we
  choose them as a continuous motion would: at the first layer (first row) the converged
  seed of largest w, then each layer (row) continued from the previous one's solution (fresh
  random seeds, best w, only where the continuation does not converge). On the grid that is
  done per cell over the layers; along a planned path row by row, and that w is the one
  verified against the threshold. Arm rates along the path: central differences in s.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from mmplan.arrays import Array, BoolArray
from mmplan.planners.manipulability_area import grid as lma_grid
from mmplan.robot.library import base_6dof_ik as puma_ik
from mmplan.robot.library.base_6dof_ik import PumaGeometry
from mmplan.robot.numeric_ik import ArmIK
from mmplan.robot.robot import Robot

Limits = tuple[Array, Array] | None
#: Largest change of an arm joint between two rows of a path [rad or m] (numeric IK).
MAX_ROW_CHANGE = 0.2


class Arm(Protocol):
    """What the planner asks of an arm (see the module docstring)."""

    def layer_stack(self, grid: lma_grid.Grid, poses: lma_grid.ToolPoses) -> lma_grid.LayerStack:
        """w and reachability of every layer over the grid."""
        ...

    def path_manipulability(self, poses: lma_grid.ToolPoses, layers: range, xy: Array) -> Array:
        """Exact w along base paths ``xy`` (M, len(layers), 2) -> (M, len(layers))."""
        ...

    def along(self, robot: Robot, poses: lma_grid.ToolPoses,
              xy: Array) -> tuple[Array, Array, BoolArray]:
        """Arm joints (N, n_arm), w (N,) and valid mask (N,) at one base path (N, 2)."""
        ...

    def arm_rates(self, poses: lma_grid.ToolPoses, q_arm: Array, v_base: Array,
                  a_base: Array) -> tuple[Array, Array]:
        """d/ds and d2/ds2 of the arm joints along the path, (N, n_arm) each."""
        ...


class PumaArm:
    """base-6dof's PUMA: closed-form IK (the planner as in [Nagatani], bit for bit)."""

    def __init__(self, branch: lma_grid.Branch, limits: Limits) -> None:
        self.geom = PumaGeometry.base_6dof()
        self.branch = branch
        self.limits = limits

    def layer_stack(self, grid: lma_grid.Grid, poses: lma_grid.ToolPoses) -> lma_grid.LayerStack:
        """:func:`mmplan.planners.manipulability_area.grid.layer_stack`."""
        return lma_grid.layer_stack(self.geom, grid, poses, self.branch, self.limits)

    def path_manipulability(self, poses: lma_grid.ToolPoses, layers: range, xy: Array) -> Array:
        """:func:`mmplan.planners.manipulability_area.grid.path_manipulability`."""
        return lma_grid.path_manipulability(self.geom, poses, layers, xy, self.branch,
                                            self.limits)

    def along(self, robot: Robot, poses: lma_grid.ToolPoses,
              xy: Array) -> tuple[Array, Array, BoolArray]:
        """Arm joints (N, 6) by exact IK at bases ``xy`` (N, 2) (angles shifted by 2 pi into
        the robot's limits where that helps), exact w (N,) and the valid mask (N,)."""
        N = len(poses.s)
        q_arm, ok = np.zeros((N, 6)), np.zeros(N, dtype=bool)
        robot_limits = (robot.limits.joint_min, robot.limits.joint_max)
        for k in range(N):
            qk, okk = lma_grid.configurations(self.geom, poses, k, xy[k][None], self.branch)
            qk, inside = lma_grid.fit_joint_limits(qk, *robot_limits)
            q_arm[k], ok[k] = qk[0], okk[0] and (self.limits is None or inside[0])
        return q_arm, np.where(ok, puma_ik.manipulability(self.geom, q_arm), 0.0), ok

    def arm_rates(self, poses: lma_grid.ToolPoses, q_arm: Array, v_base: Array,
                  a_base: Array) -> tuple[Array, Array]:
        """Exact rates: the base velocity and acceleration given, the tool along the segment
        at constant orientation, the arm rates solve J dq = (v_tool - v_base, 0) in the arm
        frame (:func:`mmplan.robot.library.base_6dof_ik.joint_rates`)."""
        N = len(poses.s)
        c, s = np.cos(poses.heading), np.sin(poses.heading)
        Rz_T = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        v_tool = (poses.positions[-1] - poses.positions[0]) / (poses.s[-1] - poses.s[0])
        v_rel = (v_tool[None] - np.column_stack([v_base, np.zeros(N)])) @ Rz_T.T
        a_rel = -np.column_stack([a_base, np.zeros(N)]) @ Rz_T.T
        dq, ddq = puma_ik.joint_rates(self.geom, q_arm, v_rel, a_rel)
        return np.asarray(dq), np.asarray(ddq)


def _aligning(a: Array, b: Array) -> Array:
    """A rotation R (3, 3) with R a = b (unit vectors): about a x b (Rodrigues), or half a
    turn about an axis normal to a when b = -a."""
    v, c = np.cross(a, b), float(a @ b)
    if c < -1.0 + 1e-12:
        n = np.cross(a, [1.0, 0.0, 0.0])
        n = n if np.linalg.norm(n) > 1e-6 else np.cross(a, [0.0, 1.0, 0.0])
        n /= np.linalg.norm(n)
        return np.asarray(2.0 * np.outer(n, n) - np.eye(3))
    K = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.asarray(np.eye(3) + K + K @ K / (1.0 + c))


class NumericArm:
    """Any arm of >= 6 joints by numeric IK (module docstring).

    Args:
        robot: The robot (its arm coordinates are solved for; limits always respected).
        tool_axis: Axis of the end-effector body's frame that points into the surface.
        seeds: Random seeds per cell besides the continued one.
        iterations: IK iterations at most per solve.
    """

    def __init__(self, robot: Robot, tool_axis: tuple[float, float, float],
                 seeds: int = 4, iterations: int = 100) -> None:
        self.ik = ArmIK(robot, "axis", axis=tool_axis)
        self.seeds = seeds
        self.iterations = iterations

    def _targets(self, poses: lma_grid.ToolPoses, k: int) -> tuple[Array, Array]:
        """Tool position (3,) and a rotation whose tool axis is the poses' into-surface axis."""
        return poses.positions[k], _aligning(self.ik.axis, poses.rotation[:, 2])

    def _solve(self, poses: lma_grid.ToolPoses, k: int, xy: Array, previous: Array | None,
               best_w: bool, restart: bool = True) -> tuple[Array, BoolArray]:
        """Arm joints (N, n_arm) and convergence (N,) at bases ``xy`` (N, 2) for layer k:
        best w over random seeds, or continued from ``previous`` (``restart``: fresh seeds
        where the continuation fails)."""
        base = np.column_stack([xy, np.full(len(xy), poses.heading)])
        p, R = self._targets(poses, k)
        seeds = None if previous is None else previous[:, None, :]
        if best_w:
            res = self.ik.solve(base, p, R, seeds=seeds, random_seeds=self.seeds,
                                score=self.ik.manipulability, iterations=self.iterations)
            return res.q, res.ok
        assert previous is not None
        res = self.ik.solve(base, p, R, seeds=seeds, random_seeds=0,
                            iterations=self.iterations)
        redo = np.flatnonzero(~res.ok)  # lost the continued branch: start afresh there
        q, ok = res.q.copy(), res.ok.copy()
        if redo.size and restart:
            again = self.ik.solve(base[redo], p, R, random_seeds=self.seeds,
                                  score=self.ik.manipulability, iterations=self.iterations)
            q[redo], ok[redo] = again.q, again.ok
        return q, ok

    def layer_stack(self, grid: lma_grid.Grid, poses: lma_grid.ToolPoses) -> lma_grid.LayerStack:
        """w per cell and layer: the first layer's converged seed of largest w, continued
        to the next layers from the cell's previous solution (fresh seeds where that fails),
        as paths are verified. Cells behind the surface, or farther from every tool position
        than the arm reaches (:meth:`~mmplan.robot.numeric_ik.ArmIK.reach`), are unreachable
        without a solve."""
        cells = grid.cells()
        L = len(poses.s)
        w = np.zeros((L, *grid.shape))
        reachable = np.zeros((L, *grid.shape), dtype=bool)
        gap = np.linalg.norm(cells[:, None, :] - poses.positions[None, :, :2], axis=2)  # (C, L)
        idx = np.flatnonzero(poses.in_front(cells) & (gap.min(axis=1) <= self.ik.reach()))
        previous: Array | None = None
        for k in range(L):
            q, ok = self._solve(poses, k, cells[idx], previous, best_w=previous is None)
            previous = q
            wk = np.zeros(len(cells))
            wk[idx] = np.where(ok, self.ik.manipulability(q), 0.0)
            okk = np.zeros(len(cells), dtype=bool)
            okk[idx] = ok
            w[k], reachable[k] = wk.reshape(grid.shape), okk.reshape(grid.shape)
        return lma_grid.LayerStack(grid, poses, w, reachable)

    def _continued(self, poses: lma_grid.ToolPoses, layers: range,
                   xy: Array) -> tuple[Array, BoolArray]:
        """Arm joints (M, K, n_arm) and validity (M, K) along M paths, row by row: a row is
        invalid where the continuation does not converge or jumps by more than
        ``MAX_ROW_CHANGE`` (a change of branch is no continuous motion)."""
        M, K = xy.shape[:2]
        q = np.zeros((M, K, self.ik.n_arm))
        ok = np.zeros((M, K), dtype=bool)
        previous: Array | None = None
        for col, k in enumerate(layers):
            qk, okk = self._solve(poses, k, xy[:, col], previous, best_w=previous is None,
                                  restart=False)
            if previous is not None:
                okk &= np.abs(qk - previous).max(axis=1) <= MAX_ROW_CHANGE
            q[:, col], ok[:, col], previous = qk, okk, qk
        return q, ok

    def path_manipulability(self, poses: lma_grid.ToolPoses, layers: range, xy: Array) -> Array:
        """w along each path with the continued configurations; 0 where IK fails."""
        xy = np.asarray(xy, dtype=float)
        q, ok = self._continued(poses, layers, xy)
        w = self.ik.manipulability(q.reshape(-1, self.ik.n_arm)).reshape(ok.shape)
        return np.asarray(np.where(ok, w, 0.0))

    def along(self, robot: Robot, poses: lma_grid.ToolPoses,
              xy: Array) -> tuple[Array, Array, BoolArray]:
        """Continued configurations along one path (N, 2), their w, validity."""
        q, ok = self._continued(poses, range(len(poses.s)), np.asarray(xy, dtype=float)[None])
        w = np.where(ok[0], self.ik.manipulability(q[0]), 0.0)
        return q[0], w, ok[0]

    def arm_rates(self, poses: lma_grid.ToolPoses, q_arm: Array, v_base: Array,
                  a_base: Array) -> tuple[Array, Array]:
        """Central differences in s of the rows (second order; one-sided at the ends)."""
        dq = np.gradient(q_arm, poses.s, axis=0)
        return np.asarray(dq), np.asarray(np.gradient(dq, poses.s, axis=0))
