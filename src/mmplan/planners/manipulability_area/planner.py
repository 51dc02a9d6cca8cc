r"""Base path planning that keeps manipulability ([Nagatani]; see docs/manipulability_area.md).

Pipeline: tool poses along the segment (one per layer) -> manipulability distribution of
every layer over the grid of base positions ([Nagatani] eq. (1), vectorized; base-6dof by
its analytic IK, :mod:`mmplan.planners.manipulability_area.grid`, any other arm of >= 6
joints by numeric IK, :mod:`mmplan.planners.manipulability_area.arms`; a platform with wheel
constraints only along its heading) -> LMA with the threshold (default 0.5 x the
largest w of
the whole stack; [Nagatani] uses a fixed value, set ``threshold`` for that) -> shortest straight
base segment from the bottom to the top layer inside the LMA (section 4.1; round-robin over
start/end cells, :mod:`mmplan.planners.manipulability_area.path`). Among the shortest grid-feasible
segments
the one with the largest exact minimum w is kept; a segment whose exact w (IK at the
interpolated base positions, not at the cells) dips below the threshold is rejected.

When no straight segment exists (the paper leaves it open): a shortest path through the
voxelized LMA with at most ``max_step`` metres of base motion per layer, shortcut into few
straight pieces between sub-goals, each verified with the exact w.

Output: one trajectory row per layer (``substeps`` > 1: that many rows per layer interval,
the exact checks use the same samples), time t = layer parameter s in [0, 1] (dq, ddq are
exact derivatives with respect to s), q = (x, y, theta_B, q1..q6) with the arm joints by
exact IK at the base position of that row. Sub-goal corners are rounded by parabolic blends
over half a layer interval when the exact w stays above the threshold there (else kept).
``problem.start`` is not used (the base start is chosen by the planner). Joint limits are
ignored by default, as in [Nagatani] (its s.6 lists them as future work); the largest
violation is reported, ``respect_joint_limits`` removes such cells.
"""

from __future__ import annotations

import numpy as np

from mmplan.errors import InputError
from mmplan.planners.base import Planner, register
from mmplan.planners.manipulability_area import grid as lma_grid
from mmplan.planners.manipulability_area import path as lma_path
from mmplan.planners.manipulability_area.arms import Arm, NumericArm, PumaArm
from mmplan.planners.manipulability_area.result import assemble, failure
from mmplan.planners.manipulability_area.settings import ManipulabilityAreaSettings
from mmplan.problem import Problem, Progress
from mmplan.task import DrawSegment
from mmplan.trajectory import Solution


@register
class ManipulabilityArea(Planner[ManipulabilityAreaSettings, DrawSegment]):
    """[Nagatani]: straight (or sub-goal) base path inside the Layer of Manipulability Areas."""

    def _solve(
        self,
        problem: Problem,
        settings: ManipulabilityAreaSettings,
        task: DrawSegment,
        progress: Progress,
    ) -> Solution:
        """Plan the base path and the arm motion for a :class:`~mmplan.task.DrawSegment`."""
        if problem.scene.obstacles:
            raise InputError(
                "obstacles",
                f"{len(problem.scene.obstacles)} given, but the manipulability-area method "
                "has no obstacle model ([Nagatani]); remove the obstacles or choose another "
                "method",
            )
        arm = self._arm(problem, settings)
        grid = lma_grid.Grid.from_bounds(settings.x_range, settings.y_range, settings.resolution)
        poses = lma_grid.tool_poses(task, settings.layers, settings.heading)
        stack = arm.layer_stack(grid, poses)
        if progress is not None:
            progress(0.5)

        def fail(message: str) -> Solution:
            return failure(problem, message)

        unreachable = np.flatnonzero(~stack.reachable.any(axis=(1, 2)))
        if unreachable.size:
            k = int(unreachable[0])
            return fail(
                f"layer {k} (s={poses.s[k]:.3f}, tool at {np.round(poses.positions[k], 3)}"
                f"): no IK solution from any grid cell (tool pose unreachable)"
            )
        threshold = (
            settings.threshold
            if settings.threshold is not None
            else settings.threshold_ratio * float(stack.w.max())
        )
        masks = stack.areas(threshold)
        empty = np.flatnonzero(~masks.any(axis=(1, 2)))
        if empty.size:
            k = int(empty[0])
            return fail(
                f"layer {k} (s={poses.s[k]:.3f}): manipulability area empty (max w "
                f"{stack.w[k].max():.5g} < threshold {threshold:.5g} m^3)"
            )
        m = settings.substeps
        dense = lma_grid.tool_poses(task, (settings.layers - 1) * m + 1, settings.heading)

        def exact_min(xy: np.ndarray) -> np.ndarray:  # (M, L, 2) -> (M,), checked densely
            w = arm.path_manipulability(dense, range(len(dense.s)), lma_path.densify(xy, m))
            return np.asarray(w.min(axis=1))

        # A platform with wheel constraints (h > 0) moves only along its heading.
        along = None if problem.robot.h == 0 else poses.heading
        layer_xy, kind, checked = self._straight(masks, grid, settings.straight_groups,
                                                 threshold, exact_min, along)
        keep: list[int] = [0, settings.layers - 1]
        if layer_xy is None:
            if not settings.subgoals:
                return fail(f"no straight base segment inside the LMA ({checked} lengths "
                            "checked) and sub-goals are disabled")
            if along is not None:
                return fail(f"no straight base segment along the heading {poses.heading:.4g} "
                            f"rad inside the LMA ({checked} lengths checked); sub-goal paths "
                            "need an omnidirectional platform")
            step = max(1, int(np.floor(settings.max_step / settings.resolution + 1e-9)))
            cells, bad = lma_path.layered_shortest_path(masks, step)
            if cells is None:
                return fail(f"layer {bad} (s={poses.s[bad]:.3f}): no base path reaches it "
                            f"with moves <= {settings.max_step} m per layer inside the LMA")

            def accept(i: int, pts: np.ndarray) -> bool:
                xy = lma_path.densify(grid.to_metres(pts)[None], m)
                w = arm.path_manipulability(dense, range(i * m, i * m + xy.shape[1]), xy)
                return bool(w.min() >= threshold)

            keep = lma_path.shortcut(cells, accept)
            layer_xy = grid.to_metres(cells.astype(float))
            kind = "subgoals"
        return assemble(problem, stack, masks, threshold, dense, layer_xy[keep], keep, arm,
                        kind=kind, straight_groups=checked)

    @staticmethod
    def _arm(problem: Problem, settings: ManipulabilityAreaSettings) -> Arm:
        """base-6dof's closed-form PUMA, or numeric IK for any other arm of >= 6 joints."""
        robot = problem.robot
        if robot.name == "base-6dof":
            branch = lma_grid.Branch(
                1 if settings.shoulder == "right" else -1,
                1 if settings.elbow == "up" else -1,
                settings.wrist_flip,
            )
            limits = (
                (robot.limits.joint_min, robot.limits.joint_max)
                if settings.respect_joint_limits
                else None
            )
            return PumaArm(branch, limits)
        if len(robot.arm_indices) < 6:
            raise InputError(
                "robot",
                f"manipulability-area needs an arm of >= 6 joints (a tool pose); "
                f"{robot.name} has {len(robot.arm_indices)}",
            )
        if not settings.respect_joint_limits:
            raise InputError(
                "planner.respect_joint_limits",
                f"the numeric IK of {robot.name} always respects the joint limits; "
                "set it to true (false is only for base-6dof's closed form)",
            )
        return NumericArm(robot, settings.tool_axis, settings.ik_seeds)

    @staticmethod
    def _straight(
        masks: np.ndarray,
        grid: lma_grid.Grid,
        groups: int,
        threshold: float,
        exact_min: lma_path.ExactCheck,
        along: float | None = None,
    ) -> tuple[np.ndarray | None, str, int]:
        """Shortest straight segment passing the exact check: (base xy (L, 2) | None, kind, n);
        with ``along`` (a heading [rad]) only segments parallel to it (or of zero length)."""
        L = masks.shape[0]
        s = np.linspace(0.0, 1.0, L)[None, :, None]
        n = 0
        for n, group in enumerate(lma_path.straight_candidates(masks), start=1):
            if n > groups:
                return None, "none", groups
            a, b = grid.to_metres(group.starts)[:, None], grid.to_metres(group.ends)[:, None]
            if along is not None:
                d = (b - a)[:, 0]
                side = np.abs(d[:, 0] * np.sin(along) - d[:, 1] * np.cos(along))
                parallel = side <= 1e-9 * (1.0 + np.linalg.norm(d, axis=1))
                if not parallel.any():
                    continue
                a, b = a[parallel], b[parallel]
            paths = a + s * (b - a)  # (M, L, 2)
            wmin = exact_min(paths)
            best = int(np.argmax(wmin))
            if wmin[best] >= threshold:
                return paths[best], "straight", n
        return None, "none", n
