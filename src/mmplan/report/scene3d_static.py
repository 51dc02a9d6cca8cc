"""The still parts of the 3D view: obstacles in their true shapes, paths, goal, ground grid.

Each function adds meshcat commands to a :class:`Commands` list and returns the text labels
the page draws over the view ([x, y, z, text, kind]).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from mmplan.arrays import Array
from mmplan.report.context import ObstacleView, ReportContext
from mmplan.report.meshcat_commands import Commands, path
from mmplan.report.meshcat_commands import geometry as g
from mmplan.report.palette import EE_COLOR, GOAL_COLOR, PLATFORM_PATH_COLOR, obstacle_color
from mmplan.report.shapes import superellipsoid_mesh, tube_mesh
from mmplan.report.visuals import pose_from
from mmplan.task import DrawSegment, ReachPoint, TrackPath

GRID_MINOR, GRID_MAJOR = (0.72, 0.75, 0.79), (0.45, 0.48, 0.53)

Label = list[Any]


def scene_bounds(ctx: ReportContext, base: Array | None, robot: Array) -> tuple[Array, Array]:
    """Box [lo, hi] (3,) holding the paths, the robot's bodies (``robot`` (P, 3), all frames),
    the obstacles, the goal and the ground (z = 0)."""
    points = [ctx.plan.ee, ctx.plan.q[:, :2] if base is None else base[:, :2], robot]
    for view in ctx.obstacles:
        model = view.obstacle.superellipsoid()
        c, a = np.asarray(model.center, dtype=float), float(np.max(model.semi_axes))
        points.append(np.array([c - a, c + a]))
    if isinstance(ctx.task, ReachPoint):
        points.append(np.asarray(ctx.task.position, dtype=float)[None, :])
    cloud = np.vstack([np.column_stack([p, np.zeros(len(p))]) if p.shape[1] == 2 else p
                       for p in points])
    cloud = cloud[np.all(np.isfinite(cloud), axis=1)]
    lo, hi = cloud.min(axis=0), cloud.max(axis=0)
    lo[2], hi[2] = min(lo[2], 0.0), max(hi[2], 0.3)
    margin = 0.25 + 0.05 * float(np.max(hi[:2] - lo[:2]))
    return lo - [margin, margin, 0.0], hi + [margin, margin, 0.0]


def grid_step(span: float) -> float:
    """A round grid step [m] (1, 2, 5 x 10^k) giving 6-15 lines across ``span``."""
    for step in (0.05, 0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0):
        if span / step <= 15:
            return step
    return 10.0 ** math.ceil(math.log10(span / 10))


def draw_grid(cmds: Commands, lo: Array, hi: Array) -> tuple[float, list[Label]]:
    """Grid lines on the ground over [lo, hi] (x, y); major lines every metre when the step is
    finer, labelled in metres along the near x and y edges. Returns the step and the labels."""
    step = grid_step(float(max(hi[0] - lo[0], hi[1] - lo[1])))
    xs = np.arange(math.floor(lo[0] / step), math.ceil(hi[0] / step) + 1) * step
    ys = np.arange(math.floor(lo[1] / step), math.ceil(hi[1] / step) + 1) * step
    major = max(step, 1.0)
    segments, colors = [], []
    for x in xs:
        segments += [[x, ys[0], 0.0], [x, ys[-1], 0.0]]
        colors += [GRID_MAJOR if _on(x, major) else GRID_MINOR] * 2
    for y in ys:
        segments += [[xs[0], y, 0.0], [xs[-1], y, 0.0]]
        colors += [GRID_MAJOR if _on(y, major) else GRID_MINOR] * 2
    position = np.array(segments, dtype=np.float32).T
    color = np.array(colors, dtype=np.float32).T
    lines = g.LineSegments(g.PointsGeometry(position, color),
                           g.LineBasicMaterial(vertexColors=True))
    cmds.set_object(path("ground", "grid"), lines)
    labels: list[Label] = []
    label_step = label_spacing(float(max(xs[-1] - xs[0], ys[-1] - ys[0])), step)
    for x in xs:
        if _on(x, label_step):
            labels.append([float(x), float(ys[0]), 0.0, f"x = {_metres(x)}", "grid"])
    for y in ys:
        if _on(y, label_step):
            labels.append([float(xs[0]), float(y), 0.0, f"y = {_metres(y)}", "grid"])
    return float(step), labels


def label_spacing(span: float, step: float) -> float:
    """Spacing [m] of the grid's labels: a multiple of the step (1, 2, 5 x 10^k) leaving at
    most 6 labels along ``span``."""
    for factor in (1, 2, 5, 10, 20, 50, 100):
        if span / (factor * step) <= 6:
            return factor * step
    return 100 * step


def _on(value: float, step: float) -> bool:
    return abs(value / step - round(value / step)) < 1e-6


def _metres(value: float) -> str:
    return f"{value:.10g} m" if abs(value) > 1e-9 else "0 m"


def obstacle_geometry(obstacle: Any) -> tuple[Any, Array]:
    """meshcat geometry and world pose of an obstacle in its true shape (its ``solid()``)."""
    solid = obstacle.solid()
    T = pose_from(solid.center)
    if solid.kind == "sphere":
        return g.Sphere(solid.size[0]), T
    if solid.kind == "box":
        c, s = math.cos(solid.yaw), math.sin(solid.yaw)
        T[:2, :2] = [[c, -s], [s, c]]
        return g.Box(list(solid.size)), T
    if solid.kind == "cylinder":
        T[:3, :3] = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]  # three.js: along y
        return g.Cylinder(solid.size[1], solid.size[0]), T
    vertices, faces = superellipsoid_mesh(obstacle.superellipsoid())
    return g.TriangularMeshGeometry(vertices, faces), np.eye(4)


def draw_obstacles(cmds: Commands, obstacles: tuple[ObstacleView, ...]) -> list[Label]:
    """Every obstacle as /obstacles/<n>, labelled "n shape" above its top."""
    labels: list[Label] = []
    for j, view in enumerate(obstacles):
        geometry, pose = obstacle_geometry(view.obstacle)
        cmds.mesh(path("obstacles", view.label.replace(" ", "_")), geometry, obstacle_color(j),
                  0.8, pose)
        model = view.obstacle.superellipsoid()
        top = np.asarray(model.center, dtype=float) + [0.0, 0.0, float(model.semi_axes[2])]
        labels.append([*(float(v) for v in top), f"obstacle {view.label}", "obstacle"])
    return labels


def _tube(cmds: Commands, name: str, points: Array, radius: float, color: str,
          opacity: float = 1.0) -> None:
    vertices, faces = tube_mesh(points, radius)
    cmds.mesh(path("paths", name), g.TriangularMeshGeometry(vertices, faces), color, opacity)


def draw_goal_and_paths(cmds: Commands, ctx: ReportContext, base: Array | None,
                        extent: float) -> list[Label]:
    """End-effector path, platform path on the ground, the task's reference and the goal."""
    radius = float(np.clip(0.0012 * extent, 0.003, 0.008))
    ee = ctx.plan.ee[ctx.index]
    _tube(cmds, "end_effector", ee, radius, EE_COLOR)
    if base is not None:
        ground = np.column_stack([base[:, :2], np.full(len(base), 0.004)])
        _tube(cmds, "platform", ground, radius, PLATFORM_PATH_COLOR)
    labels: list[Label] = [[*(float(v) for v in ee[0]), "start", "point"]]
    task = ctx.task
    if isinstance(task, ReachPoint):
        goal = np.asarray(task.position, dtype=float)
        size = max(2.5 * radius, float(task.tolerance))
        cmds.mesh(path("goal"), g.Sphere(size), GOAL_COLOR, 1.0, pose_from(goal))
        labels.append([*(float(v) for v in goal), "goal", "point"])
    elif isinstance(task, TrackPath | DrawSegment):
        if isinstance(task, TrackPath):
            t = np.linspace(0.0, float(task.duration), 200)
            reference = np.array([task.position(float(s)) for s in t])
        else:
            reference = np.array([task.point(float(s)) for s in np.linspace(0.0, 1.0, 50)])
        _tube(cmds, "reference", reference, 0.7 * radius, GOAL_COLOR, 0.8)
        labels.append([*(float(v) for v in reference[-1]), "end of the reference", "point"])
    return labels
