"""youbot-4r: KUKA youBot (2,0) platform with a 4R arm ([Pajak], section 5).

q = [x, y, theta, phi1, phi2, q1, q2, q3, q4]; n = 9, h = 3. With alpha = theta - q1 and
L = l1 + l2 cos q2 + l3 cos(q2+q3) + l4 cos(q2+q3+q4):
``k = (x + xr cos th - yr sin th + L cos alpha, y + xr sin th + yr cos th + L sin alpha,
zc + zr - l2 sin q2 - l3 sin(q2+q3) - l4 sin(q2+q3+q4))``.

Parameters of [Pajak] Table 1 (read as in docs/conventions.md): r = 0.05 (Table 1 prints 0.005),
half track d = 0.158, zc = 0.084, xr = 0.167, yr = 0, zr = 0.161, l1..l4 = 0.033, 0.155, 0.135,
0.1708. Masses: platform 19.803 (uniform box 0.456 x 0.316 x 0.046 at height zc), wheels 1.4 (thin
discs), links 1.39, 1.318, 0.821, 1.675 (slender rods, centre at mid-length). Friction (Coulomb 0.2,
viscous 0.045 on the wheels) is available through ``build(friction=True)`` and off by default
(docs/conventions.md: Coulomb 0.2 N m equals the wheel limit).
Joint limits are not printed in [Pajak]: we use the youBot's published ranges
q1 +-169 deg, q2 [-65, 90] deg, q3 [-151, 146] deg, q4 +-102.5 deg.
Wheel labels follow [PajakPajak] ([Pajak] eq. (25) swaps them; either way, see
docs/conventions.md).
Rate limits (:mod:`.youbot_rates`, sources there and in docs/conventions.md "Limits"): platform
speed 0.8 m/s (KUKA youBot data sheet), wheels 0.8 / r = 16 rad/s and yaw rate 0.8 / d = 5.063
rad/s (derived), arm joints pi/2 rad/s (youBot arm URDF, 90 deg/s); platform acceleration
1.0 m/s^2 (an assumption: no published value), wheels 20 rad/s^2 and yaw 6.329 rad/s^2 derived
from it; arm joint accelerations off.
"""

from __future__ import annotations

import numpy as np

from mmplan.robot.bases import PLATFORM, DifferentialDrive
from mmplan.robot.collision import points_on_box, points_on_segment
from mmplan.robot.dynamics import Friction
from mmplan.robot.library.youbot_rates import youbot_rate_limits
from mmplan.robot.limits import Limits
from mmplan.robot.robot import EndEffector, Robot
from mmplan.robot.tree import Body, Inertial, Joint, JointKind

WHEEL_RADIUS = 0.05
HALF_TRACK = 0.158
PLATFORM_SIZE = (0.456, 0.316, 0.046)
ZC, XR, YR, ZR = 0.084, 0.167, 0.0, 0.161
L1, L2, L3, L4 = 0.033, 0.155, 0.135, 0.1708
SPACING = 0.14
DEG = np.pi / 180


def build(friction: bool = False) -> Robot:
    """Build youbot-4r (optionally with [Pajak]'s wheel friction)."""
    platform = DifferentialDrive(
        wheel_radius=WHEEL_RADIUS,
        half_track=HALF_TRACK,
        body=Inertial.box(19.803, PLATFORM_SIZE, (0.0, 0.0, ZC)),
        wheel=Inertial.disc(1.4, WHEEL_RADIUS, axis=1),
    )
    bodies = [
        Body("link1", Inertial.rod(1.39, L1, axis=0, com=(L1 / 2, 0.0, 0.0))),
        Body("link2", Inertial.rod(1.318, L2, axis=0, com=(L2 / 2, 0.0, 0.0))),
        Body("link3", Inertial.rod(0.821, L3, axis=0, com=(L3 / 2, 0.0, 0.0))),
        Body("link4", Inertial.rod(1.675, L4, axis=0, com=(L4 / 2, 0.0, 0.0))),
    ]
    joints = [
        Joint(
            "q1_joint",
            JointKind.REVOLUTE,
            PLATFORM,
            "link1",
            origin_xyz=(XR, YR, ZC + ZR),
            axis=(0, 0, -1),
            coordinate="q1",
        ),
        Joint(
            "q2_joint",
            JointKind.REVOLUTE,
            "link1",
            "link2",
            origin_xyz=(L1, 0.0, 0.0),
            axis=(0, 1, 0),
            coordinate="q2",
        ),
        Joint(
            "q3_joint",
            JointKind.REVOLUTE,
            "link2",
            "link3",
            origin_xyz=(L2, 0.0, 0.0),
            axis=(0, 1, 0),
            coordinate="q3",
        ),
        Joint(
            "q4_joint",
            JointKind.REVOLUTE,
            "link3",
            "link4",
            origin_xyz=(L3, 0.0, 0.0),
            axis=(0, 1, 0),
            coordinate="q4",
        ),
    ]
    collision = [
        *points_on_box(PLATFORM, (0.0, 0.0, ZC), PLATFORM_SIZE, SPACING),
        *points_on_segment("link2", (0, 0, 0), (L2, 0, 0), SPACING),
        *points_on_segment("link3", (0, 0, 0), (L3, 0, 0), SPACING)[1:],
        *points_on_segment("link4", (0, 0, 0), (L4, 0, 0), SPACING)[1:],
    ]
    inf = np.inf
    limits = Limits(
        joint_min=np.array([-169.0, -65.0, -151.0, -102.5]) * DEG,
        joint_max=np.array([169.0, 90.0, 146.0, 102.5]) * DEG,
        torque_min=np.full(6, -inf),
        torque_max=np.full(6, inf),
        rates=youbot_rate_limits(WHEEL_RADIUS, HALF_TRACK, ("phi1", "phi2"),
                                 ("q1", "q2", "q3", "q4")),
    )
    wheel_friction = Friction(viscous=0.045, coulomb=0.2)
    return Robot(
        "youbot-4r",
        platform,
        bodies,
        joints,
        EndEffector("link4", (L4, 0.0, 0.0)),
        limits,
        collision,
        friction={"phi1": wheel_friction, "phi2": wheel_friction} if friction else None,
        description="KUKA youBot (2,0) platform with a 4R arm, [Pajak].",
    )
