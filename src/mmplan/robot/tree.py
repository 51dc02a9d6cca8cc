"""Symbolic kinematic tree: bodies connected by revolute, prismatic and fixed joints.

The tree is the single description of a robot's geometry and mass. Forward kinematics,
centres of mass and (in :mod:`mmplan.robot.dynamics`) the equations of motion are all
derived from it symbolically with CasADi, so nothing is typed in per robot.

Frames follow URDF: a joint's frame is placed in its parent body's frame by
``origin_xyz``/``origin_rpy``; the joint then rotates about (or slides along) ``axis``
given in the joint frame; the child body's frame is the moved joint frame.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum

import casadi as ca
import numpy as np

from mmplan.errors import ModelError
from mmplan.robot.spatial import homogeneous, rot_axis, rot_rpy, translation

WORLD = "world"


class JointKind(Enum):
    """Kinds of joints a tree can hold."""

    REVOLUTE = "revolute"
    PRISMATIC = "prismatic"
    FIXED = "fixed"


@dataclass(frozen=True)
class Inertial:
    """Mass properties of one rigid body.

    Attributes:
        mass: Mass [kg].
        com: Centre of mass in the body frame [m], (3,).
        inertia: Inertia tensor about the centre of mass in body axes [kg m^2], (3, 3).
    """

    mass: float
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: tuple[tuple[float, float, float], ...] = ((0.0,) * 3,) * 3

    def __post_init__(self) -> None:
        if not np.isfinite(self.mass) or self.mass < 0:
            raise ModelError(f"Inertial.mass must be finite and >= 0, got {self.mass}")
        inertia = np.asarray(self.inertia, dtype=float)
        if inertia.shape != (3, 3) or not np.allclose(inertia, inertia.T):
            raise ModelError(f"Inertial.inertia must be a symmetric 3x3 matrix, got {inertia}")

    @property
    def inertia_matrix(self) -> np.ndarray:
        """Inertia tensor as a (3, 3) array."""
        return np.asarray(self.inertia, dtype=float)

    @staticmethod
    def point(mass: float, com: Sequence[float] = (0.0, 0.0, 0.0)) -> Inertial:
        """Point mass at ``com``."""
        return Inertial(mass, _vec3(com))

    @staticmethod
    def box(mass: float, size: Sequence[float], com: Sequence[float] = (0, 0, 0)) -> Inertial:
        """Uniform solid box with edge lengths ``size`` (x, y, z) centred at ``com``."""
        a, b, c = (float(s) for s in size)
        diag = (
            mass * (b * b + c * c) / 12,
            mass * (a * a + c * c) / 12,
            mass * (a * a + b * b) / 12,
        )
        return Inertial(mass, _vec3(com), _diag(diag))

    @staticmethod
    def disc(mass: float, radius: float, axis: int, com: Sequence[float] = (0, 0, 0)) -> Inertial:
        """Thin uniform disc: m r^2/2 about its axle (body axis ``axis``), m r^2/4 across."""
        diag = [mass * radius**2 / 4] * 3
        diag[axis] = mass * radius**2 / 2
        return Inertial(mass, _vec3(com), _diag(tuple(diag)))

    @staticmethod
    def rod(mass: float, length: float, axis: int, com: Sequence[float]) -> Inertial:
        """Slender uniform rod along body axis ``axis`` with centre of mass ``com``."""
        diag = [mass * length**2 / 12] * 3
        diag[axis] = 0.0
        return Inertial(mass, _vec3(com), _diag(tuple(diag)))


def _vec3(v: Sequence[float]) -> tuple[float, float, float]:
    if len(v) != 3:
        raise ModelError(f"expected a 3-vector, got {v}")
    return (float(v[0]), float(v[1]), float(v[2]))


def _diag(d: Sequence[float]) -> tuple[tuple[float, float, float], ...]:
    return tuple(_vec3([float(d[i]) if i == j else 0.0 for j in range(3)]) for i in range(3))


@dataclass(frozen=True)
class Body:
    """A rigid body of the tree (massless bodies serve as frames)."""

    name: str
    inertial: Inertial = field(default_factory=lambda: Inertial(0.0))


@dataclass(frozen=True)
class Joint:
    """A joint connecting ``parent`` to ``child``.

    Attributes:
        name: Joint name.
        kind: Revolute, prismatic or fixed.
        parent: Parent body name (``"world"`` for the root).
        child: Child body name.
        origin_xyz: Joint frame position in the parent frame [m].
        origin_rpy: Joint frame orientation in the parent frame (URDF roll, pitch, yaw) [rad].
        axis: Unit axis in the joint frame (rotation or translation direction).
        coordinate: Name of the generalized coordinate that drives the joint (None if fixed).
    """

    name: str
    kind: JointKind
    parent: str
    child: str
    origin_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    origin_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    coordinate: str | None = None

    def __post_init__(self) -> None:
        if (self.kind is JointKind.FIXED) != (self.coordinate is None):
            raise ModelError(f"joint {self.name!r}: fixed joints have no coordinate, others one")
        norm = float(np.linalg.norm(self.axis))
        if abs(norm - 1.0) > 1e-9:
            raise ModelError(f"joint {self.name!r}: axis {self.axis} is not a unit vector")

    def transform(self, value: ca.SX | float) -> ca.SX:
        """Parent-frame-to-child-frame transform for the coordinate ``value``, (4, 4)."""
        placement = homogeneous(rot_rpy(self.origin_rpy), list(self.origin_xyz))
        if self.kind is JointKind.REVOLUTE:
            motion = homogeneous(rot_axis(self.axis, value), [0.0, 0.0, 0.0])
        elif self.kind is JointKind.PRISMATIC:
            motion = translation([a * value for a in self.axis])
        else:
            return placement
        return placement @ motion


class KinematicTree:
    """Bodies and joints forming a tree rooted at the world frame.

    Args:
        bodies: All bodies (names unique, not ``"world"``).
        joints: One joint per body, naming its parent; parents come before children.
    """

    def __init__(self, bodies: Sequence[Body], joints: Sequence[Joint]) -> None:
        names = [b.name for b in bodies]
        if len(set(names)) != len(names) or WORLD in names:
            raise ModelError(f"body names must be unique and not {WORLD!r}: {names}")
        self.bodies: dict[str, Body] = {b.name: b for b in bodies}
        self.joints: list[Joint] = list(joints)
        seen = {WORLD}
        for joint in self.joints:
            if joint.parent not in seen:
                raise ModelError(f"joint {joint.name!r}: parent {joint.parent!r} not defined yet")
            if joint.child not in self.bodies or joint.child in seen:
                raise ModelError(f"joint {joint.name!r}: child {joint.child!r} unknown or reused")
            seen.add(joint.child)
        if seen != set(self.bodies) | {WORLD}:
            raise ModelError(f"bodies without a joint: {sorted(set(self.bodies) - seen)}")
        coords = [j.coordinate for j in self.joints if j.coordinate is not None]
        if len(set(coords)) != len(coords):
            raise ModelError(f"each coordinate drives one joint: {coords}")
        self.coordinates: tuple[str, ...] = tuple(coords)

    def parent_joint(self, body: str) -> Joint:
        """The joint whose child is ``body``."""
        for joint in self.joints:
            if joint.child == body:
                return joint
        raise ModelError(f"unknown body {body!r}; bodies: {sorted(self.bodies)}")

    def world_transforms(self, q: Mapping[str, ca.SX]) -> dict[str, ca.SX]:
        """World transform T_world_body (4, 4) of every body, given coordinate values."""
        transforms: dict[str, ca.SX] = {WORLD: ca.SX.eye(4)}
        for joint in self.joints:
            value = q[joint.coordinate] if joint.coordinate is not None else 0.0
            transforms[joint.child] = transforms[joint.parent] @ joint.transform(value)
        del transforms[WORLD]
        return transforms

    def com_positions(self, transforms: Mapping[str, ca.SX]) -> dict[str, ca.SX]:
        """World position (3,) of the centre of mass of every body with mass."""
        out = {}
        for name, body in self.bodies.items():
            if body.inertial.mass > 0:
                T = transforms[name]
                out[name] = T[:3, :3] @ ca.DM(body.inertial.com) + T[:3, 3]
        return out

    @property
    def total_mass(self) -> float:
        """Sum of all body masses [kg]."""
        return sum(b.inertial.mass for b in self.bodies.values())
