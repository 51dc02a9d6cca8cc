"""Robots from URDF: an arm described in URDF, mounted on one of mmplan's platform kinds.

The URDF is parsed with Pinocchio (``pin``, optional extra ``urdf``); its kinematic tree
(revolute, continuous and prismatic joints; fixed joints merged by Pinocchio) and its
inertias become an mmplan :class:`~mmplan.robot.tree.KinematicTree` mounted on the platform
at ``mount_xyz``/``mount_rpy``. The platform (differential drive, car, omnidirectional)
keeps its own Pfaffian constraints: a URDF cannot express rolling constraints, so wheels
are never faked with holonomic joints.

Collision points are placed along each link, from its joint to each child joint, at most
``collision_spacing`` apart, plus the platform's box when given.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mmplan.errors import InputError
from mmplan.robot.bases import PLATFORM, Platform
from mmplan.robot.collision import points_on_box, points_on_segment
from mmplan.robot.limits import Limits
from mmplan.robot.robot import CollisionSphere, EndEffector, Robot
from mmplan.robot.tree import Body, Inertial, Joint, JointKind

_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


def _pinocchio():  # type: ignore[no-untyped-def]
    try:
        import pinocchio
    except ImportError:  # pragma: no cover - depends on the installation
        raise InputError(
            "robot.urdf", "URDF support needs Pinocchio: pip install 'mmplan[urdf]'"
        ) from None
    return pinocchio


def _joint_kind_and_axis(model_joint: Any) -> tuple[JointKind, tuple[float, float, float]]:
    name = model_joint.shortname()
    for prefix, kind in (("JointModelR", JointKind.REVOLUTE), ("JointModelP", JointKind.PRISMATIC)):
        if name.startswith(prefix):
            suffix = name[len(prefix) :]
            if suffix in _AXES:
                return kind, _AXES[suffix]
            if suffix in ("evoluteUnaligned", "rismaticUnaligned"):
                concrete = model_joint.extract()
                axis = np.asarray(concrete.axis, dtype=float)
                return kind, (float(axis[0]), float(axis[1]), float(axis[2]))
            if suffix.startswith("UB"):
                raise InputError("robot.urdf", f"unbounded (continuous) joint {name} unsupported")
    raise InputError("robot.urdf", f"joint type {name} is not supported (revolute/prismatic only)")


def _xyz_rpy(placement: Any) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    pin = _pinocchio()
    t = np.asarray(placement.translation, dtype=float)
    rpy = pin.rpy.matrixToRpy(placement.rotation)
    return (float(t[0]), float(t[1]), float(t[2])), (float(rpy[0]), float(rpy[1]), float(rpy[2]))


def _vec(v: Any) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _inertial(inertia: Any) -> Inertial:
    """mmplan Inertial from a Pinocchio Inertia (mass, lever = com, inertia about the com)."""
    rows = tuple(_vec(row) for row in np.asarray(inertia.inertia, dtype=float))
    return Inertial(float(inertia.mass), _vec(inertia.lever), rows)


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
    pin = _pinocchio()
    text = str(urdf)
    try:
        if text.lstrip().startswith("<"):
            model = pin.buildModelFromXML(text)
        else:
            if not Path(text).is_file():
                raise InputError("robot.urdf", f"no such file: {text}")
            model = pin.buildModelFromUrdf(text)
    except (RuntimeError, ValueError) as exc:
        raise InputError("robot.urdf", f"cannot parse URDF: {exc}") from None
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
                _vec(mount_xyz),
                _vec(mount_rpy),
            )
        )
    coordinates: list[str] = []
    for jid in range(1, model.njoints):
        kind, axis = _joint_kind_and_axis(model.joints[jid])
        parent = body_of_joint[model.parents[jid]]
        placement = model.jointPlacements[jid]
        if model.parents[jid] == 0:
            mount = pin.SE3(
                pin.rpy.rpyToMatrix(np.asarray(mount_rpy, float)), np.asarray(mount_xyz, float)
            )
            placement = mount * placement
        xyz, rpy = _xyz_rpy(placement)
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
