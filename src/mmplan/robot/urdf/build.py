"""Load a whole-robot URDF (or an arm-only URDF on a platform) as one mmplan robot.

q = (x, y, theta, wheel joints..., moving URDF joints in tree order); the planar pose places
the URDF root (or, for an arm-only URDF, the platform frame holding it at ``mount``) on the
ground z = 0. Joint limits, velocity limits, efforts and inertias come from the file.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mmplan.errors import InputError
from mmplan.robot.bases import PLATFORM
from mmplan.robot.limits import Limits, RateLimits
from mmplan.robot.robot import CollisionSphere, EndEffector
from mmplan.robot.tree import Body, Joint
from mmplan.robot.urdf import collision as col
from mmplan.robot.urdf.base import make_platform
from mmplan.robot.urdf.geometry import box_points
from mmplan.robot.urdf.parse import (
    inertial,
    is_xml,
    joint_kind_and_axis,
    joint_type,
    link_of_joint,
    load_collision_geometry,
    load_model,
    pinocchio,
    se3,
    vec3,
    xyz_rpy,
)
from mmplan.robot.urdf.record import record_arguments
from mmplan.robot.urdf.reduce import Reduction, reduce_model
from mmplan.robot.urdf.robot import UrdfRobot, UrdfSource
from mmplan.robot.urdf.spec import (
    CollisionOptions,
    Locked,
    Mount,
    PlatformBox,
    PlatformKind,
    PlatformSpec,
)

_RESERVED = {PLATFORM, "_slide_x", "_slide_y", "world", "wheel1", "wheel2", "steering"}


def _limit(value: float) -> float:
    """A URDF effort or velocity limit: 0 or non-finite means none."""
    return float(value) if np.isfinite(value) and value > 0 else np.inf


def _arm(reduction: Reduction, root: Any, wheels: set[str], key: str
         ) -> tuple[list[Body], list[Joint], dict[int, str]]:
    """Bodies and joints of the moving URDF joints other than the wheels."""
    model = reduction.model
    body_of_joint = {0: PLATFORM}
    bodies, joints = [], []
    for jid in range(1, model.njoints):
        name = str(model.names[jid])
        link = link_of_joint(model, jid)
        body_of_joint[jid] = f"urdf_{link}" if link in _RESERVED else link
        if name in wheels:
            continue
        kind, axis = joint_kind_and_axis(model.joints[jid], name, key)
        parent = int(model.parents[jid])
        placement = root * model.jointPlacements[jid] if parent == 0 else model.jointPlacements[jid]
        xyz, rpy = xyz_rpy(placement)
        bodies.append(Body(body_of_joint[jid], inertial(model.inertias[jid])))
        joints.append(Joint(name, kind, body_of_joint[parent], body_of_joint[jid], xyz, rpy, axis,
                            name))
    return bodies, joints, body_of_joint


def _limits(model: Any, coordinates: Sequence[str], actuated_wheels: Sequence[str],
            n_platform_actuators: int, label: str) -> Limits:
    lo, hi, effort = [], [], []
    velocity, sources = {}, {}
    for name in [*actuated_wheels, *coordinates]:
        jid = int(model.getJointId(name))
        i, v = int(model.idx_qs[jid]), int(model.idx_vs[jid])
        effort.append(_limit(model.effortLimit[v]))
        speed = _limit(model.velocityLimit[v])
        if np.isfinite(speed):
            velocity[name] = speed
            sources[f"velocity.{name}"] = f"URDF {label}: <limit velocity> of {name}"
        if name in coordinates:
            continuous = joint_type(model.joints[jid]) == "continuous"
            lo.append(-np.inf if continuous else float(model.lowerPositionLimit[i]))
            hi.append(np.inf if continuous else float(model.upperPositionLimit[i]))
    sources["*"] = (f"URDF {label}: <limit velocity> per joint; accelerations off (a URDF has "
                    "none); platform speed and yaw rate bounded through the wheel rates only")
    tau = np.r_[np.full(n_platform_actuators - len(actuated_wheels), np.inf), effort]
    return Limits(np.array(lo), np.array(hi), -tau, tau,
                  RateLimits(velocity=velocity, sources=sources))


def _reference(model: Any) -> np.ndarray:
    """Reduced-model config with every joint at zero or the limit nearest zero."""
    pin = pinocchio()
    q = np.asarray(pin.neutral(model), dtype=float).copy()
    for jid in range(1, model.njoints):
        if model.joints[jid].nq == 1:
            i = int(model.idx_qs[jid])
            q[i] = np.clip(0.0, model.lowerPositionLimit[i], model.upperPositionLimit[i])
    return q


def load_urdf_robot(
    urdf: str | Path,
    *,
    platform: Mapping[str, Any] | PlatformSpec,
    end_effector: str,
    locked: Mapping[str, float] | None = None,
    mount: Mapping[str, Any] | Mount | None = None,
    name: str | None = None,
    ee_offset: Sequence[float] = (0.0, 0.0, 0.0),
    package_dirs: Sequence[str | Path] | None = None,
    srdf: str | Path | None = None,
    collision: CollisionOptions | None = CollisionOptions(),  # noqa: B008 (frozen)
    description: str | None = None,
) -> UrdfRobot:
    """Load a whole-robot URDF (wheels in the file), or an arm-only URDF put on a platform.

    Args:
        urdf: Path to a URDF file, or the URDF text.
        platform: ``{kind, wheels, wheel_radius, half_track, box, wheel_mass}``
            (:class:`~mmplan.robot.urdf.spec.PlatformSpec`).
        end_effector: URDF frame (link or joint) holding the end-effector point.
        locked: Values of joints to hold [rad or m]; every joint off the chain to the end
            effector is held anyway (at zero, or the limit nearest zero).
        mount: Pose ``{xyz, rpy}`` of an arm-only URDF's root on the platform; marks the URDF
            as arm-only (the platform body is then ``platform.box``).
        name: Robot name (default: the URDF's robot name).
        ee_offset: End-effector point in the ``end_effector`` frame [m].
        package_dirs: Folders for ``package://`` meshes (default: every folder above the file).
        srdf: SRDF whose ``disable_collisions`` pairs are never checked for self-collision.
        collision: Sphere fitting options, or None for no collision model.
        description: One paragraph for ``mmplan robots``.

    Raises:
        InputError: one line naming the joint, frame or key and the problem.
    """
    spec = PlatformSpec.parse(platform)
    held = Locked.parse(locked)
    mounting = None if mount is None else Mount.parse(mount)
    arm_only = mounting is not None
    if spec.box is not None and not arm_only:
        raise InputError("robot.platform.box", "only for an arm-only URDF (with mount); a "
                         "whole robot's platform body comes from the URDF")
    if arm_only and spec.box is None:
        raise InputError("robot.platform.box", "missing: an arm-only URDF (with mount) needs "
                         "the platform body, box: {size, mass}")
    model = load_model(urdf)
    if arm_only:
        for i, wheel in enumerate(spec.wheels):
            if model.existJointName(wheel):
                raise InputError(f"robot.platform.wheels[{i}]", f"{wheel!r} is a URDF joint; an "
                                 "arm-only URDF's wheels are new coordinate names")
    geometry = None
    wheels_from_file = spec.kind is PlatformKind.DIFFERENTIAL_DRIVE and not arm_only
    if collision is not None or (wheels_from_file and spec.wheel_radius is None):
        geometry = load_collision_geometry(model, urdf, package_dirs, "robot.urdf")
    urdf_wheels = () if arm_only else spec.wheels
    reduction = reduce_model(model, geometry, end_effector=end_effector, wheels=urdf_wheels,
                             locked=held)
    rm = reduction.model
    root = se3(mounting.xyz, mounting.rpy) if mounting else pinocchio().SE3.Identity()
    derived: dict[str, tuple[float, str]] = {}
    base = make_platform(rm, reduction.geometry, spec, root, arm_only, derived)
    bodies, joints, body_of_joint = _arm(reduction, root, set(urdf_wheels), "robot.urdf")

    frame = rm.frames[rm.getFrameId(end_effector)]
    offset = frame.placement.act(np.asarray(ee_offset, dtype=float))
    label = "text" if is_xml(urdf) else Path(urdf).name
    coordinates = [j.coordinate for j in joints if j.coordinate is not None]
    limits = _limits(rm, coordinates, urdf_wheels, len(base.actuators), label)

    spheres: list[CollisionSphere] = []
    if reduction.geometry is not None and collision is not None:
        points, exact = col.body_surface(reduction.geometry, body_of_joint, root, collision.spacing)
        if spec.box is not None:
            points.setdefault(PLATFORM, []).append(_box_points(spec.box, collision.spacing))
        order = list(dict.fromkeys([PLATFORM, *body_of_joint.values()]))
        spheres = col.fit_body_spheres(order, points, exact, collision)
        spheres = col.replace_spheres(spheres, collision.spheres, order, "robot.collision.spheres")
    reference_pin = _reference(rm)
    transforms = col.reference_transforms(rm, reference_pin, body_of_joint, root)
    adjacent = {frozenset((body_of_joint[int(rm.parents[j])], body_of_joint[j]))
                for j in range(1, rm.njoints)}
    if srdf is not None:
        adjacent |= col.srdf_disabled_pairs(srdf, rm, body_of_joint, "robot.srdf")
    platform_bodies = [PLATFORM, *(body_of_joint[int(rm.getJointId(w))] for w in urdf_wheels)]
    pairs = col.self_collision_pairs(spheres, transforms, adjacent, platform_bodies)

    reference = np.zeros(len(base.coordinates) + len(coordinates))
    for k, c in enumerate(coordinates):
        jid = int(rm.getJointId(c))
        if rm.joints[jid].nq == 1:
            reference[len(base.coordinates) + k] = reference_pin[int(rm.idx_qs[jid])]
    robot_name = name or str(model.name) or "urdf-robot"
    arguments = record_arguments(
        urdf, spec, end_effector, held, mounting, robot_name, ee_offset, package_dirs, srdf,
        collision, description)
    source = UrdfSource(None if is_xml(urdf) else str(urdf), end_effector, reduction.chain,
                        reduction.wheels, reduction.held, reference, derived, arguments)
    text = description or (f"{model.name or 'URDF robot'} ({label}): {spec.kind.value} platform, "
                           f"{len(coordinates)} joints to {end_effector}")
    end = EndEffector(body_of_joint[int(frame.parentJoint)], vec3(offset))
    return UrdfRobot(robot_name, base, bodies, joints, end, limits, spheres, description=text,
                     self_collision=pairs, source=source)


def _box_points(box: PlatformBox, spacing: float) -> np.ndarray:
    return box_points(np.asarray(box.size) / 2, spacing) + np.asarray(box.box_center)
