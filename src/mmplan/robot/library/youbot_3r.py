"""youbot-3r: KUKA youBot (2,0) platform with a 3R arm ([PajakPajak], section 5).

q = [x, y, theta, phi1, phi2, q1, q2, q3]; n = 8, h = 3; actuators: 2 wheels + 3 joints.

Geometry uses the rounded coefficients of [PajakPajak]'s printed closed form, with
alpha = theta - q1 and R = 0.03 + 0.16 cos q2 + 0.34 cos(q2 + q3):
``k = (x + 0.17 cos th + R cos alpha, y + 0.17 sin th + R sin alpha,
0.25 - 0.16 sin q2 - 0.34 sin(q2 + q3))``. The q1 axis points down (so the arm heading is
theta - q1) and positive q2, q3 lower the arm.

Inertias are not printed (our choice, docs/conventions.md): the platform is a uniform box
0.456 x 0.316 x 0.046 m of 19.803 kg centred 0.084 m above the ground ([Pajak]'s z_c); wheels
are thin uniform discs of 1.4 kg, r = 0.05; the arm base (0.961 kg) is a point mass at the
mounting point on top of the platform; links are slender rods with the centre of mass at
mid-length (1.39 kg over the 0.03 m offset, 1.318 kg over 0.16 m, 2.496 kg over 0.34 m).

Rate limits (:mod:`.youbot_rates`, sources there and in docs/conventions.md "Limits"): platform
speed 0.8 m/s (KUKA youBot data sheet), wheels 0.8 / r = 16 rad/s and yaw rate 0.8 / d = 5 rad/s
(derived), arm joints pi/2 rad/s (youBot arm URDF, 90 deg/s); platform acceleration 1.0 m/s^2
(an assumption: no published value), wheels 20 rad/s^2 and yaw 6.25 rad/s^2 derived from it;
arm joint accelerations off.
"""

from __future__ import annotations

import numpy as np

from mmplan.robot.bases import PLATFORM, DifferentialDrive
from mmplan.robot.collision import points_on_box, points_on_segment
from mmplan.robot.library.youbot_rates import youbot_rate_limits
from mmplan.robot.limits import Limits
from mmplan.robot.robot import EndEffector, Robot
from mmplan.robot.tree import Body, Inertial, Joint, JointKind

WHEEL_RADIUS = 0.05
HALF_TRACK = 0.16
PLATFORM_SIZE = (0.456, 0.316, 0.046)
PLATFORM_HEIGHT = 0.084  # centre of the platform box above the ground
MOUNT = (0.17, 0.0, PLATFORM_HEIGHT + PLATFORM_SIZE[2] / 2)
SHOULDER_HEIGHT = 0.25
L1, L2, L3 = 0.03, 0.16, 0.34
SPACING = 0.14

DEG = np.pi / 180


def build() -> Robot:
    """Build youbot-3r."""
    platform = DifferentialDrive(
        wheel_radius=WHEEL_RADIUS,
        half_track=HALF_TRACK,
        body=Inertial.box(19.803, PLATFORM_SIZE, (0.0, 0.0, PLATFORM_HEIGHT)),
        wheel=Inertial.disc(1.4, WHEEL_RADIUS, axis=1),
    )
    rise = SHOULDER_HEIGHT - MOUNT[2]
    bodies = [
        Body("arm_base", Inertial.point(0.961)),
        Body("link1", Inertial.rod(1.39, L1, axis=0, com=(L1 / 2, 0.0, rise))),
        Body("link2", Inertial.rod(1.318, L2, axis=0, com=(L2 / 2, 0.0, 0.0))),
        Body("link3", Inertial.rod(2.496, L3, axis=0, com=(L3 / 2, 0.0, 0.0))),
    ]
    joints = [
        Joint("arm_mount", JointKind.FIXED, PLATFORM, "arm_base", origin_xyz=MOUNT),
        Joint(
            "q1_joint", JointKind.REVOLUTE, "arm_base", "link1", axis=(0, 0, -1), coordinate="q1"
        ),
        Joint(
            "q2_joint",
            JointKind.REVOLUTE,
            "link1",
            "link2",
            origin_xyz=(L1, 0.0, rise),
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
    ]
    collision = [
        *points_on_box(PLATFORM, (0.0, 0.0, PLATFORM_HEIGHT), PLATFORM_SIZE, SPACING),
        *points_on_segment("link2", (0, 0, 0), (L2, 0, 0), SPACING),
        *points_on_segment("link3", (0, 0, 0), (L3, 0, 0), SPACING)[1:],
    ]
    limits = Limits(
        joint_min=np.array([-169.0, -65.0, -151.0]) * DEG,
        joint_max=np.array([169.0, 90.0, 145.0]) * DEG,
        torque_min=np.array([-1.5, -1.5, -1.0, -10.0, -5.0]),
        torque_max=np.array([1.5, 1.5, 1.0, 0.0, 0.0]),
        rates=youbot_rate_limits(WHEEL_RADIUS, HALF_TRACK, ("phi1", "phi2"), ("q1", "q2", "q3")),
    )
    return Robot(
        "youbot-3r",
        platform,
        bodies,
        joints,
        EndEffector("link3", (L3, 0.0, 0.0)),
        limits,
        collision,
        description="KUKA youBot (2,0) platform with a 3R arm, [PajakPajak].",
    )
