r"""A differential drive whose wheels, body and inertias come from a URDF.

The planar pose (x, y, theta) places the URDF root on the ground; the two wheel joints keep
their URDF names, placements, axes and inertias. Wheel k sits at (a, b_k) in the platform
frame (the same a for both) with its axle along s_k y (s_k = +-1: the sign that makes a
positive wheel angle roll forward). Pfaffian rows (h = 3), as [PajakPajak] section 5 with the
wheels' offsets:

.. math::

    \cos\theta\,\dot x + \sin\theta\,\dot y - b_k\dot\theta - s_k r\dot\varphi_k = 0
    \quad (k = 1, 2), \qquad
    \sin\theta\,\dot x - \cos\theta\,\dot y - a\dot\theta = 0 .

With b_1 = d, b_2 = -d, a = 0 and s_k = 1 these are the rows of
:class:`~mmplan.robot.bases.DifferentialDrive`. Actuators are the two wheel torques
(named after the wheel joints); N(q) has the wheel rates as parameters, so N^T B = I.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from mmplan.robot.bases import PLATFORM, Platform
from mmplan.robot.tree import Body, Inertial, Joint, JointKind

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class UrdfWheel:
    """One wheel from the URDF: joint name (coordinate), link, placement, axis, inertia.

    Attributes:
        joint: URDF joint name (the coordinate and actuator name).
        link: URDF link name (the mmplan body).
        origin_xyz, origin_rpy: Joint placement in the platform frame.
        axis: Joint axis in the joint frame.
        inertial: The wheel link's inertia (with anything fixed to it).
    """

    joint: str
    link: str
    origin_xyz: Vec3
    origin_rpy: Vec3
    axis: Vec3
    inertial: Inertial


@dataclass(frozen=True)
class UrdfDifferentialDrive(Platform):
    """(2,0) platform with two driven URDF wheels; q_p = (x, y, theta, wheel_1, wheel_2).

    Attributes:
        wheel_radius: r [m].
        lateral: b_1, b_2: lateral offsets of the wheel centres [m] (left wheel first, b_1 > b_2).
        axle_x: a: forward offset of the axle from the platform origin [m].
        signs: s_1, s_2: +1 where the wheel axis is +y in the platform frame, -1 for -y.
        body: Inertia of the platform body (the URDF root and everything held fixed to it).
        wheels: The two wheels.
        names: Names of x, y and the heading.
    """

    wheel_radius: float
    lateral: tuple[float, float]
    axle_x: float
    signs: tuple[float, float]
    body: Inertial
    wheels: tuple[UrdfWheel, UrdfWheel]
    names: tuple[str, str, str] = ("x", "y", "theta")

    @property
    def half_track(self) -> float:
        """d = (b_1 - b_2) / 2 [m]."""
        return (self.lateral[0] - self.lateral[1]) / 2

    @property
    def coordinates(self) -> tuple[str, ...]:
        return (*self.names, self.wheels[0].joint, self.wheels[1].joint)

    @property
    def actuators(self) -> tuple[str, ...]:
        return (self.wheels[0].joint, self.wheels[1].joint)

    def bodies_and_joints(self) -> tuple[list[Body], list[Joint]]:
        x, y, yaw = self.names
        bodies = [Body("_slide_x"), Body("_slide_y"), Body(PLATFORM, self.body)]
        joints = [
            Joint(f"{x}_joint", JointKind.PRISMATIC, "world", "_slide_x", axis=(1, 0, 0),
                  coordinate=x),
            Joint(f"{y}_joint", JointKind.PRISMATIC, "_slide_x", "_slide_y", axis=(0, 1, 0),
                  coordinate=y),
            Joint(f"{yaw}_joint", JointKind.REVOLUTE, "_slide_y", PLATFORM, axis=(0, 0, 1),
                  coordinate=yaw),
        ]
        for wheel in self.wheels:
            bodies.append(Body(wheel.link, wheel.inertial))
            joints.append(Joint(wheel.joint, JointKind.REVOLUTE, PLATFORM, wheel.link,
                                wheel.origin_xyz, wheel.origin_rpy, wheel.axis, wheel.joint))
        return bodies, joints

    def pfaffian(self, qp: ca.SX) -> ca.SX:
        r, (b1, b2), (s1, s2), a = self.wheel_radius, self.lateral, self.signs, self.axle_x
        c, s = ca.cos(qp[2]), ca.sin(qp[2])
        return ca.vertcat(
            ca.horzcat(c, s, -b1, -s1 * r, 0),
            ca.horzcat(c, s, -b2, 0, -s2 * r),
            ca.horzcat(s, -c, -a, 0, 0),
        )

    def null_basis(self, qp: ca.SX) -> ca.SX:
        r, (b1, b2), (s1, s2), a = self.wheel_radius, self.lateral, self.signs, self.axle_x
        c, s = ca.cos(qp[2]), ca.sin(qp[2])
        columns = []
        for k, (sign, b) in enumerate(((s1, b1), (s2, b2))):
            # wheel k alone at unit rate: yaw rate w and forward speed v of the platform origin
            w = (-sign * r if k == 0 else sign * r) / (b1 - b2)
            v = sign * r + b * w
            unit = [0.0, 0.0]
            unit[k] = 1.0
            columns.append(ca.vertcat(c * v + s * a * w, s * v - c * a * w, w, *unit))
        return ca.horzcat(*columns)

    def actuation(self, qp: ca.SX) -> ca.SX:
        B = ca.SX.zeros(5, 2)
        B[3, 0] = 1
        B[4, 1] = 1
        return B
