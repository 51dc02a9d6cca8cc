"""Schema of a scenario's ``robot:`` entry: a built-in robot's name, or a URDF robot.

.. code-block:: yaml

    robot:
      urdf: robots/my_robot.urdf        # a file (relative to the scenario file's folder),
                                        # package://NAME/path, or the URDF text itself
      platform: {kind: differential-drive, wheels: [wheel_left_joint, wheel_right_joint],
                 wheel_radius: 0.0985, half_track: 0.2022}   # radius and track optional
      end_effector: arm_7_link          # frame whose origin (plus ee_offset) is controlled
      ee_offset: [0, 0, 0]              # optional, in the end_effector frame [m]
      locked: {head_1_joint: 0.0}       # optional: joints held at these values
      mount: {xyz: [0.2, 0, 0.4], rpy: [0, 0, 0]}   # only for an arm-only URDF on a platform
      srdf: robots/my_robot.srdf        # optional: its disable_collisions pairs are skipped
      collision: {tolerance: 0.05}      # sphere fit; null: no collision model
      name: my-robot                    # optional (default: the URDF's robot name)

What needs the file (joint and frame names, limits of locked values) is checked when the robot
is built (:mod:`mmplan.scenario.robot_entry`); here only types, ranges and unknown keys.
Defaults are not restated: a key left out is left to :func:`~mmplan.robot.urdf.load_urdf_robot`
and :class:`~mmplan.robot.urdf.CollisionOptions`.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from mmplan.scenario.schema_types import Finite, NonNegative, Positive, PositiveVec3, Strict, Vec3

#: The values of :class:`mmplan.robot.urdf.PlatformKind` (restated: importing the URDF package
#: loads SciPy; a test keeps the two equal).
PlatformKindName = Literal["differential-drive", "unicycle", "omnidirectional"]

#: A non-empty name (joint, frame, robot) or path.
Name = Annotated[str, Field(strict=True, min_length=1, max_length=100_000)]


class PlatformBoxModel(Strict):
    """Platform body of an arm-only URDF: a uniform box (edge lengths [m], mass [kg])."""

    size: PositiveVec3
    mass: Positive
    center: Vec3 | None = None


class PlatformModel(Strict):
    """Platform kind, its wheel joints (differential drive, left first) and wheel geometry."""

    kind: PlatformKindName
    wheels: list[Name] | None = None
    wheel_radius: Positive | None = None
    half_track: Positive | None = None
    box: PlatformBoxModel | None = None
    wheel_mass: Positive | None = None


class MountModel(Strict):
    """Pose of an arm-only URDF's root on the platform (platform frame on the ground)."""

    xyz: Vec3 | None = None
    rpy: Vec3 | None = None


class SphereModel(Strict):
    """A collision sphere given by hand: centre in its body's frame [m], radius [m]."""

    center: Vec3
    radius: NonNegative


#: Sphere-fit tolerance [m] and surface sampling [m]: bounded below so that a hostile file
#: cannot ask for millions of surface points.
FitTolerance = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=1e-3, le=1.0)]
FitSpacing = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=2e-3, le=1.0)]


class CollisionModel(Strict):
    """Sphere fit to the URDF's collision geometry; ``spheres`` replace a body's fitted ones."""

    tolerance: FitTolerance | None = None
    spacing: FitSpacing | None = None
    max_spheres_per_body: Annotated[int, Field(strict=True, ge=1, le=1000)] | None = None
    spheres: dict[Name, list[SphereModel]] | None = None


class UrdfRobotSpec(Strict):
    """A robot loaded from a URDF (:func:`~mmplan.robot.urdf.load_urdf_robot`)."""

    urdf: Name
    name: Name | None = None
    description: Annotated[str, Field(strict=True)] | None = None
    platform: PlatformModel
    end_effector: Name
    ee_offset: Vec3 | None = None
    mount: MountModel | None = None
    locked: dict[Name, Finite] | None = None
    srdf: Name | None = None
    package_dirs: list[Name] | None = None
    collision: CollisionModel | None = Field(default_factory=CollisionModel)


__all__ = ["CollisionModel", "MountModel", "PlatformBoxModel", "PlatformModel", "SphereModel",
           "UrdfRobotSpec"]
