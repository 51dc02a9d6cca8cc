"""The ``<visual>`` elements of a URDF robot, each posed in the body of the robot's tree that
carries it.

A :class:`~mmplan.robot.urdf.UrdfRobot` moves only the chain to the end effector and the
wheels; every other joint is held and merged into its parent body by Pinocchio's reduced
model (:mod:`mmplan.robot.urdf.reduce`). The same reduction is rebuilt here from the robot's
:class:`~mmplan.robot.urdf.UrdfSource` (without collision geometry), and each URDF link's
frame in it gives where that link's visuals sit in the body that carries it: a head held at
its value rides on the torso, casters on the platform, the hand on the last arm link.

Nothing is loaded here but the URDF's XML and its kinematics: mesh files are only located
(``package://NAME/...`` against package folders, ``file://`` and relative paths against the
URDF's folder); reading them is the caller's business (the report's
:mod:`mmplan.report.meshes`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np

from mmplan.arrays import Array
from mmplan.robot.bases import PLATFORM
from mmplan.robot.tree import Inertial
from mmplan.robot.urdf.parse import inertial, load_model, pinocchio, se3
from mmplan.robot.urdf.reduce import reduce_model
from mmplan.robot.urdf.robot import UrdfRobot
from mmplan.robot.urdf.spec import Locked

RGBA = tuple[float, float, float, float]


@dataclass(frozen=True)
class VisualElement:
    """One ``<visual>`` of a URDF link, in the frame of the tree body carrying it.

    Attributes:
        link: The URDF link it belongs to.
        kind: ``mesh``, ``box``, ``cylinder`` or ``sphere``.
        size: box: edges (x, y, z) [m]; cylinder: (radius, length) [m] along z, centred;
            sphere: (radius,) [m]; mesh: the scale (x, y, z).
        pose: T_body_visual (4, 4): the link's frame in the body times the visual's origin.
        mesh: The mesh file (may be missing on disk), None for a primitive.
        rgba: The colour of its URDF material, None where it has none (or only a texture).
        filename: The mesh filename as the URDF writes it ("" for a primitive).
    """

    link: str
    kind: str
    size: tuple[float, ...]
    pose: Array
    mesh: Path | None = None
    rgba: RGBA | None = None
    filename: str = ""


def _floats(text: str | None, default: Sequence[float]) -> tuple[float, ...]:
    if text is None:
        return tuple(default)
    return tuple(float(v) for v in text.split())


def _rgba(material: ElementTree.Element | None, named: dict[str, RGBA]) -> RGBA | None:
    if material is None:
        return None
    color = material.find("color")
    if color is not None and color.get("rgba"):
        r, g, b, a = (_floats(color.get("rgba"), (0, 0, 0, 1)) + (1.0,))[:4]
        return (r, g, b, a)
    return named.get(material.get("name", ""))


def mesh_path(filename: str, urdf: Path, package_dirs: Sequence[Path]) -> Path:
    """Where a URDF mesh filename points: ``package://NAME/rest`` is the first
    ``DIR/NAME/rest`` that exists among ``package_dirs`` (else the first candidate),
    ``file://`` an absolute path, anything else a path relative to the URDF's folder."""
    if filename.startswith("package://"):
        rest = filename[len("package://"):]
        candidates = [Path(d) / rest for d in package_dirs]
        return next((c for c in candidates if c.is_file()),
                    candidates[0] if candidates else Path(rest))
    if filename.startswith("file://"):
        return Path(filename[len("file://"):])
    path = Path(filename)
    return path if path.is_absolute() else urdf.parent / path


def _reduced_model(robot: UrdfRobot) -> Any:
    """The robot's reduced Pinocchio model, rebuilt from its source (no geometry)."""
    source = robot.source
    assert source.urdf is not None
    model = load_model(source.urdf)
    reduction = reduce_model(model, None, end_effector=source.end_effector,
                             wheels=source.wheels, locked=Locked(dict(source.held)))
    return reduction.model


def _root(robot: UrdfRobot, model: Any) -> Any:
    """The URDF root's placement in the platform frame (the mount of an arm-only URDF)."""
    tree_joints = {j.name: j for j in robot.tree.joints}
    for jid in range(1, model.njoints):
        name = str(model.names[jid])
        if int(model.parents[jid]) == 0 and name in tree_joints:
            joint = tree_joints[name]
            return se3(joint.origin_xyz, joint.origin_rpy) * model.jointPlacements[jid].inverse()
    return pinocchio().SE3.Identity()


def visual_elements(robot: UrdfRobot, package_dirs: Sequence[str | Path] | None = None
                    ) -> dict[str, list[VisualElement]]:
    """The URDF's visuals by tree body (``platform``, wheel and arm bodies), in URDF order.

    Links that are not in the kinematics (none, for a URDF Pinocchio parsed) and geometry
    kinds other than mesh, box, cylinder and sphere are left out. A robot given as URDF text
    (``robot.source.urdf`` None) has none.

    Args:
        robot: A robot from :func:`~mmplan.robot.urdf.load_urdf_robot`.
        package_dirs: Folders for ``package://`` meshes (default: those the robot was loaded
            with, else every folder above the URDF file, as the loader's default).
    """
    if robot.source.urdf is None:
        return {}
    pin = pinocchio()
    urdf = Path(robot.source.urdf)
    given = package_dirs if package_dirs is not None \
        else robot.source.arguments.get("package_dirs")
    dirs = [Path(d) for d in given] if given is not None else list(urdf.resolve().parents)
    model = _reduced_model(robot)
    root = _root(robot, model)
    body_of = {j.name: j.child for j in robot.tree.joints}
    xml = ElementTree.parse(urdf).getroot()
    named = {}
    for material in xml.findall("material"):
        rgba = _rgba(material, {})
        if rgba is not None:
            named[material.get("name", "")] = rgba
    out: dict[str, list[VisualElement]] = {}
    for link in xml.findall("link"):
        name = link.get("name", "")
        if not model.existFrame(name, pin.FrameType.BODY):
            continue
        frame = model.frames[model.getFrameId(name, pin.FrameType.BODY)]
        jid = int(frame.parentJoint)
        body = PLATFORM if jid == 0 else body_of.get(str(model.names[jid]))
        if body is None:
            continue
        link_in_body = (root * frame.placement) if jid == 0 else frame.placement
        for visual in link.findall("visual"):
            element = _element(visual, name, link_in_body, named, urdf, dirs)
            if element is not None:
                out.setdefault(body, []).append(element)
    return out


def _element(visual: ElementTree.Element, link: str, link_in_body: Any,
             named: dict[str, RGBA], urdf: Path, dirs: Sequence[Path]) -> VisualElement | None:
    geometry = visual.find("geometry")
    shape = geometry[0] if geometry is not None and len(geometry) else None
    if shape is None:
        return None
    origin = visual.find("origin")
    xyz = _floats(origin.get("xyz") if origin is not None else None, (0, 0, 0))
    rpy = _floats(origin.get("rpy") if origin is not None else None, (0, 0, 0))
    pose = np.asarray((link_in_body * se3(xyz, rpy)).homogeneous, dtype=float)
    rgba = _rgba(visual.find("material"), named)
    if shape.tag == "mesh":
        filename = shape.get("filename", "")
        scale = _floats(shape.get("scale"), (1, 1, 1))
        scale = scale * 3 if len(scale) == 1 else scale
        return VisualElement(link, "mesh", scale[:3], pose, mesh_path(filename, urdf, dirs),
                             rgba, filename)
    if shape.tag == "box":
        return VisualElement(link, "box", _floats(shape.get("size"), (0, 0, 0))[:3], pose,
                             rgba=rgba)
    if shape.tag == "cylinder":
        size = (float(shape.get("radius", 0)), float(shape.get("length", 0)))
        return VisualElement(link, "cylinder", size, pose, rgba=rgba)
    if shape.tag == "sphere":
        return VisualElement(link, "sphere", (float(shape.get("radius", 0)),), pose, rgba=rgba)
    return None


def added_platform_body(robot: UrdfRobot) -> Inertial | None:
    """What the platform body holds besides the URDF's own links: the box given for an
    arm-only URDF (its inertia about its centre, centre in the platform frame), None for a
    whole robot, whose platform body is the URDF root with everything held to it."""
    if robot.source.urdf is None:
        return None
    pin = pinocchio()
    model = _reduced_model(robot)
    own = _root(robot, model).act(model.inertias[0])
    body = robot.tree.bodies[PLATFORM].inertial
    total = pin.Inertia(body.mass, np.asarray(body.com, dtype=float), body.inertia_matrix)
    if total.mass - own.mass < 1e-9:
        return None
    return inertial(total - own)
