"""Robot models: kinematic trees, platforms, dynamics and the built-in robots."""

from mmplan.robot.bases import (
    DifferentialDrive,
    KinematicCar,
    Omnidirectional,
    Platform,
    UnicycleDrive,
)
from mmplan.robot.library import get_robot, robot_names
from mmplan.robot.limits import Limits, RateLimits
from mmplan.robot.robot import CollisionSphere, EndEffector, Robot

__all__ = [
    "CollisionSphere",
    "DifferentialDrive",
    "EndEffector",
    "KinematicCar",
    "Limits",
    "Omnidirectional",
    "Platform",
    "RateLimits",
    "Robot",
    "UnicycleDrive",
    "get_robot",
    "robot_names",
]
