"""base-6dof: PUMA 560 arm (scaled by 0.4) on a planar base ([Nagatani]).

Set-up as in docs/manipulability_area.md. q = (x, y, theta, q1, ..., q6). The arm follows
Corke's standard DH parameters of the PUMA 560 scaled by 0.4 (a2 = 0.17272, a3 = 0.00812, d3 =
0.06002, d4 = 0.17272 m; alpha = pi/2, 0, -pi/2, pi/2, -pi/2, 0), with the shoulder 0.45 m
above the ground at the platform centre and a pen tool 0.10 m along the flange z axis. Each DH
link i is modelled as a revolute joint about z followed by the fixed placement Tz(d_i) Tx(a_i)
Rx(alpha_i), which becomes the origin of joint i+1. Joint limits are Corke's qlim; masses are
nominal small boxes ([Nagatani] is kinematic). Manipulability is [Nagatani]'s w = sqrt(det(J
J^T)) of the 6x6 tool Jacobian of the arm (``manipulability="pose"``). The base is
omnidirectional in the model ([Nagatani] plans its path only).
Velocity and acceleration limits: off. Corke's PUMA 560 model (the source of the DH
parameters and joint ranges) lists no joint speed limits, the arm is scaled by 0.4 and the
base is not specified, so no published number applies.
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
    "off: Corke's PUMA 560 model (source of the DH parameters and qlim) gives no joint speed "
    "limits, the arm is scaled by 0.4 and the base is not specified ([Nagatani]); the "
    "manipulability-area plan is timed by the segment parameter, not in seconds"
)

SCALE = 0.4
SHOULDER_HEIGHT = 0.45
TOOL = 0.10
#: Standard DH (d, a, alpha) of the PUMA 560 (Corke), before scaling.
DH = (
    (0.0, 0.0, np.pi / 2),
    (0.0, 0.4318, 0.0),
    (0.15005, 0.0203, -np.pi / 2),
    (0.4318, 0.0, np.pi / 2),
    (0.0, 0.0, -np.pi / 2),
    (0.0, 0.0, 0.0),
)
QLIM_DEG = ((-160, 160), (-45, 225), (-225, 45), (-110, 170), (-100, 100), (-266, 266))


def dh_scaled() -> list[tuple[float, float, float]]:
    """(d, a, alpha) of the scaled arm."""
    return [(SCALE * d, SCALE * a, alpha) for d, a, alpha in DH]


def build() -> Robot:
    """Build base-6dof."""
    platform = Omnidirectional(body=Inertial.box(30.0, (0.6, 0.5, 0.3), (0.0, 0.0, 0.15)))
    bodies, joints = [], []
    parent, origin_xyz, origin_rpy = PLATFORM, (0.0, 0.0, SHOULDER_HEIGHT), (0.0, 0.0, 0.0)
    for i, (d, a, alpha) in enumerate(dh_scaled(), start=1):
        name = f"link{i}"
        mass = 1.0 if i < 4 else 0.2
        bodies.append(
            Body(name, Inertial.box(mass, (0.05 + a, 0.05, 0.05 + d), (a / 2, 0.0, d / 2)))
        )
        joints.append(
            Joint(
                f"q{i}_joint",
                JointKind.REVOLUTE,
                parent,
                name,
                origin_xyz=origin_xyz,
                origin_rpy=origin_rpy,
                axis=(0, 0, 1),
                coordinate=f"q{i}",
            )
        )
        parent, origin_xyz, origin_rpy = name, (a, 0.0, d), (alpha, 0.0, 0.0)
    bodies.append(Body("flange"))
    joints.append(
        Joint(
            "flange_joint",
            JointKind.FIXED,
            parent,
            "flange",
            origin_xyz=origin_xyz,
            origin_rpy=origin_rpy,
        )
    )
    collision = [
        CollisionSphere(PLATFORM, (0.0, 0.0, 0.15), 0.35),
        *points_on_segment("link3", (0, 0, 0), (0, 0, SCALE * 0.4318), 0.05),
    ]
    limits = Limits(
        joint_min=np.deg2rad([lo for lo, _ in QLIM_DEG]),
        joint_max=np.deg2rad([hi for _, hi in QLIM_DEG]),
        torque_min=np.full(9, -np.inf),
        torque_max=np.full(9, np.inf),
        rates=RateLimits(sources={"*": RATE_SOURCE}),
    )
    return Robot(
        "base-6dof",
        platform,
        bodies,
        joints,
        EndEffector("flange", (0.0, 0.0, TOOL), manipulability="pose"),
        limits,
        collision,
        description="PUMA 560 (scaled 0.4) on a planar base, [Nagatani] (manipulability areas).",
    )
