"""Reading URDF with Pinocchio: models, collision geometry, joints and inertias in mmplan terms.

Pinocchio (``pin``, optional extra ``urdf``) parses the file; this module turns its joint
models, placements and inertias into the pieces of an mmplan
:class:`~mmplan.robot.tree.KinematicTree`, and names what it cannot convert.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mmplan.errors import InputError
from mmplan.robot.tree import Inertial, JointKind

_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
Vec3 = tuple[float, float, float]


def pinocchio() -> Any:
    """The ``pinocchio`` module, or an InputError saying how to install it."""
    try:
        import pinocchio
    except ImportError:  # pragma: no cover - depends on the installation
        from mmplan.extras import install_command

        raise InputError(
            "robot.urdf", f"URDF support needs Pinocchio: {install_command('urdf')}"
        ) from None
    return pinocchio


def is_xml(urdf: str | Path) -> bool:
    """True when ``urdf`` is URDF text rather than a path."""
    return isinstance(urdf, str) and urdf.lstrip().startswith("<")


def load_model(urdf: str | Path, key: str = "robot.urdf") -> Any:
    """Pinocchio model of a URDF file or text (fixed joints merged, no root joint).

    Raises:
        InputError: no such file, or the URDF does not parse.
    """
    pin = pinocchio()
    try:
        if is_xml(urdf):
            return pin.buildModelFromXML(str(urdf))
        if not Path(urdf).is_file():
            raise InputError(key, f"no such file: {urdf}")
        return pin.buildModelFromUrdf(str(urdf))
    except (RuntimeError, ValueError) as exc:
        raise InputError(key, f"cannot parse URDF: {one_line(exc)}") from None


def load_collision_geometry(
    model: Any, urdf: str | Path, package_dirs: Sequence[str | Path] | None, key: str
) -> Any:
    """Pinocchio GeometryModel of the URDF's ``<collision>`` elements (meshes loaded).

    ``package://NAME/...`` mesh paths are resolved against ``package_dirs``; by default every
    folder above the URDF file (so the files of a package tree such as example-robot-data are
    found where they are installed).
    """
    pin = pinocchio()
    dirs = [str(d) for d in package_dirs] if package_dirs is not None else []
    if package_dirs is None and not is_xml(urdf):
        dirs = [str(p) for p in Path(urdf).resolve().parents]
    try:
        if is_xml(urdf):
            return pin.buildGeomFromUrdfString(
                model, str(urdf), pin.GeometryType.COLLISION, package_dirs=dirs
            )
        return pin.buildGeomFromUrdf(
            model, str(urdf), pin.GeometryType.COLLISION, package_dirs=dirs
        )
    except (RuntimeError, ValueError, OSError) as exc:
        raise InputError(key, f"cannot load the collision geometry: {one_line(exc)}") from None


def one_line(exc: BaseException) -> str:
    """An exception's message on one line."""
    return " ".join(str(exc).split())


def close_matches(name: str, choices: Iterable[str], what: str) -> str:
    """`` (close matches: a, b)`` or `` (known WHAT: ...)`` for an error message."""
    choices = list(choices)
    close = difflib.get_close_matches(name, choices, n=4, cutoff=0.5)
    if close:
        return f"; close matches: {', '.join(close)}"
    shown = ", ".join(choices[:12]) + (", ..." if len(choices) > 12 else "")
    return f"; {what}: {shown}"


def joint_type(model_joint: Any) -> str:
    """URDF-like type of a Pinocchio joint: revolute, continuous, prismatic or its short name."""
    name = model_joint.shortname()
    if name.startswith("JointModelRUB"):
        return "continuous"
    if name.startswith("JointModelR"):
        return "revolute"
    if name.startswith("JointModelP") and not name.startswith("JointModelPlanar"):
        return "prismatic"
    return name


def joint_kind_and_axis(model_joint: Any, joint_name: str, key: str) -> tuple[JointKind, Vec3]:
    """mmplan joint kind and unit axis (joint frame) of a revolute, continuous or prismatic joint.

    Continuous joints become revolute joints (their limits are infinite).

    Raises:
        InputError: another joint type (spherical, planar, floating, ...), naming the joint.
    """
    name = model_joint.shortname()
    for prefix, kind in (
        ("JointModelRUB", JointKind.REVOLUTE),
        ("JointModelR", JointKind.REVOLUTE),
        ("JointModelP", JointKind.PRISMATIC),
    ):
        if name.startswith(prefix):
            suffix = name[len(prefix) :]
            if suffix in _AXES:
                return kind, _AXES[suffix]
            if suffix in ("evoluteUnaligned", "rismaticUnaligned", "evoluteUnboundedUnaligned"):
                axis = np.asarray(model_joint.extract().axis, dtype=float)
                axis = axis / np.linalg.norm(axis)
                return kind, vec3(axis)
    raise InputError(
        key, f"joint {joint_name!r} has type {name}: only revolute, continuous and prismatic "
        "joints can move (lock it with locked: {joint: value}, or pick another end effector)"
    )


def vec3(v: Any) -> Vec3:
    """A 3-tuple of floats."""
    return (float(v[0]), float(v[1]), float(v[2]))


def xyz_rpy(placement: Any) -> tuple[Vec3, Vec3]:
    """URDF origin (xyz, rpy) of a Pinocchio SE3 placement."""
    pin = pinocchio()
    return vec3(placement.translation), vec3(pin.rpy.matrixToRpy(placement.rotation))


def se3(xyz: Sequence[float], rpy: Sequence[float]) -> Any:
    """Pinocchio SE3 from a URDF origin."""
    pin = pinocchio()
    return pin.SE3(pin.rpy.rpyToMatrix(np.asarray(rpy, float)), np.asarray(xyz, float))


def inertial(inertia: Any) -> Inertial:
    """mmplan Inertial from a Pinocchio Inertia (mass, lever = com, inertia about the com)."""
    rows = np.asarray(inertia.inertia, dtype=float)
    rows = (rows + rows.T) / 2  # exact symmetry (Pinocchio stores it packed, to rounding)
    return Inertial(float(inertia.mass), vec3(inertia.lever), tuple(vec3(r) for r in rows))


def link_of_joint(model: Any, jid: int) -> str:
    """Name of the URDF link a joint moves (the body frame placed at the joint frame)."""
    pin = pinocchio()
    candidates = [
        f for f in model.frames if f.type == pin.FrameType.BODY and f.parentJoint == jid
    ]
    for frame in candidates:
        if frame.placement.isIdentity():
            return str(frame.name)
    return str(candidates[0].name) if candidates else str(model.names[jid])
