r"""Manipulability distribution over candidate base positions and its layers ([Nagatani] s.3).

For one tool pose the base-6dof arm (6 dof) has one configuration per base position (x, y)
once the IK branch and the base heading are fixed, so the manipulability
:math:`w = \sqrt{\det(J J^T)}` ([Nagatani] eq. (1)) is a function of (x, y): the manipulability
distribution (section 3.2, figure 3). Thresholding it gives the manipulability area MA
(section 3.3, figure 4); stacking the MAs of the poses along the task gives the LMA
(section 3.4, figure 5). Everything here is vectorized over the whole grid: one batched IK
call per layer.

Task poses (:func:`tool_poses`): the tool axis (flange z) points into the surface,
:math:`z_t = -n / |n|`; the roll about it does not change w (w does not depend on q6), we fix
the flange x axis along the component of world -z orthogonal to :math:`z_t` (world x when the
tool is vertical). The base heading is fixed by the task: the platform faces the surface,
:math:`\theta_B = \mathrm{atan2}(-n_y, -n_x)` (pi for the wall x = 0); since the first joint is
vertical and passes through the platform centre, w does not depend on the heading either,
only q1 does (and with it the joint-limit check).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mmplan.arrays import Array, BoolArray
from mmplan.errors import InputError
from mmplan.robot.library import base_6dof_ik as puma_ik
from mmplan.robot.library.base_6dof_ik import PumaGeometry
from mmplan.task import DrawSegment


@dataclass(frozen=True)
class Branch:
    """IK branch: shoulder +1/-1, elbow +1 (Corke "u") / -1, wrist flip."""

    shoulder: int = 1
    elbow: int = 1
    flip: bool = False


@dataclass(frozen=True)
class ToolPoses:
    """Tool poses along the task, one per layer.

    Attributes:
        s: Layer parameters in [0, 1], (L,).
        positions: Tool tip positions [m], (L, 3).
        rotation: Flange rotation in the world (3, 3) (the same at every layer).
        heading: Base heading theta_B [rad].
    """

    s: Array
    positions: Array
    rotation: Array
    heading: float

    def in_front(self, base_xy: Array) -> BoolArray:
        """Bases (N, 2) strictly in front of the surface (the side its normal points to); the
        base cannot stand inside the wall ([Nagatani] s.5.5), (N,)."""
        n = -self.rotation[:2, 2]  # horizontal part of the outward normal
        if np.linalg.norm(n) < 1e-12:
            return np.ones(len(base_xy), dtype=bool)
        return np.asarray((np.asarray(base_xy) - self.positions[0, :2]) @ n > 0.0)


@dataclass(frozen=True)
class Grid:
    """Candidate base positions: ``xs`` (nx,) x ``ys`` (ny,) [m], spacing ``resolution``."""

    xs: Array
    ys: Array
    resolution: float

    @classmethod
    def from_bounds(
        cls, x_range: tuple[float, float], y_range: tuple[float, float], resolution: float
    ) -> Grid:
        """Cells x_min + i * resolution up to x_max (inclusive within 1e-9), same for y."""
        axes = []
        for lo, hi in (x_range, y_range):
            n = int(np.floor((hi - lo) / resolution + 1e-9)) + 1
            axes.append(lo + resolution * np.arange(n, dtype=float))
        return cls(axes[0], axes[1], resolution)

    @property
    def shape(self) -> tuple[int, int]:
        """(nx, ny)."""
        return len(self.xs), len(self.ys)

    def cells(self) -> Array:
        """Every cell's (x, y), (nx * ny, 2), x-major (reshape to (nx, ny))."""
        X, Y = np.meshgrid(self.xs, self.ys, indexing="ij")
        return np.column_stack([X.ravel(), Y.ravel()])

    def to_metres(self, cells: NDArray[np.floating] | NDArray[np.integer]) -> Array:
        """Real cell coordinates (..., 2) -> positions [m] (..., 2)."""
        c = np.asarray(cells, dtype=float)
        return np.stack(
            [self.xs[0] + self.resolution * c[..., 0], self.ys[0] + self.resolution * c[..., 1]],
            axis=-1,
        )


def tool_poses(task: DrawSegment, layers: int, heading: float | None = None) -> ToolPoses:
    """Poses of the tool at ``layers`` equally spaced points of the segment (module docstring).

    Raises:
        InputError: the normal is zero, or vertical while no heading is given.
    """
    n = np.asarray(task.normal, dtype=float)
    if not np.all(np.isfinite(n)) or np.linalg.norm(n) < 1e-12:
        raise InputError("goal.segment.normal", f"must be a non-zero vector, got {task.normal}")
    z_t = -n / np.linalg.norm(n)
    if heading is None:
        if np.hypot(n[0], n[1]) < 1e-9:
            raise InputError(
                "goal.segment.normal",
                f"{task.normal} is vertical: the base "
                "heading cannot face the surface; set planner.heading",
            )
        heading = float(np.arctan2(0.0 - n[1], 0.0 - n[0]))
    down = np.array([0.0, 0.0, -1.0])
    x_t = down - (down @ z_t) * z_t
    if np.linalg.norm(x_t) < 1e-9:
        x_t = np.array([1.0, 0.0, 0.0])
    x_t /= np.linalg.norm(x_t)
    rotation = np.column_stack([x_t, np.cross(z_t, x_t), z_t])
    s = np.linspace(0.0, 1.0, layers)
    a, b = np.asarray(task.start, dtype=float), np.asarray(task.end, dtype=float)
    return ToolPoses(s, a[None] + s[:, None] * (b - a)[None], rotation, float(heading))


def fit_joint_limits(q: Array, lo: Array, hi: Array) -> tuple[Array, BoolArray]:
    """Shift each angle by +-2 pi into [lo, hi] where possible; (q, inside (N,))."""
    q = np.array(q, dtype=float)
    for shift in (2 * np.pi, -2 * np.pi):
        moved = q + shift
        use = ((q < lo) | (q > hi)) & (moved >= lo) & (moved <= hi)
        q[use] = moved[use]
    return q, np.all((q >= lo) & (q <= hi), axis=1)


def configurations(
    geom: PumaGeometry, poses: ToolPoses, layer: int, base_xy: Array, branch: Branch
) -> tuple[Array, BoolArray]:
    """Arm joints (N, 6) and reachable mask (N,) for bases at ``base_xy`` (N, 2), one layer."""
    p_arm, R_arm = puma_ik.base_to_arm(
        geom, base_xy, poses.heading, poses.positions[layer], poses.rotation
    )
    sol = puma_ik.inverse(geom, p_arm, R_arm, branch.shoulder, branch.elbow, branch.flip)
    return sol.q, sol.reachable


def manipulability_at(
    geom: PumaGeometry,
    poses: ToolPoses,
    layer: int,
    base_xy: Array,
    branch: Branch,
    limits: tuple[Array, Array] | None = None,
) -> Array:
    """Exact w at bases ``base_xy`` (N, 2) for one layer; 0 where unreachable (or off limits)."""
    if limits is None:
        p_arm, R_arm = puma_ik.base_to_arm(
            geom, base_xy, poses.heading, poses.positions[layer], poses.rotation
        )
        return puma_ik.pose_manipulability(geom, p_arm, R_arm, branch.shoulder, branch.elbow)[0]
    q, ok = configurations(geom, poses, layer, base_xy, branch)
    q, inside = fit_joint_limits(q, *limits)
    return np.where(ok & inside, puma_ik.manipulability(geom, q), 0.0)


def path_manipulability(
    geom: PumaGeometry,
    poses: ToolPoses,
    layers: range,
    base_xy: Array,
    branch: Branch,
    limits: tuple[Array, Array] | None = None,
) -> Array:
    """Exact w along many base paths: ``base_xy`` (M, len(layers), 2) -> (M, len(layers))."""
    xy = np.asarray(base_xy, dtype=float)
    out = np.empty(xy.shape[:2])
    for col, k in enumerate(layers):
        out[:, col] = manipulability_at(geom, poses, k, xy[:, col], branch, limits)
    return out


@dataclass(frozen=True)
class LayerStack:
    """Manipulability distributions of all layers on the grid.

    Attributes:
        grid: The candidate base positions.
        poses: Tool poses per layer.
        w: Manipulability per layer and cell (L, nx, ny) [m^3]; 0 where unreachable.
        reachable: IK exists (and within limits when they are respected) (L, nx, ny).
    """

    grid: Grid
    poses: ToolPoses
    w: Array
    reachable: BoolArray

    def areas(self, threshold: float) -> BoolArray:
        """LMA: MA_k = {w >= threshold} of every layer, (L, nx, ny)."""
        return np.asarray(self.reachable & (self.w >= threshold))


def layer_stack(
    geom: PumaGeometry,
    grid: Grid,
    poses: ToolPoses,
    branch: Branch,
    limits: tuple[Array, Array] | None = None,
) -> LayerStack:
    """Manipulability distribution of every layer over the whole grid (one IK call a layer).

    Cells behind the surface (:meth:`ToolPoses.in_front`) count as unreachable.
    """
    cells = grid.cells()
    front = poses.in_front(cells)
    L = len(poses.s)
    w = np.zeros((L, *grid.shape))
    reachable = np.zeros((L, *grid.shape), dtype=bool)
    for k in range(L):
        if limits is None:
            p_arm, R_arm = puma_ik.base_to_arm(
                geom, cells, poses.heading, poses.positions[k], poses.rotation
            )
            wk, ok = puma_ik.pose_manipulability(geom, p_arm, R_arm, branch.shoulder, branch.elbow)
        else:
            q, ok = configurations(geom, poses, k, cells, branch)
            q, inside = fit_joint_limits(q, *limits)
            ok &= inside
            wk = np.where(ok, puma_ik.manipulability(geom, q), 0.0)
        ok &= front
        reachable[k] = ok.reshape(grid.shape)
        wk = np.where(ok, wk, 0.0)
        w[k] = wk.reshape(grid.shape)
    return LayerStack(grid, poses, w, reachable)
