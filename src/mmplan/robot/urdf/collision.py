"""Collision spheres of a URDF robot from its collision geometry, and its self-collision pairs.

Each body of the reduced model (the platform with everything held fixed to it, each wheel,
each moving link with what is held fixed to it: a hand on the last arm link, the head on the
torso) gathers the surface points of its collision primitives and meshes in its own frame;
:func:`~mmplan.robot.sphere_fit.fit_spheres` covers them with spheres (each primitive or mesh
is one convex piece of the body). Sphere primitives are
kept exactly. Self-collision pairs follow :func:`~mmplan.robot.self_collision.select_pairs`,
minus the pairs an SRDF's ``disable_collisions`` names, where one is given.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np

from mmplan.arrays import Array
from mmplan.robot.robot import CollisionSphere
from mmplan.robot.self_collision import SelfCollision, select_pairs
from mmplan.robot.sphere_fit import fit_spheres
from mmplan.robot.urdf.geometry import surface_points
from mmplan.robot.urdf.parse import pinocchio, vec3
from mmplan.robot.urdf.spec import CollisionOptions


def body_surface(
    geometry: Any, body_of_joint: Mapping[int, str], root: Any, spacing: float
) -> tuple[dict[str, list[Array]], dict[str, list[tuple[Array, float]]]]:
    """Surface points of each collision piece (k, 3) and exact spheres of every body, in the
    body's frame.

    Args:
        geometry: Reduced Pinocchio GeometryModel.
        body_of_joint: mmplan body of each reduced-model joint id (0: the platform).
        root: SE3 of the URDF root in the platform frame (the mount).
        spacing: Surface sampling [m].
    """
    points: dict[str, list[Array]] = {}
    spheres: dict[str, list[tuple[Array, float]]] = {}
    for obj in geometry.geometryObjects:
        jid = int(obj.parentJoint)
        body = body_of_joint[jid]
        placement = root * obj.placement if jid == 0 else obj.placement
        R, t = np.asarray(placement.rotation), np.asarray(placement.translation)
        pts, exact = surface_points(obj.geometry, spacing, str(obj.name))
        if pts.shape[0]:
            points.setdefault(body, []).append(pts @ R.T + t)
        spheres.setdefault(body, []).extend((R @ c + t, r) for c, r in exact)
    return points, spheres


def fit_body_spheres(
    bodies: Sequence[str],
    points: Mapping[str, Sequence[Array]],
    exact: Mapping[str, list[tuple[Array, float]]],
    options: CollisionOptions,
) -> list[CollisionSphere]:
    """Collision spheres of ``bodies`` (in that order) covering their points."""
    out = []
    for body in bodies:
        kept = exact.get(body, [])
        budget = max(1, options.max_spheres_per_body - len(kept))
        fitted = fit_spheres(points.get(body, []), options.tolerance, budget)
        for center, radius in [*fitted, *kept]:
            out.append(CollisionSphere(body, vec3(center), float(radius)))
    return out


def reference_transforms(
    model: Any, q: Array, body_of_joint: Mapping[int, str], root: Any
) -> dict[str, Array]:
    """Transform (4, 4) of every body in the platform frame at the reduced-model config q."""
    pin = pinocchio()
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    out = {body_of_joint[0]: np.eye(4)}
    for jid in range(1, model.njoints):
        out[body_of_joint[jid]] = np.asarray((root * data.oMi[jid]).homogeneous)
    return out


def self_collision_pairs(
    spheres: Sequence[CollisionSphere],
    transforms: Mapping[str, Array],
    adjacent: set[frozenset[str]],
    platform_bodies: Sequence[str],
) -> SelfCollision:
    """Pairs of non-adjacent bodies apart in the reference pose (``transforms``)."""
    if not spheres:
        return SelfCollision()
    bodies = [s.body for s in spheres]
    centers = np.array(
        [transforms[s.body][:3, :3] @ s.center + transforms[s.body][:3, 3] for s in spheres]
    )
    radii = np.array([s.radius for s in spheres])
    return select_pairs(bodies, centers, radii, adjacent, [set(platform_bodies)])


def srdf_disabled_pairs(
    srdf: str | Path, model: Any, body_of_joint: Mapping[int, str], key: str
) -> set[frozenset[str]]:
    """Body pairs an SRDF's ``<disable_collisions link1 link2>`` exempts (links not in the
    model are ignored: an SRDF often covers several variants of a robot)."""
    from mmplan.errors import InputError

    try:
        root = ElementTree.parse(srdf).getroot()
    except (OSError, ElementTree.ParseError) as exc:
        raise InputError(key, f"cannot read SRDF {srdf}: {exc}") from None
    pin = pinocchio()

    def body(link: str | None) -> str | None:
        if link is None or not model.existFrame(link, pin.FrameType.BODY):
            return None
        return body_of_joint[int(model.frames[model.getFrameId(link)].parentJoint)]

    out = set()
    for element in root.iter("disable_collisions"):
        a, b = body(element.get("link1")), body(element.get("link2"))
        if a is not None and b is not None and a != b:
            out.add(frozenset((a, b)))
    return out


def replace_spheres(
    spheres: Sequence[CollisionSphere],
    given: Mapping[str, Sequence[tuple[Sequence[float], float]]],
    bodies: Sequence[str],
    key: str,
) -> list[CollisionSphere]:
    """``spheres`` with those of each body named in ``given`` replaced by the given ones.

    Raises:
        InputError: a body that is not one of ``bodies``, a centre that is not 3 finite
            numbers, or a negative or non-finite radius.
    """
    from mmplan.errors import InputError

    for body, items in given.items():
        if body not in bodies:
            raise InputError(f"{key}.{body}", f"unknown body {body!r}; bodies: "
                             f"{', '.join(bodies)} (platform, wheel links, moving links)")
        for i, (center, radius) in enumerate(items):
            c = np.asarray(center, dtype=float)
            if c.shape != (3,) or not np.isfinite(c).all():
                raise InputError(f"{key}.{body}[{i}].center", f"expected 3 finite numbers "
                                 f"(x, y, z) in the body's frame, got {list(center)!r}")
            if not np.isfinite(radius) or radius < 0:
                raise InputError(f"{key}.{body}[{i}].radius", f"expected a radius >= 0 m, "
                                 f"got {radius!r}")
    out = [s for s in spheres if s.body not in given]
    for body, items in given.items():
        out += [CollisionSphere(body, vec3(np.asarray(c, dtype=float)), float(r))
                for c, r in items]
    order = {b: i for i, b in enumerate(bodies)}
    return sorted(out, key=lambda s: order[s.body])  # stable: body order, fitted order within
