"""UrdfRobot: a :class:`~mmplan.robot.robot.Robot` loaded from a URDF, with its provenance.

Besides the robot model it keeps what was read or derived from the file (wheel radius and
track, held joints, reference pose) and the self-collision pairs of its collision spheres.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from mmplan.arrays import Array
from mmplan.errors import ModelError
from mmplan.robot.robot import CollisionSphere, Robot
from mmplan.robot.self_collision import SelfCollision


@dataclass(frozen=True)
class UrdfSource:
    """What a URDF robot was built from.

    Attributes:
        urdf: Path of the URDF file (None when given as text).
        end_effector: End-effector frame.
        chain: URDF joints moving the end effector, root first (minus locked ones).
        wheels: URDF wheel joints (empty for an arm-only URDF or a platform without wheels).
        held: Value of every held joint by name [rad or m].
        reference: Reference configuration q (n,): platform at the origin, arm joints at zero
            or at the limit nearest zero. Self-collision pairs overlapping here are skipped.
        derived: Numbers derived from the file with where they come from, e.g.
            ``{"wheel_radius": (0.0985, "collision cylinder of wheel_left_link")}``.
        arguments: The :func:`~mmplan.robot.urdf.load_urdf_robot` call in the form of a
            scenario's ``robot: {urdf: ...}`` entry (paths absolute, plain lists and floats):
            loading it again builds the same robot (plan folders record it).
    """

    urdf: str | None
    end_effector: str
    chain: tuple[str, ...]
    wheels: tuple[str, ...]
    held: Mapping[str, float]
    reference: Array
    derived: Mapping[str, tuple[float, str]] = field(default_factory=dict)
    arguments: Mapping[str, Any] = field(default_factory=dict)


class UrdfRobot(Robot):
    """A robot loaded from a URDF (see :func:`mmplan.robot.urdf.load_urdf_robot`).

    Args:
        *args, **kwargs: As :class:`~mmplan.robot.robot.Robot`.
        self_collision: Sphere pairs to keep apart.
        source: Provenance and derived numbers.
    """

    def __init__(
        self, *args: Any, self_collision: SelfCollision, source: UrdfSource, **kwargs: Any
    ) -> None:
        super().__init__(*args, **kwargs)
        self.self_collision = self_collision
        self.source = source

    def self_collision_distances(self, q: Array) -> Array:
        """Signed distances (K,) of the self-collision sphere pairs at ``q`` [m]."""
        return self.self_collision.distances(self.collision_points(q), self.collision_radii)

    def with_collision(
        self, spheres: Sequence[CollisionSphere], self_collision: SelfCollision | None = None
    ) -> UrdfRobot:
        """A copy with other collision spheres (and pairs; none by default).

        The kinematics and dynamics are shared; functions of the collision points are rebuilt.
        The copy's ``source.arguments`` are empty (a plan folder cannot record it; give
        spheres by hand as ``CollisionOptions(spheres=...)`` to keep it recordable).
        """
        for sphere in spheres:
            if sphere.body not in self.tree.bodies:
                raise ModelError(f"{self.name}: unknown body {sphere.body!r}")
        other = copy.copy(self)
        other.collision = tuple(spheres)
        other.self_collision = self_collision or SelfCollision()
        # hand-placed spheres are not in the load arguments: the copy cannot be rebuilt from them
        other.source = dataclasses.replace(self.source, arguments={})
        other._shared = {}
        other.__dict__.pop("collision_radii", None)
        return other
