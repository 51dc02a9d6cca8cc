"""The platform of a URDF robot: its body (the URDF root and all held to it) and its wheels.

Whole robot: a differential drive's wheels are the URDF's continuous wheel joints; the wheel
radius comes from the wheel link's collision cylinder (or sphere) and the track from the wheel
joints' origins (unless given). Arm-only URDF (with a ``mount``): the platform body is the given box
plus the URDF root's links, and a differential drive gets new wheel coordinates of the given
radius and track.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mmplan.errors import InputError
from mmplan.robot.bases import DifferentialDrive, Omnidirectional, Platform, UnicycleDrive
from mmplan.robot.tree import Inertial
from mmplan.robot.urdf.parse import (
    inertial,
    joint_kind_and_axis,
    link_of_joint,
    pinocchio,
    xyz_rpy,
)
from mmplan.robot.urdf.platforms import UrdfDifferentialDrive, UrdfWheel
from mmplan.robot.urdf.spec import PlatformKind, PlatformSpec

#: Wheel centres may sit this far from z = r above the ground [m] (URDF rounding).
WHEEL_HEIGHT_TOLERANCE = 1e-3
KEY = "robot.platform"


def platform_inertia(model: Any, spec: PlatformSpec, root: Any) -> Inertial:
    """Platform body: the URDF root's merged links at ``root`` (the mount), plus the box."""
    pin = pinocchio()
    total = root.act(model.inertias[0])
    if spec.box is not None:
        box = pin.Inertia.FromBox(spec.box.mass, *spec.box.size)
        total = total + pin.SE3(np.eye(3), np.asarray(spec.box.box_center)).act(box)
    return inertial(total)


def wheel_radius_from_geometry(geometry: Any, jid: int, axis: np.ndarray, name: str) -> float:
    """Radius of the wheel link's collision cylinder coaxial with the joint ``axis`` (joint
    frame), or of a collision sphere centred on the axis."""
    radii = []
    for obj in [] if geometry is None else geometry.geometryObjects:
        kind = type(obj.geometry).__name__
        if int(obj.parentJoint) != jid or kind not in ("Cylinder", "Sphere"):
            continue
        on_axis = np.linalg.norm(np.cross(np.asarray(obj.placement.translation), axis)) < 1e-9
        cyl_axis = np.asarray(obj.placement.rotation)[:, 2]
        coaxial = abs(abs(float(cyl_axis @ axis)) - 1) < 1e-6
        if on_axis and (kind == "Sphere" or coaxial):
            radii.append(float(obj.geometry.radius))
    if not radii:
        raise InputError(f"{KEY}.wheel_radius", f"missing: wheel joint {name!r} has no collision "
                         "cylinder (or sphere) on its axis to derive the radius from")
    return max(radii)


def _urdf_wheels(model: Any, geometry: Any, spec: PlatformSpec, root: Any, body: Inertial,
                 derived: dict[str, tuple[float, str]]) -> UrdfDifferentialDrive:
    wheels, centers, signs, radii = [], [], [], []
    for i, name in enumerate(spec.wheels):
        key = f"{KEY}.wheels[{i}]"
        jid = int(model.getJointId(name))
        placement = root * model.jointPlacements[jid]
        _, axis = joint_kind_and_axis(model.joints[jid], name, key)
        axis_p = np.asarray(placement.rotation) @ np.asarray(axis)
        if abs(abs(axis_p[1]) - 1) > 1e-6:
            raise InputError(key, f"wheel joint {name!r}: axis {np.round(axis_p, 6).tolist()} in "
                             "the root frame is not along y (a differential drive's axle)")
        signs.append(float(np.sign(axis_p[1])))
        centers.append(np.asarray(placement.translation, dtype=float))
        if spec.wheel_radius is None:
            radii.append(wheel_radius_from_geometry(geometry, jid, np.asarray(axis), name))
        xyz, rpy = xyz_rpy(placement)
        wheels.append(UrdfWheel(name, link_of_joint(model, jid), xyz, rpy, axis,
                                inertial(model.inertias[jid])))
    if spec.wheel_radius is not None:
        radius = spec.wheel_radius
        derived["wheel_radius"] = (radius, "given")
    else:
        if abs(radii[0] - radii[1]) > 1e-9:
            raise InputError(f"{KEY}.wheel_radius", f"missing: the wheels' collision cylinders "
                             f"differ ({radii[0]:g}, {radii[1]:g} m); give wheel_radius")
        radius = radii[0]
        derived["wheel_radius"] = (radius, f"collision cylinder or sphere of {wheels[0].link}")
    (a1, b1, z1), (a2, b2, z2) = centers
    if b1 <= b2:
        raise InputError(f"{KEY}.wheels", f"list the left wheel (+y) first: {spec.wheels[0]} is "
                         f"at y = {b1:g}, {spec.wheels[1]} at y = {b2:g}")
    if abs(a1 - a2) > 1e-6:
        raise InputError(f"{KEY}.wheels", f"the wheels are not on one axle (x = {a1:g}, {a2:g})")
    for name, z in zip(spec.wheels, (z1, z2), strict=True):
        if abs(z - radius) > WHEEL_HEIGHT_TOLERANCE:
            raise InputError(f"{KEY}.wheels", f"wheel {name!r} has its centre {z:g} m above the "
                             f"URDF root but radius {radius:g} m: the root frame must lie on "
                             "the ground (z = 0)")
    if spec.half_track is not None:
        lateral = (spec.half_track, -spec.half_track)
        derived["half_track"] = (spec.half_track, "given")
    else:
        lateral = (float(b1), float(b2))
        derived["half_track"] = (float(b1 - b2) / 2, "wheel joint origins")
    return UrdfDifferentialDrive(
        radius, lateral, float(a1), (signs[0], signs[1]), body, (wheels[0], wheels[1])
    )


def make_platform(
    model: Any,
    geometry: Any,
    spec: PlatformSpec,
    root: Any,
    arm_only: bool,
    derived: dict[str, tuple[float, str]],
) -> Platform:
    """The platform object (body inertia from the URDF root and the box)."""
    body = platform_inertia(model, spec, root)
    if body.mass <= 0:
        raise InputError(f"{KEY}.box", "missing: the platform has no mass (the URDF root "
                         "carries none); give box: {size, mass}")
    if spec.kind is PlatformKind.OMNIDIRECTIONAL:
        return Omnidirectional(body=body)
    if spec.kind is PlatformKind.UNICYCLE:
        return UnicycleDrive(body=body)
    if not arm_only:
        return _urdf_wheels(model, geometry, spec, root, body, derived)
    if spec.wheel_radius is None or spec.half_track is None:
        missing = "wheel_radius" if spec.wheel_radius is None else "half_track"
        raise InputError(f"{KEY}.{missing}", "missing: an arm-only URDF's differential drive "
                         "needs wheel_radius and half_track")
    derived["wheel_radius"] = (spec.wheel_radius, "given")
    derived["half_track"] = (spec.half_track, "given")
    r = spec.wheel_radius
    return DifferentialDrive(
        wheel_radius=r,
        half_track=spec.half_track,
        body=body,
        wheel=Inertial.disc(spec.wheel_mass, r, axis=1),
        names=("x", "y", "theta", spec.wheels[0], spec.wheels[1]),
    )

