"""car-rtr: kinematic car with an RTR arm ([JaniakTchon], section III).

q = (x, y, phi, psi, x1, x2, x3); platform controls u = (u1, u2):
``dx = u1 cos phi cos psi, dy = u1 sin phi cos psi, dphi = u1 sin psi, dpsi = u2``
(car length 1). Arm: x1 rotation about the vertical at the platform point (x, y),
x2 vertical prismatic, x3 rotation raising the last link, so that
``y = (x + (l2 + l3 cos x3) cos(phi + x1), y + (l2 + l3 cos x3) sin(phi + x1), x2 + l3 sin x3)``.
l2 = l3 = 0.5 (not printed; our choice, docs/conventions.md). The paper has no masses or limits:
nominal masses (platform 10 kg box, links 1 kg rods and discs) serve only for dynamics, and joint
limits are wide (+-2 pi for rotations, [-5, 5] m for x2) so that bounds come from the scenario.
Velocity and acceleration limits: off (no data sheet; no real machine behind the model).
"""

from __future__ import annotations

import numpy as np

from mmplan.robot.bases import PLATFORM, KinematicCar
from mmplan.robot.collision import points_on_box, points_on_segment
from mmplan.robot.limits import Limits, RateLimits
from mmplan.robot.robot import EndEffector, Robot
from mmplan.robot.tree import Body, Inertial, Joint, JointKind

#: Source of the (absent) velocity and acceleration limits.
RATE_SOURCE = "no data sheet: off (a kinematic car of [JaniakTchon], no real machine behind it)"

LENGTH = 1.0
L2 = L3 = 0.5


def build() -> Robot:
    """Build car-rtr."""
    platform = KinematicCar(length=LENGTH, body=Inertial.box(10.0, (1.2, 0.6, 0.2), (0.5, 0, 0.3)))
    bodies = [
        Body("turret", Inertial.disc(1.0, 0.1, axis=2)),
        Body("slider", Inertial.rod(1.0, L2, axis=0, com=(L2 / 2, 0.0, 0.0))),
        Body("forearm", Inertial.rod(1.0, L3, axis=0, com=(L3 / 2, 0.0, 0.0))),
    ]
    joints = [
        Joint("x1_joint", JointKind.REVOLUTE, PLATFORM, "turret", axis=(0, 0, 1), coordinate="x1"),
        Joint("x2_joint", JointKind.PRISMATIC, "turret", "slider", axis=(0, 0, 1), coordinate="x2"),
        Joint(
            "x3_joint",
            JointKind.REVOLUTE,
            "slider",
            "forearm",
            origin_xyz=(L2, 0.0, 0.0),
            axis=(0, -1, 0),
            coordinate="x3",
        ),
    ]
    collision = [
        *points_on_box(PLATFORM, (0.5, 0.0, 0.3), (1.2, 0.6, 0.2), 0.3),
        *points_on_segment("forearm", (0, 0, 0), (L3, 0, 0), 0.14),
    ]
    two_pi = 2 * np.pi
    limits = Limits(
        joint_min=np.array([-two_pi, -5.0, -two_pi]),
        joint_max=np.array([two_pi, 5.0, two_pi]),
        torque_min=np.full(5, -np.inf),
        torque_max=np.full(5, np.inf),
        rates=RateLimits(sources={"*": RATE_SOURCE}),
    )
    return Robot(
        "car-rtr",
        platform,
        bodies,
        joints,
        EndEffector("forearm", (L3, 0.0, 0.0)),
        limits,
        collision,
        description="Kinematic car with an RTR arm, [JaniakTchon].",
    )
