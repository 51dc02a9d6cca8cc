"""omni-3dof: omnidirectional platform with a 3-dof arm ([AbdessemedDjebrani] section 3, eq. (33)).

q = (x, y, theta, qa1, qa2, qa3);
``xi1 = x + (a + C1 (a3 C23 + a2 C2)) C_th - (b + S1 (a3 C23 + a2 C2)) S_th``,
``xi2 = y + (a + C1 (...)) S_th + (b + S1 (...)) C_th``, ``xi3 = z + a1 - a2 S2 - a3 S23``
with a1 = 0.6, a2 = 0.4, a3 = 0.3, mounting offset (a, b) = (0.2, 0), platform height z = 0.
Masses are nominal ([AbdessemedDjebrani] is kinematic). Arm limits (not printed): qa1 +-pi,
qa2 [-pi, pi/2], qa3 [-2.5, 2.5] rad.
Velocity and acceleration limits: off (no data sheet; no real machine named).
"""

from __future__ import annotations

import numpy as np

from mmplan.robot.bases import PLATFORM, Omnidirectional
from mmplan.robot.collision import points_on_segment
from mmplan.robot.limits import Limits, RateLimits
from mmplan.robot.robot import CollisionSphere, EndEffector, Robot
from mmplan.robot.tree import Body, Inertial, Joint, JointKind

#: Source of the (absent) velocity and acceleration limits.
RATE_SOURCE = (
    "no data sheet: off ([AbdessemedDjebrani]'s robot is kinematic, no real machine named)"
)

A1, A2, A3 = 0.6, 0.4, 0.3
MOUNT = (0.2, 0.0)
PLATFORM_RADIUS = 0.25


def build() -> Robot:
    """Build omni-3dof."""
    platform = Omnidirectional(body=Inertial.box(20.0, (0.6, 0.5, 0.2), (0.0, 0.0, 0.1)))
    bodies = [
        Body("link1", Inertial.rod(2.0, A1, axis=2, com=(0.0, 0.0, A1 / 2))),
        Body("link2", Inertial.rod(1.5, A2, axis=0, com=(A2 / 2, 0.0, 0.0))),
        Body("link3", Inertial.rod(1.0, A3, axis=0, com=(A3 / 2, 0.0, 0.0))),
    ]
    joints = [
        Joint(
            "qa1_joint",
            JointKind.REVOLUTE,
            PLATFORM,
            "link1",
            origin_xyz=(*MOUNT, 0.0),
            axis=(0, 0, 1),
            coordinate="qa1",
        ),
        Joint(
            "qa2_joint",
            JointKind.REVOLUTE,
            "link1",
            "link2",
            origin_xyz=(0.0, 0.0, A1),
            axis=(0, 1, 0),
            coordinate="qa2",
        ),
        Joint(
            "qa3_joint",
            JointKind.REVOLUTE,
            "link2",
            "link3",
            origin_xyz=(A2, 0.0, 0.0),
            axis=(0, 1, 0),
            coordinate="qa3",
        ),
    ]
    collision = [
        CollisionSphere(PLATFORM, (0.0, 0.0, 0.0), PLATFORM_RADIUS),
        *points_on_segment("link2", (0, 0, 0), (A2, 0, 0), 0.14),
        *points_on_segment("link3", (0, 0, 0), (A3, 0, 0), 0.14)[1:],
    ]
    limits = Limits(
        joint_min=np.array([-np.pi, -np.pi, -2.5]),
        joint_max=np.array([np.pi, np.pi / 2, 2.5]),
        torque_min=np.full(6, -np.inf),
        torque_max=np.full(6, np.inf),
        rates=RateLimits(sources={"*": RATE_SOURCE}),
    )
    return Robot(
        "omni-3dof",
        platform,
        bodies,
        joints,
        EndEffector("link3", (A3, 0.0, 0.0)),
        limits,
        collision,
        description="Omnidirectional platform with a 3-dof arm, [AbdessemedDjebrani] section 3.",
    )
