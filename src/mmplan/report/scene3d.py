"""The 3D view of a plan as meshcat commands: the robot's bodies animated along the plan, the
obstacles in their true shapes, the paths, the goal and a ground grid with its scale.

Scene tree (meshcat paths; each can be hidden from the viewer's "Open Controls" panel):

* ``/robot/<body>``: one node per body with visual geometry (:func:`robot_looks`), posed in
  the world by an animation track per frame (position and quaternion from the robot's forward
  kinematics); its pieces below it, posed in the body frame; ``/robot/<body>/collision``:
  the body's collision model (points of radius 0 as a point cloud, spheres translucent),
  hidden at first;
* ``/obstacles/<n>``: obstacle n (1-based, scenario order) as a box, cylinder, sphere or
  superellipsoid mesh;
* ``/paths/end_effector``, ``/paths/platform``, ``/paths/reference``: tubes along the paths;
  ``/goal``: the goal point;
* ``/ground/grid``: grid lines on z = 0 (major lines every metre where the step is finer).

:func:`scene_commands` returns the packed commands and a small JSON document for the page
(time span, labels of the grid and the obstacles, camera, followed body).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.report.context import ReportContext, decimation
from mmplan.report.meshcat_commands import (
    ArrayTrack,
    Commands,
    IndexedMesh,
    path,
    quaternions_xyzw,
    rgb,
)
from mmplan.report.meshcat_commands import geometry as g
from mmplan.report.palette import GOAL_COLOR
from mmplan.report.scene3d_static import (
    draw_goal_and_paths,
    draw_grid,
    draw_obstacles,
    scene_bounds,
)
from mmplan.report.visual import COLLISION_COLOR, Visual, VisualKind
from mmplan.report.visuals import pose_from, robot_looks
from mmplan.robot import Robot
from mmplan.robot.bases import PLATFORM

MAX_FRAMES = 2000
FOV_DEG = 75.0  # meshcat's default camera
#: Playback length [s] of a plan whose t is a path parameter, not time (a segment task).
UNTIMED_PLAYBACK_S = 10.0


@dataclass
class Scene3D:
    """Packed meshcat commands and what the page script needs besides them.

    Attributes:
        commands: msgpack-encoded meshcat commands, in order.
        meta: JSON-ready: ``t0``, ``duration`` [s] of the playback, ``scale`` (playback
            seconds per unit of t: 1, or more for a path parameter), ``timed`` (t is time),
            ``frames``, ``bodies`` (scene paths),
            ``labels`` ([x, y, z, text, kind]), ``grid_step`` [m], ``follow`` (path of the body
            the camera can follow), ``camera`` (``target`` and ``offset`` [m]),
            ``robot_legend`` (how the robot is drawn, for the legend).
    """

    commands: list[bytes]
    meta: dict[str, Any] = field(default_factory=dict)


def body_transforms(robot: Robot, bodies: list[str], q: Array) -> Array:
    """World transforms T_world_body (K, B, 4, 4) of ``bodies`` at the configurations q (K, n),
    evaluated at all K samples in one CasADi call."""
    T = robot.symbols.transforms
    fn = ca.Function("body_transforms", [robot.symbols.q], [ca.horzcat(*[T[b] for b in bodies])])
    K = len(q)
    values = np.asarray(fn.map(K)(np.ascontiguousarray(q.T)), dtype=float)  # (4, K * 4 B)
    return values.reshape(4, K, len(bodies), 4).transpose(1, 2, 0, 3)


def _geometry(visual: Visual) -> tuple[Any, Array]:
    """meshcat geometry of a piece and the pose correcting three.js's conventions."""
    pose = np.asarray(visual.pose, dtype=float)
    if visual.kind is VisualKind.BOX:
        return g.Box(list(visual.size)), pose
    if visual.kind is VisualKind.SPHERE:
        return g.Sphere(visual.size[0]), pose
    if visual.kind is VisualKind.CYLINDER:
        y_to_z = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
        return g.Cylinder(visual.size[1], visual.size[0]), pose @ y_to_z  # three.js: along y
    scale = np.diag([*visual.size[:3], 1.0]) if len(visual.size) >= 3 else np.eye(4)
    if visual.vertices is not None and visual.faces is not None:
        return IndexedMesh(visual.vertices, visual.faces), pose @ scale
    return FileMesh(visual.mesh_data or "", visual.mesh_format), pose @ scale


class FileMesh(g.Geometry):
    """A mesh file's contents (stl, obj, dae) for meshcat's loaders (the URDF-mesh hook)."""

    def __init__(self, contents: bytes | str, mesh_format: str) -> None:
        super().__init__()
        self.contents = contents
        self.mesh_format = mesh_format

    def lower(self, object_data: Any) -> dict[str, Any]:
        import umsgpack

        data: Any = self.contents
        if isinstance(data, bytes):
            data = umsgpack.Ext(0x12, data)  # Uint8Array, as meshcat's StlMeshGeometry sends it
        return {"uuid": self.uuid, "type": "_meshfile_geometry", "format": self.mesh_format,
                "data": data}


def _draw_robot(cmds: Commands, robot: Robot, visuals: dict[str, tuple[Visual, ...]],
                first: Array, bodies: list[str]) -> None:
    for b, body in enumerate(bodies):
        node = path("robot", body)
        for piece in visuals.get(body, ()):
            geometry, pose = _geometry(piece)
            cmds.mesh(path("robot", body, piece.name), geometry, piece.color, piece.opacity, pose)
        points = np.array([s.center for s in robot.collision if s.body == body and s.radius == 0])
        spheres = [(i, s) for i, s in enumerate(robot.collision) if s.body == body and s.radius > 0]
        for i, sphere in spheres:
            cmds.mesh(path("robot", body, "collision", f"sphere_{i}"), g.Sphere(sphere.radius),
                      COLLISION_COLOR, 0.3, pose_from(sphere.center))
        if len(points):
            color = np.array(rgb(COLLISION_COLOR), dtype=np.float32) / 255
            colors = np.tile(color, (len(points), 1))
            cloud = g.PointCloud(points.T.astype(np.float32), colors.T, size=0.018)
            cmds.set_object(path("robot", body, "collision", "points"), cloud)
        if len(points) or spheres:
            cmds.set_property(path("robot", body, "collision"), "visible", False)
        cmds.set_transform(node, first[b])


def _animation(cmds: Commands, bodies: list[str], times: Array, T: Array) -> None:
    clips = {}
    for b, body in enumerate(bodies):
        clips[path("robot", body)] = [
            ArrayTrack("position", "vector3", times, T[:, b, :3, 3]),
            ArrayTrack("quaternion", "quaternion", times, quaternions_xyzw(T[:, b, :3, :3])),
        ]
    cmds.set_animation(clips)


def camera_views(ctx: ReportContext, lo: Array, hi: Array, robot_points: Array
                 ) -> dict[str, dict[str, list[float]]]:
    """Two camera placements, both from behind the start (against the end effector's overall
    direction of travel), 40 deg above the horizon: ``scene`` frames the box [lo, hi];
    ``robot`` looks at the robot (its points (P, 3) at the start, the platform's first) from
    2.1 robot sizes (at least 1 m).

    Returns:
        ``{"scene": {"target", "offset"}, "robot": {"target", "offset"}}`` [m]; the camera
        sits at target + offset.
    """
    center = 0.5 * (lo + hi)
    center[2] = 0.25 * (hi[2] - lo[2]) + lo[2]
    radius = 0.5 * float(np.linalg.norm(hi - lo))
    travel = ctx.plan.ee[-1, :2] - ctx.plan.ee[0, :2]
    heading = math.atan2(travel[1], travel[0]) if np.linalg.norm(travel) > 0.05 else 0.9
    azimuth = heading + math.pi - math.radians(30.0)
    elevation = math.radians(40.0)
    direction = np.array([math.cos(elevation) * math.cos(azimuth),
                          math.cos(elevation) * math.sin(azimuth), math.sin(elevation)])
    scene_distance = 1.05 * radius / math.tan(math.radians(FOV_DEG / 2))
    size = float(np.max(np.ptp(robot_points, axis=0)))
    robot_distance = max(2.1 * size, 1.0)
    robot_target = robot_points[0].copy()  # the first body: the platform (followed)
    robot_target[2] = 0.45 * float(robot_points[:, 2].max())

    def rounded(v: Array) -> list[float]:
        return [round(float(x), 4) for x in v]

    return {"scene": {"target": rounded(center), "offset": rounded(scene_distance * direction)},
            "robot": {"target": rounded(robot_target),
                      "offset": rounded(robot_distance * direction)}}


def prismatic_ranges(ctx: ReportContext) -> dict[str, tuple[float, float]]:
    """Range (lo, hi) each prismatic coordinate takes in the plan (rail lengths)."""
    robot = ctx.robot
    out = {}
    for joint in robot.tree.joints:
        if joint.coordinate is not None and joint.kind.value == "prismatic" \
                and joint.coordinate in robot.coordinates:
            values = ctx.plan.q[:, robot.index(joint.coordinate)]
            out[joint.coordinate] = (float(np.min(values)), float(np.max(values)))
    return out


def scene_commands(ctx: ReportContext, max_frames: int = 1000) -> Scene3D:
    """The 3D view of ``ctx``'s plan (see the module docstring).

    Args:
        ctx: Report context (robot with the scenario's limits, obstacles, plan).
        max_frames: Animation keyframes (the trajectory is decimated), 2..2000; three.js
            interpolates between them (linearly, quaternions by slerp).
    """
    if not 2 <= max_frames <= MAX_FRAMES:
        raise ValueError(f"max_frames must be in [2, {MAX_FRAMES}], got {max_frames}")
    robot, plan = ctx.robot, ctx.plan
    index = decimation(plan.samples, max_frames)
    looks = robot_looks(robot, prismatic_ranges(ctx))
    visuals = looks.bodies
    with_points = {s.body for s in robot.collision}
    bodies = [b for b in robot.tree.bodies if b in visuals or b in with_points]
    T = body_transforms(robot, bodies, plan.q[index])
    cmds = Commands()
    cmds.set_property(path("Grid"), "visible", False)  # meshcat's fixed 20 m grid: ours instead
    base = T[:, bodies.index(PLATFORM), :3, 3] if PLATFORM in bodies else None
    lo, hi = scene_bounds(ctx, base, T[:, :, :3, 3].reshape(-1, 3))
    step, labels = draw_grid(cmds, lo, hi)
    labels += draw_obstacles(cmds, ctx.obstacles)
    labels += draw_goal_and_paths(cmds, ctx, base, float(np.linalg.norm(hi - lo)))
    _draw_robot(cmds, robot, visuals, T[0], bodies)
    t0 = float(plan.t[index[0]])
    scale = 1.0 if ctx.timed else UNTIMED_PLAYBACK_S / max(float(plan.t[index[-1]] - t0), 1e-9)
    _animation(cmds, bodies, (plan.t[index] - t0) * scale, T)
    cmds.set_property(path("Background"), "visible", False)  # the page's own background
    meta = {
        "t0": t0,
        "duration": float(plan.t[index[-1]] - t0) * scale,
        "scale": scale,
        "timed": ctx.timed,
        "frames": len(index),
        "bodies": [f"robot/{b}" for b in bodies],
        "labels": labels,
        "grid_step": step,
        "follow": f"robot/{PLATFORM}" if PLATFORM in bodies else None,
        "camera": camera_views(ctx, lo, hi, np.vstack([T[0, :, :3, 3], ctx.plan.ee[:1]])),
        "goal_color": GOAL_COLOR,
        "robot_legend": looks.legend,
    }
    return Scene3D(cmds.packed, meta)
