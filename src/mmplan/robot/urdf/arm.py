"""An arm described in URDF, mounted on a hand-built platform object (arm-only URDFs).

The URDF is parsed with Pinocchio (``pin``, optional extra ``urdf``); its kinematic tree
(revolute and prismatic joints; fixed joints merged by Pinocchio) and its
inertias become an mmplan :class:`~mmplan.robot.tree.KinematicTree` mounted on the platform
at ``mount_xyz``/``mount_rpy``. The platform (differential drive, car, omnidirectional)
keeps its own Pfaffian constraints: a URDF cannot express rolling constraints, so wheels
are never faked with holonomic joints. A whole robot (wheels in the URDF) loads with
:func:`mmplan.robot.urdf.load_urdf_robot`.

Collision points are placed along each link, from its joint to each child joint, at most
``collision_spacing`` apart, plus the platform's box when given.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mmplan.errors import InputError
from mmplan.robot.bases import PLATFORM, Platform
from mmplan.robot.collision import points_on_box, points_on_segment
from mmplan.robot.limits import Limits
from mmplan.robot.robot import CollisionSphere, EndEffector, Robot
from mmplan.robot.tree import Body, Joint, JointKind
from mmplan.robot.urdf.parse import inertial as _inertial
from mmplan.robot.urdf.parse import joint_kind_and_axis, load_model, pinocchio, vec3, xyz_rpy


def robot_from_urdf(
    urdf: str | Path,
    platform: Platform,
    ee_link: str,
    *,
    name: str = "urdf-robot",
    ee_offset: Sequence[float] = (0.0, 0.0, 0.0),
    mount_xyz: Sequence[float] = (0.0, 0.0, 0.0),
    mount_rpy: Sequence[float] = (0.0, 0.0, 0.0),
    platform_box: tuple[Sequence[float], Sequence[float]] | None = None,
    collision_spacing: float = 0.14,
    torque_limits: tuple[Sequence[float], Sequence[float]] | None = None,
) -> Robot:
    """Build a :class:`Robot` from an arm URDF on ``platform``.

    Args:
        urdf: Path to a URDF file, or the URDF XML text itself.
        platform: Platform kind carrying the arm (its coordinates come first in q).
        ee_link: URDF link (or frame) holding the end-effector point.
        name: Robot name.
        ee_offset: End-effector point in ``ee_link``'s frame [m].
        mount_xyz, mount_rpy: Pose of the URDF root in the platform frame.
        platform_box: (centre, size) of the platform box for collision points, or None.
        collision_spacing: Maximum spacing of collision points along links [m].
        torque_limits: (min, max) for the platform actuators; arm effort limits come from
            the URDF (``effort``), unlimited where the URDF gives 0.

    Raises:
        InputError: unreadable URDF, unsupported joints, unknown ``ee_link``.
    """
    pin = pinocchio()
    model = load_model(urdf)
    if not model.existFrame(ee_link):
        links = [f.name for f in model.frames]
        raise InputError("robot.ee_link", f"unknown link {ee_link!r}; links: {links}")

    prefix = "arm_"
    body_of_joint = {0: PLATFORM}
    bodies: list[Body] = []
    joints: list[Joint] = []
    root = model.inertias[0]  # links fixed to the URDF root ride on the platform
    if root.mass > 0:
        bodies.append(Body(prefix + "root", _inertial(root)))
        joints.append(
            Joint(
                f"{prefix}root_joint",
                JointKind.FIXED,
                PLATFORM,
                prefix + "root",
                vec3(mount_xyz),
                vec3(mount_rpy),
            )
        )
    coordinates: list[str] = []
    for jid in range(1, model.njoints):
        if model.joints[jid].shortname().startswith("JointModelRUB"):
            raise InputError(
                "robot.urdf", f"joint {model.names[jid]!r} is continuous: give the whole robot "
                "to load_urdf_robot (wheels become platform coordinates)"
            )
        kind, axis = joint_kind_and_axis(model.joints[jid], model.names[jid], "robot.urdf")
        parent = body_of_joint[model.parents[jid]]
        placement = model.jointPlacements[jid]
        if model.parents[jid] == 0:
            mount = pin.SE3(
                pin.rpy.rpyToMatrix(np.asarray(mount_rpy, float)), np.asarray(mount_xyz, float)
            )
            placement = mount * placement
        xyz, rpy = xyz_rpy(placement)
        inertia = model.inertias[jid]
        inertial = _inertial(inertia)
        body = prefix + model.names[jid]
        coordinate = model.names[jid]
        bodies.append(Body(body, inertial))
        joints.append(Joint(f"{body}_joint", kind, parent, body, xyz, rpy, axis, coordinate))
        body_of_joint[jid] = body
        coordinates.append(coordinate)

    frame = model.frames[model.getFrameId(ee_link)]
    ee_body = body_of_joint[frame.parentJoint]
    ee_point = frame.placement.act(np.asarray(ee_offset, dtype=float))
    if frame.parentJoint == 0:
        raise InputError("robot.ee_link", f"{ee_link!r} is not moved by any arm joint")

    collision: list[CollisionSphere] = []
    if platform_box is not None:
        collision += points_on_box(PLATFORM, platform_box[0], platform_box[1], collision_spacing)
    for jid in range(1, model.njoints):
        children = [c for c in range(1, model.njoints) if model.parents[c] == jid]
        ends = [np.asarray(model.jointPlacements[c].translation) for c in children]
        if body_of_joint[jid] == ee_body:
            ends.append(ee_point)
        for end in ends:
            collision += points_on_segment(body_of_joint[jid], (0, 0, 0), end, collision_spacing)
    n_platform_act = len(platform.actuators)
    effort = np.asarray(model.effortLimit, dtype=float)
    arm_max = np.where(effort > 0, effort, np.inf)
    p_min, p_max = torque_limits or ([-np.inf] * n_platform_act, [np.inf] * n_platform_act)
    limits = Limits(
        joint_min=np.asarray(model.lowerPositionLimit, dtype=float),
        joint_max=np.asarray(model.upperPositionLimit, dtype=float),
        torque_min=np.r_[np.asarray(p_min, float), -arm_max],
        torque_max=np.r_[np.asarray(p_max, float), arm_max],
    )
    p = (float(ee_point[0]), float(ee_point[1]), float(ee_point[2]))
    return Robot(
        name,
        platform,
        bodies,
        joints,
        EndEffector(ee_body, p),
        limits,
        collision,
        description=f"{model.name or 'URDF arm'} on a {type(platform).__name__} platform",
    )
