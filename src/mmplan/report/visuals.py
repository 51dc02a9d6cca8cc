"""Visual geometry of a robot's bodies for the 3D view: what each body looks like.

:func:`body_visuals` is the one place that says how a robot is drawn: it returns, per body of
the kinematic tree, a tuple of :class:`Visual` pieces posed in that body's frame. The 3D view
(:mod:`mmplan.report.scene3d`) animates the body frames and never looks at geometry itself.

Built-in robots are drawn from their model, nothing typed in per robot:

* the platform as the box with the platform's inertia (a uniform box of edges a, b, c has
  I_xx = m (b^2 + c^2) / 12, ..., so a^2 = 6 (I_yy + I_zz - I_xx) / m), at its centre of mass;
* wheels (bodies with a disc's inertia, I_axle = 2 I_across) as cylinders of radius
  sqrt(2 I_axle / m) about the axle, with a light spoke so that their rotation shows; platforms
  without wheel bodies (car, unicycle) get wheels fixed to the platform (and, for a car, to the
  steering body) where the platform box leaves ground clearance;
* arm links as cylinders from each body's origin to its children's joint origins and to the
  end-effector point, a dark cylinder along each revolute axis, a sleeve and a rail for each
  prismatic joint, discs for disc-shaped arm bodies (a turret);
The collision model (points and spheres) is not part of the looks: the 3D view draws it
apart, hidden until asked for.

Robots loaded from a URDF (:class:`~mmplan.robot.urdf.UrdfRobot`) are drawn from the URDF's
own ``<visual>`` geometry instead (:mod:`mmplan.report.urdf_visuals`): link meshes as
triangles, boxes, cylinders and spheres, with the URDF's colours, each in the body that
carries its link (held links in place); an arm-only URDF's platform box and wheels are drawn
as above, and the tool point as a red dot. A :class:`Visual` of kind ``MESH`` carries either
vertices and faces or a mesh file's contents and format (``stl``, ``obj``, ``dae``), which
meshcat's viewer loads as they are.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeGuard

import numpy as np

from mmplan.arrays import Array
from mmplan.report.visual import (
    JOINT_COLOR,
    LINK_COLOR,
    PLATFORM_COLOR,
    SPOKE_COLOR,
    TOOL_COLOR,
    WHEEL_COLOR,
    Visual,
    VisualKind,
)
from mmplan.robot import KinematicCar, Robot, UnicycleDrive
from mmplan.robot.bases import PLATFORM
from mmplan.robot.tree import Inertial, Joint, JointKind

if TYPE_CHECKING:
    from mmplan.robot.urdf.robot import UrdfRobot

def pose_from(position: Array | tuple[float, ...], z_axis: Array | None = None) -> Array:
    """T (4, 4) at ``position`` whose z axis points along ``z_axis`` (identity rotation if None)."""
    T = np.eye(4)
    T[:3, 3] = np.asarray(position, dtype=float)
    if z_axis is not None:
        T[:3, :3] = rotation_z_to(np.asarray(z_axis, dtype=float))
    return T


def rotation_z_to(direction: Array) -> Array:
    """A rotation (3, 3) taking the z axis onto the unit vector along ``direction``."""
    z = direction / np.linalg.norm(direction)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def inertia_box(inertial: Inertial) -> Array | None:
    """Edge lengths (3,) of the uniform box with this inertia, None if it is no box."""
    m = inertial.mass
    moments = np.diag(inertial.inertia_matrix)
    if m <= 0 or not np.allclose(inertial.inertia_matrix, np.diag(moments)):
        return None
    squares = 6.0 * (moments.sum() - 2.0 * moments) / m  # a^2 = 6 (I_yy + I_zz - I_xx) / m, ...
    if np.any(squares <= 1e-8):
        return None
    return np.sqrt(squares)


def disc_axis(inertial: Inertial) -> tuple[int, float] | None:
    """(axle index, radius) when the inertia is a thin disc's (I_axle = 2 I_across), else None."""
    m = inertial.mass
    moments = np.diag(inertial.inertia_matrix)
    if m <= 0 or not np.allclose(inertial.inertia_matrix, np.diag(moments)):
        return None
    for axis in range(3):
        others = np.delete(moments, axis)
        if others[0] > 0 and np.allclose(others, others[0]) \
                and np.isclose(moments[axis], 2 * others[0]):
            return axis, float(np.sqrt(2.0 * moments[axis] / m))
    return None


def _wheel(name: str, center: Array, axle: Array, radius: float) -> tuple[Visual, ...]:
    """A tyre (cylinder about the axle) and a spoke across it."""
    width = max(0.02, 0.45 * radius)
    tyre = pose_from(center, axle)
    spoke = tyre.copy()
    return (
        Visual(name, VisualKind.CYLINDER, (radius, width), tyre, WHEEL_COLOR),
        Visual(f"{name}_spoke", VisualKind.BOX, (1.7 * radius, 0.22 * radius, 1.04 * width),
               spoke, SPOKE_COLOR),
    )


def platform_box(robot: Robot) -> tuple[Array, Array]:
    """Edge lengths (3,) and centre (3,) of the platform box in the platform frame."""
    body = robot.tree.bodies[PLATFORM].inertial
    size = inertia_box(body)
    if size is not None:
        return size, np.asarray(body.com, dtype=float)
    points = np.array([s.center for s in robot.collision if s.body == PLATFORM])
    if len(points) >= 2 and np.all(np.ptp(points, axis=0)[:2] > 1e-3):
        lo, hi = points.min(axis=0), points.max(axis=0)
        size = np.maximum(hi - lo, 0.05)
        return size, 0.5 * (lo + hi)
    return np.array([0.4, 0.3, 0.1]), np.array([0.0, 0.0, 0.1])


def _platform_visuals(robot: Robot, out: dict[str, list[Visual]],
                      box: tuple[Array, Array] | None = None) -> None:
    size, center = platform_box(robot) if box is None else box
    out[PLATFORM].append(Visual("body", VisualKind.BOX, tuple(size), pose_from(center),
                                PLATFORM_COLOR))
    clearance = float(center[2] - size[2] / 2)
    if clearance < 0.03:
        return
    radius = clearance
    side = size[1] / 2 + max(0.02, 0.45 * radius) / 2 + 0.005
    y_axis = np.array([0.0, 1.0, 0.0])
    if isinstance(robot.platform, UnicycleDrive | KinematicCar):
        for k, y in (("left", side), ("right", -side)):
            out[PLATFORM].extend(_wheel(f"wheel_{k}", np.array([0.0, y, radius]), y_axis, radius))
    if isinstance(robot.platform, KinematicCar):
        steering = robot.platform.coordinates[3]
        steer = next(j.child for j in robot.tree.joints if j.coordinate == steering)
        for k, y in (("left", side), ("right", -side)):
            out[steer].extend(_wheel(f"wheel_{k}", np.array([0.0, y, radius]), y_axis, radius))


def _child_joints(robot: Robot, body: str) -> list[Joint]:
    return [j for j in robot.tree.joints if j.parent == body]


def _is_wheel(robot: Robot, joint: Joint) -> bool:
    """A platform coordinate turning a body about a horizontal axle."""
    return (joint.parent == PLATFORM and joint.kind is JointKind.REVOLUTE
            and joint.coordinate in robot.platform_coordinates and abs(joint.axis[2]) < 1e-9)


def arm_bodies(robot: Robot) -> list[str]:
    """Bodies of the arm: those not moved by a platform coordinate (nor the platform's own)."""
    return [j.child for j in robot.tree.joints
            if j.child != PLATFORM and not j.child.startswith("_")
            and j.coordinate not in robot.platform_coordinates]


def link_radius(robot: Robot) -> float:
    """Radius [m] of the arm's link cylinders: 4 % of the arm's reach, within [1.5, 5] cm."""
    reach = sum(float(np.linalg.norm(j.origin_xyz)) for j in robot.tree.joints
                if j.coordinate in robot.arm_coordinates)
    reach += float(np.linalg.norm(robot.end_effector.offset))
    return float(np.clip(0.04 * reach, 0.015, 0.05))


def _arm_visuals(robot: Robot, ranges: Mapping[str, tuple[float, float]],
                 out: dict[str, list[Visual]]) -> None:
    r = link_radius(robot)
    arm = set(arm_bodies(robot))
    for joint in robot.tree.joints:
        body = joint.child
        if body not in arm:
            continue
        axis = np.asarray(joint.axis, dtype=float)
        if joint.kind is JointKind.REVOLUTE and joint.coordinate in robot.arm_coordinates:
            out[body].append(Visual("joint", VisualKind.CYLINDER, (1.35 * r, 3.2 * r),
                                    pose_from((0.0, 0.0, 0.0), axis), JOINT_COLOR))
        elif joint.kind is JointKind.PRISMATIC:
            lo, hi = ranges.get(joint.coordinate or "", (0.0, 0.5))
            lo, hi = min(lo, 0.0), max(hi, 0.0)
            mid = 0.5 * (lo + hi) * axis
            out[joint.parent].append(Visual(f"rail_{body}", VisualKind.CYLINDER,
                                            (0.8 * r, hi - lo + 2 * r), pose_from(mid, axis),
                                            JOINT_COLOR))
            out[body].append(Visual("sleeve", VisualKind.BOX, (3.0 * r, 3.0 * r, 3.0 * r),
                                    pose_from((0.0, 0.0, 0.0), axis), JOINT_COLOR))
        disc = disc_axis(robot.tree.bodies[body].inertial)
        if disc is not None:
            axle = np.eye(3)[disc[0]]
            out[body].append(Visual("disc", VisualKind.CYLINDER, (disc[1], 0.3 * disc[1]),
                                    pose_from((0.0, 0.0, 0.0), axle), LINK_COLOR))
        ends = [np.asarray(c.origin_xyz, dtype=float) for c in _child_joints(robot, body)]
        if robot.end_effector.body == body:
            tip = np.asarray(robot.end_effector.offset, dtype=float)
            ends.append(tip)
            out[body].append(Visual("tool", VisualKind.SPHERE, (1.1 * r,), pose_from(tip),
                                    TOOL_COLOR))
        for k, end in enumerate(ends):
            length = float(np.linalg.norm(end))
            if length > 1e-6:
                out[body].append(Visual(f"link_{k}", VisualKind.CYLINDER, (r, length),
                                        pose_from(end / 2, end), LINK_COLOR))


BUILTIN_LEGEND = ("Robot: platform (grey box), wheels, arm links (orange) with joint axes "
                  "(dark), tool (red dot).")


@dataclass(frozen=True)
class Looks:
    """How a robot is drawn.

    Attributes:
        bodies: Visual pieces per body (bodies without any are left out).
        legend: One or two sentences for the 3D view's legend saying what is drawn.
    """

    bodies: dict[str, tuple[Visual, ...]]
    legend: str = BUILTIN_LEGEND


def body_visuals(robot: Robot, ranges: Mapping[str, tuple[float, float]] | None = None
                 ) -> dict[str, tuple[Visual, ...]]:
    """Visual geometry per body (bodies without any are left out); see the module docstring.

    Args:
        robot: The robot.
        ranges: Range (lo, hi) [m] a prismatic coordinate takes in the plan, for the length
            of its rail (default [0, 0.5] m).
    """
    return robot_looks(robot, ranges).bodies


def robot_looks(robot: Robot, ranges: Mapping[str, tuple[float, float]] | None = None
                ) -> Looks:
    """:func:`body_visuals` with the legend saying how the robot is drawn."""
    note = ""
    if _is_urdf_robot(robot) and robot.source.urdf is not None:
        looks, note = _urdf_looks(robot)
        if looks is not None:
            return looks
    out: dict[str, list[Visual]] = {name: [] for name in robot.tree.bodies}
    _platform_visuals(robot, out)
    _wheel_bodies(robot, out)
    _arm_visuals(robot, ranges or {}, out)
    return Looks({name: tuple(v) for name, v in out.items() if v}, BUILTIN_LEGEND + note)


def _is_urdf_robot(robot: Robot) -> TypeGuard[UrdfRobot]:
    """``isinstance(robot, UrdfRobot)`` without importing the URDF package (SciPy, a third of
    a second) for a built-in robot: a URDF robot exists only once that module is loaded."""
    module = sys.modules.get("mmplan.robot.urdf.robot")
    return module is not None and isinstance(robot, module.UrdfRobot)


def _wheel_bodies(robot: Robot, out: dict[str, list[Visual]]) -> None:
    for joint in robot.tree.joints:
        disc = disc_axis(robot.tree.bodies[joint.child].inertial)
        if _is_wheel(robot, joint) and disc is not None and not out[joint.child]:
            out[joint.child].extend(_wheel("wheel", np.zeros(3), np.eye(3)[disc[0]], disc[1]))


def _urdf_looks(robot: UrdfRobot) -> tuple[Looks | None, str]:
    """The URDF's visuals, plus what the URDF lacks: an arm-only URDF's platform box (and its
    wheels) and the tool point; None when the URDF has no visual geometry that can be drawn.
    Also a note naming the mesh files that could not be read ("" when none)."""
    from mmplan.report.urdf_visuals import urdf_body_visuals
    from mmplan.robot.urdf.visuals import added_platform_body

    urdf = urdf_body_visuals(robot)
    note = ""
    if urdf.skipped:
        note = f" Not drawn (unreadable mesh files): {'; '.join(urdf.skipped[:5])}"
        note += f" and {len(urdf.skipped) - 5} more." if len(urdf.skipped) > 5 else "."
    if not urdf.bodies:
        return None, note
    out: dict[str, list[Visual]] = {name: [] for name in robot.tree.bodies}
    for body, pieces in urdf.bodies.items():
        out[body].extend(pieces)
    box = added_platform_body(robot)
    size = inertia_box(box) if box is not None else None
    if box is not None and size is not None:
        _platform_visuals(robot, out, (size, np.asarray(box.com, dtype=float)))
    _wheel_bodies(robot, out)
    tip = np.asarray(robot.end_effector.offset, dtype=float)
    out[robot.end_effector.body].append(Visual("tool", VisualKind.SPHERE, (0.012,),
                                               pose_from(tip), TOOL_COLOR))
    text = f"Robot: the visual geometry of its URDF ({urdf.triangles:,} triangles"
    if urdf.cell:
        text += f", meshes decimated by vertex clustering at {urdf.cell * 1000:g} mm"
    text += ")"
    if size is not None:
        text += " on its platform box (grey)"
    text += ", tool point (red dot)."
    return Looks({name: tuple(v) for name, v in out.items() if v}, text + note), note
