"""What the figures of the trajectory draw, as plain arrays and names (no robot or scene model).

:func:`figure_data` takes everything model-dependent out of a :class:`ReportContext` (the links'
positions at a few instants, the platform path, the obstacles' outlines seen from above, units,
limits, the reference path). ``mmplan report`` computes it in the process that loads the robot
and scene models (CasADi, the scenario schema: a third of a second) while the drawing process
loads matplotlib, and the drawing process receives it pickled: it never loads the models.
Importing this module loads neither.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from mmplan.arrays import Array
from mmplan.report.plan_data import PlanData

if TYPE_CHECKING:  # the models: loaded only by figure_data()
    from mmplan.report.context import ReportContext

#: Instants at which the top view draws the robot's links.
SNAPSHOTS = 6


@dataclass(frozen=True)
class ObstacleOutline:
    """One obstacle seen from above.

    Attributes:
        label: e.g. ``"1 cylinder"`` (1-based, scenario order).
        influence: Neighbourhood size [m], or None.
        footprint: Outline in its true shape (k, 2), closed.
        neighbourhood: Outline of its superellipsoid model enlarged by the margin and the
            influence (k, 2), None without an influence.
    """

    label: str
    influence: float | None
    footprint: Array
    neighbourhood: Array | None


@dataclass(frozen=True)
class FigureData:
    """The plan and what the figures need of the robot, the scene and the task.

    Attributes:
        plan: The plan directory's data.
        index: Indices of the decimated samples (K,).
        timed: False when ``t`` is the segment parameter s in [0, 1] (a segment task).
        margin: Obstacle enlargement eps [m] (0 if not set).
        obstacles: The obstacles in scenario order.
        clearance: Distance of the robot to each obstacle at the decimated samples (K, n_obs).
        manipulability: mu(q) at the decimated samples (K,).
        manipulability_unit: ``m^3`` (position measure of an all-revolute arm) or ``-``.
        arm_coordinates: Names of the arm's coordinates.
        arm_indices: Their columns in ``plan.q``.
        joint_min, joint_max: Arm joint limits (n_arm,).
        actuators: The robot's actuators.
        torque_min, torque_max: Their effort limits (n_act,).
        effort_units: Unit of each of the plan's actuators (``plan.actuators``).
        task_error: Task error norm at every sample (N,) [m], None if the goal is unknown.
        task_kind: ``"reach"``, ``"path"`` or ``"segment"`` (or ``""``).
        tolerance: Goal tolerance [m].
        snapshots: Sample indices at which the links are drawn.
        links: For each snapshot, the segments (2, 3) between drawable body origins (and the
            tool).
        platform_path: Platform reference point (x, y) at the decimated samples (K, 2).
        reference_path: Desired end-effector positions at the decimated samples (K, 3), None
            for reach tasks.
        platform_groups: Platform coordinates in panels of one unit: (axis label, names).
        columns: Column in ``plan.q`` of each coordinate of ``platform_groups``.
    """

    plan: PlanData
    index: NDArray[np.intp]
    timed: bool
    margin: float
    obstacles: tuple[ObstacleOutline, ...]
    clearance: Array
    manipulability: Array
    manipulability_unit: str
    arm_coordinates: tuple[str, ...]
    arm_indices: tuple[int, ...]
    joint_min: Array
    joint_max: Array
    actuators: tuple[str, ...]
    torque_min: Array
    torque_max: Array
    effort_units: dict[str, str]
    task_error: Array | None
    task_kind: str
    tolerance: float
    snapshots: NDArray[np.intp]
    links: tuple[tuple[Array, ...], ...]
    platform_path: Array
    reference_path: Array | None
    platform_groups: list[tuple[str, list[str]]] = field(default_factory=list)
    columns: dict[str, int] = field(default_factory=dict)

    @property
    def t_dec(self) -> Array:
        """Times of the decimated samples (K,)."""
        return np.asarray(self.plan.t[self.index], dtype=float)

    @property
    def t_label(self) -> str:
        """Axis label of ``t``: ``t [s]``, or ``s [-]`` for the segment parameter."""
        return "t [s]" if self.timed else "segment parameter s [-]"


def figure_data(ctx: ReportContext) -> FigureData:
    """What the figures draw, derived from ``ctx`` (evaluates the robot's kinematics)."""
    from mmplan.report.overview import effort_unit
    from mmplan.report.shapes import footprint, top_outline

    robot, plan = ctx.robot, ctx.plan
    outlines = []
    for view in ctx.obstacles:
        ring = None
        if view.influence is not None:
            ring = top_outline(view.obstacle.enlarged(ctx.margin + view.influence).superellipsoid())
        outlines.append(ObstacleOutline(view.label, view.influence, footprint(view.obstacle),
                                        ring))
    snaps = np.unique(np.linspace(0, plan.samples - 1, SNAPSHOTS).round().astype(int))
    lim = robot.limits
    groups = platform_groups(ctx)
    return FigureData(
        plan=plan,
        index=ctx.index,
        timed=ctx.timed,
        margin=ctx.margin,
        obstacles=tuple(outlines),
        clearance=ctx.clearance,
        manipulability=ctx.manipulability,
        manipulability_unit=manipulability_unit(ctx),
        arm_coordinates=tuple(robot.arm_coordinates),
        arm_indices=tuple(robot.arm_indices),
        joint_min=np.asarray(lim.joint_min),
        joint_max=np.asarray(lim.joint_max),
        actuators=tuple(robot.actuators),
        torque_min=np.asarray(lim.torque_min),
        torque_max=np.asarray(lim.torque_max),
        effort_units={a: effort_unit(robot, a) for a in plan.actuators},
        task_error=ctx.task_error,
        task_kind=ctx.task_kind,
        tolerance=ctx.tolerance,
        snapshots=snaps,
        links=tuple(tuple(link_segments(ctx, plan.q[i])) for i in snaps),
        platform_path=platform_path(ctx),
        reference_path=reference_path(ctx),
        platform_groups=groups,
        columns={name: robot.index(name) for _, names in groups for name in names},
    )


def manipulability_unit(ctx: ReportContext) -> str:
    """m^3 for the position measure of an all-revolute arm (J_a: m/rad), else ``-`` (mixed)."""
    robot = ctx.robot
    revolute = all(j.kind.value == "revolute" for j in robot.tree.joints
                   if j.coordinate in robot.arm_coordinates)
    return "m^3" if revolute and robot.end_effector.manipulability == "position" else "-"


def link_segments(ctx: ReportContext, q: np.ndarray) -> list[np.ndarray]:
    """Segments (2, 3) between every drawable body origin and its parent, plus the tool."""
    robot = ctx.robot
    bodies = robot.body_positions(q)
    segments = []
    for joint in robot.tree.joints:
        if joint.parent in bodies and joint.child in bodies:
            segments.append(np.array([bodies[joint.parent], bodies[joint.child]]))
    ee_body = robot.end_effector.body
    if ee_body in bodies:
        segments.append(np.array([bodies[ee_body], robot.ee_position(q)]))
    return segments


def platform_path(ctx: ReportContext) -> np.ndarray:
    """Platform reference point (x, y) over the decimated samples (K, 2)."""
    robot = ctx.robot
    q_dec = ctx.plan.q[ctx.index.astype(int)]
    if "platform" in robot.tree.bodies:
        return np.array([robot.body_positions(q)["platform"][:2] for q in q_dec])
    return np.asarray(q_dec[:, :2], dtype=float)


def reference_path(ctx: ReportContext) -> np.ndarray | None:
    """Desired end-effector positions at the decimated samples (K, 3), None for reach tasks."""
    from mmplan.task import DrawSegment, TrackPath

    task = ctx.task
    t = ctx.t_dec
    if isinstance(task, TrackPath):
        return np.array([task.position(float(s)) for s in t])
    if isinstance(task, DrawSegment):
        return np.array([task.point(float(np.clip(s, 0.0, 1.0))) for s in t])
    return None


def platform_groups(ctx: ReportContext) -> list[tuple[str, list[str]]]:
    """Platform coordinates in panels of one unit: position [m], heading (and steering)
    [rad], wheel angles [rad]."""
    from mmplan.report.overview import coordinate_unit

    robot = ctx.robot
    names = list(robot.platform_coordinates)
    wheels = [j.coordinate for j in robot.tree.joints
              if j.coordinate in names and j.kind.value == "revolute" and abs(j.axis[2]) < 1e-9]
    position = [n for n in names[:2] if coordinate_unit(robot, n) == "m"]
    angles = [n for n in names if n not in position and n not in wheels]
    groups = [("position [m]", position), ("heading, steering [rad]", angles),
              ("wheel angle [rad]", [str(w) for w in wheels])]
    return [(label, members) for label, members in groups if members]
