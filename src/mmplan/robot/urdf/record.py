"""The arguments of a URDF robot in the form of a scenario's ``robot: {urdf: ...}`` entry.

:func:`record_arguments` turns the validated arguments of
:func:`~mmplan.robot.urdf.load_urdf_robot` back into plain YAML data (lists, floats, absolute
paths) kept on the robot (:attr:`~mmplan.robot.urdf.UrdfSource.arguments`), so that a robot
built in Python can be written with a plan and rebuilt by ``mmplan check``. Only what was given
is recorded (a derived wheel radius is derived again), except the effective collision options.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from mmplan.robot.urdf.parse import is_xml
from mmplan.robot.urdf.spec import CollisionOptions, Locked, Mount, PlatformKind, PlatformSpec


def _path(value: str | Path) -> str:
    return str(value) if is_xml(value) else str(Path(value).resolve())


def _floats(values: Sequence[float]) -> list[float]:
    return [float(v) for v in values]


def platform_dict(spec: PlatformSpec) -> dict[str, Any]:
    """``{kind, wheels, wheel_radius, half_track, box, wheel_mass}``, given keys only."""
    out: dict[str, Any] = {"kind": spec.kind.value}
    if spec.wheels:
        out["wheels"] = list(spec.wheels)
    if spec.wheel_radius is not None:
        out["wheel_radius"] = float(spec.wheel_radius)
    if spec.half_track is not None:
        out["half_track"] = float(spec.half_track)
    if spec.box is not None:
        box: dict[str, Any] = {"size": _floats(spec.box.size), "mass": float(spec.box.mass)}
        if spec.box.center is not None:
            box["center"] = _floats(spec.box.center)
        out["box"] = box
        if spec.kind is PlatformKind.DIFFERENTIAL_DRIVE:
            out["wheel_mass"] = float(spec.wheel_mass)
    return out


def collision_dict(options: CollisionOptions) -> dict[str, Any]:
    """``{tolerance, spacing, max_spheres_per_body, spheres}`` (spheres only when given)."""
    out: dict[str, Any] = {"tolerance": float(options.tolerance),
                           "spacing": float(options.spacing),
                           "max_spheres_per_body": int(options.max_spheres_per_body)}
    if options.spheres:
        out["spheres"] = {body: [{"center": _floats(c), "radius": float(r)} for c, r in spheres]
                          for body, spheres in options.spheres.items()}
    return out


def record_arguments(
    urdf: str | Path,
    platform: PlatformSpec,
    end_effector: str,
    locked: Locked,
    mount: Mount | None,
    name: str,
    ee_offset: Sequence[float],
    package_dirs: Sequence[str | Path] | None,
    srdf: str | Path | None,
    collision: CollisionOptions | None,
    description: str | None,
) -> dict[str, Any]:
    """The scenario form of one :func:`~mmplan.robot.urdf.load_urdf_robot` call.

    ``collision: None`` records a robot without a collision model.
    """
    out: dict[str, Any] = {"urdf": _path(urdf), "name": name,
                           "platform": platform_dict(platform), "end_effector": end_effector}
    offset = _floats(ee_offset)
    if any(offset):
        out["ee_offset"] = offset
    if mount is not None:
        out["mount"] = {"xyz": _floats(mount.xyz), "rpy": _floats(mount.rpy)}
    if locked.values:
        out["locked"] = {k: float(v) for k, v in locked.values.items()}
    if srdf is not None:
        out["srdf"] = _path(srdf)
    if package_dirs is not None:
        out["package_dirs"] = [_path(d) for d in package_dirs]
    out["collision"] = None if collision is None else collision_dict(collision)
    if description is not None:
        out["description"] = description
    return out
