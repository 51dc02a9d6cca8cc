"""diffdrive-3dof: (2,0) platform without wheel coordinates and a 3-dof arm.

From [AbdessemedDjebrani] section 2. q = (x, y, phi, theta1, theta2, theta3); its eq. (2):
``x_e = x + cos(theta1 + phi)(l2 cos theta2 + l3 cos(theta2 + theta3))``,
``y_e = y + sin(theta1 + phi)(...)``, ``z_e = l1 - l2 sin theta2 - l3 sin(theta2 + theta3)``
with l1 = 0.6, l2 = 0.4, l3 = 0.3 (section 2 prints no numbers; we reuse section 3's).
Collision model (our reading, docs/tracking.md): the platform as two discs of radius 0.2 m, at A and
0.3 m ahead; arm links as points. Masses are nominal ([AbdessemedDjebrani] is kinematic).
Arm limits (not printed): theta1 +-pi, theta2 [-pi/2, pi/2], theta3 [-2.5, 2.5] rad.
Velocity and acceleration limits: off (no data sheet; no real machine named).
"""

from __future__ import annotations

import numpy as np

from mmplan.robot.bases import PLATFORM, UnicycleDrive
from mmplan.robot.collision import points_on_segment
from mmplan.robot.limits import Limits, RateLimits
from mmplan.robot.robot import CollisionSphere, EndEffector, Robot
from mmplan.robot.tree import Body, Inertial, Joint, JointKind

#: Source of the (absent) velocity and acceleration limits.
RATE_SOURCE = (
    "no data sheet: off ([AbdessemedDjebrani]'s robot is kinematic, no real machine named)"
)

L1, L2, L3 = 0.6, 0.4, 0.3
DISC_RADIUS = 0.2
DISC_AHEAD = 0.3


def build() -> Robot:
    """Build diffdrive-3dof."""
    platform = UnicycleDrive(
        body=Inertial.box(20.0, (0.7, 0.4, 0.2), (0.15, 0.0, 0.2)), names=("x", "y", "phi")
    )
    bodies = [
        Body("link1", Inertial.rod(2.0, L1, axis=2, com=(0.0, 0.0, L1 / 2))),
        Body("link2", Inertial.rod(1.5, L2, axis=0, com=(L2 / 2, 0.0, 0.0))),
        Body("link3", Inertial.rod(1.0, L3, axis=0, com=(L3 / 2, 0.0, 0.0))),
    ]
    joints = [
        Joint(
            "theta1_joint",
            JointKind.REVOLUTE,
            PLATFORM,
            "link1",
            axis=(0, 0, 1),
            coordinate="theta1",
        ),
        Joint(
            "theta2_joint",
            JointKind.REVOLUTE,
            "link1",
            "link2",
            origin_xyz=(0.0, 0.0, L1),
            axis=(0, 1, 0),
            coordinate="theta2",
        ),
        Joint(
            "theta3_joint",
            JointKind.REVOLUTE,
            "link2",
            "link3",
            origin_xyz=(L2, 0.0, 0.0),
            axis=(0, 1, 0),
            coordinate="theta3",
        ),
    ]
    collision = [
        CollisionSphere(PLATFORM, (0.0, 0.0, 0.0), DISC_RADIUS),
        CollisionSphere(PLATFORM, (DISC_AHEAD, 0.0, 0.0), DISC_RADIUS),
        *points_on_segment("link2", (0, 0, 0), (L2, 0, 0), 0.14),
        *points_on_segment("link3", (0, 0, 0), (L3, 0, 0), 0.14)[1:],
    ]
    limits = Limits(
        joint_min=np.array([-np.pi, -np.pi / 2, -2.5]),
        joint_max=np.array([np.pi, np.pi / 2, 2.5]),
        torque_min=np.full(5, -np.inf),
        torque_max=np.full(5, np.inf),
        rates=RateLimits(sources={"*": RATE_SOURCE}),
    )
    return Robot(
        "diffdrive-3dof",
        platform,
        bodies,
        joints,
        EndEffector("link3", (L3, 0.0, 0.0)),
        limits,
        collision,
        description="(2,0) platform with a 3-dof arm, [AbdessemedDjebrani] section 2.",
    )
