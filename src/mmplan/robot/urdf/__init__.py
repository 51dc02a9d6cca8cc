"""Robots from URDF (parsed by Pinocchio, optional extra ``urdf``).

* :func:`load_urdf_robot`: a whole robot as it is (TIAGo from example-robot-data): give the
  platform kind and its wheel joints, the end-effector frame and optionally locked joint
  values; or an arm-only URDF with a ``mount`` on a platform box. Only the chain to the end
  effector (and the wheels) moves; everything else is held and merged. Collision spheres are
  fitted to the URDF's collision geometry; self-collision pairs come with them.
* :func:`robot_from_urdf`: an arm-only URDF on a hand-built :class:`~mmplan.robot.bases.Platform`
  object, with collision points along the links.
"""

from mmplan.robot.urdf.arm import robot_from_urdf
from mmplan.robot.urdf.build import load_urdf_robot
from mmplan.robot.urdf.robot import UrdfRobot, UrdfSource
from mmplan.robot.urdf.spec import CollisionOptions, Mount, PlatformKind, PlatformSpec

__all__ = [
    "CollisionOptions",
    "Mount",
    "PlatformKind",
    "PlatformSpec",
    "UrdfRobot",
    "UrdfSource",
    "load_urdf_robot",
    "robot_from_urdf",
]
