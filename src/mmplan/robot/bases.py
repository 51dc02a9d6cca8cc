r"""Platform kinds: their coordinates, joints, Pfaffian constraints and actuation.

A platform contributes the first coordinates of q, the joints that place its body
``"platform"`` in the world (planar x, y and heading, plus wheels or steering), and

* the Pfaffian matrix A(q) (h, n_p) with A(q) dq_p = 0 ([PajakPajak] eq. (4)),
* the actuation matrix B (n_p, n_a) mapping actuator efforts to generalized forces,
* a basis N(q) (n_p, n_p - h) of ker A, chosen with N^T B invertible so that
  tau = (N^T B)^{-1} N^T (M ddq + c) ([PajakPajak] eq. (20)) is well defined.

The platform frame sits on the ground (z = 0) below the platform centre, x forward.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import casadi as ca

from mmplan.robot.tree import Body, Inertial, Joint, JointKind

PLATFORM = "platform"
#: Steering assembly of a car: a 2 kg disc of radius 0.3 m about the vertical.
STEERING_INERTIA = Inertial.disc(2.0, 0.3, axis=2)


def _planar_joints(names: tuple[str, str, str]) -> list[Joint]:
    """World -> x slide -> y slide -> heading -> body 'platform'."""
    x, y, yaw = names
    return [
        Joint(f"{x}_joint", JointKind.PRISMATIC, "world", "_slide_x", axis=(1, 0, 0), coordinate=x),
        Joint(
            f"{y}_joint", JointKind.PRISMATIC, "_slide_x", "_slide_y", axis=(0, 1, 0), coordinate=y
        ),
        Joint(
            f"{yaw}_joint", JointKind.REVOLUTE, "_slide_y", PLATFORM, axis=(0, 0, 1), coordinate=yaw
        ),
    ]


def _planar_bodies(body: Inertial) -> list[Body]:
    return [Body("_slide_x"), Body("_slide_y"), Body(PLATFORM, body)]


class Platform(ABC):
    """A wheeled platform kind."""

    @property
    @abstractmethod
    def coordinates(self) -> tuple[str, ...]:
        """Names of the platform coordinates, in q order."""

    @property
    @abstractmethod
    def actuators(self) -> tuple[str, ...]:
        """Names of the platform actuators, in tau order."""

    @abstractmethod
    def bodies_and_joints(self) -> tuple[list[Body], list[Joint]]:
        """Bodies and joints from the world to the platform (and its wheels)."""

    @abstractmethod
    def pfaffian(self, qp: ca.SX) -> ca.SX:
        """A(q) (h, n_p) of the platform coordinates ``qp``."""

    @abstractmethod
    def null_basis(self, qp: ca.SX) -> ca.SX:
        """N(q) (n_p, n_p - h), columns spanning ker A(q)."""

    @abstractmethod
    def actuation(self, qp: ca.SX) -> ca.SX:
        """B(q) (n_p, n_a)."""

    @property
    def n_constraints(self) -> int:
        """h, the number of Pfaffian constraints."""
        return len(self.coordinates) - len(self.actuators)


@dataclass(frozen=True)
class DifferentialDrive(Platform):
    """(2,0) platform with two driven wheels, wheel angles as coordinates (youBot).

    The youBot of [PajakPajak] and [Pajak]. q_p = (x, y, theta, phi1, phi2); phi1 is the left
    wheel (at +d), phi2 the right one.
    Pfaffian rows ([PajakPajak] section 5): left wheel rolls ``v - d dtheta = r dphi1``, right
    wheel rolls ``v + d dtheta = r dphi2``, no lateral slip. [Pajak] eq. (25) swaps the wheel
    labels; we keep [PajakPajak]'s convention for every differential drive.
    """

    wheel_radius: float
    half_track: float
    body: Inertial
    wheel: Inertial
    names: tuple[str, str, str, str, str] = ("x", "y", "theta", "phi1", "phi2")

    @property
    def coordinates(self) -> tuple[str, ...]:
        return self.names

    @property
    def actuators(self) -> tuple[str, ...]:
        return ("wheel1", "wheel2")

    def bodies_and_joints(self) -> tuple[list[Body], list[Joint]]:
        r, d = self.wheel_radius, self.half_track
        bodies = [
            *_planar_bodies(self.body),
            Body("wheel1", self.wheel),
            Body("wheel2", self.wheel),
        ]
        joints = _planar_joints(self.names[:3])
        for k, side in ((1, d), (2, -d)):
            joints.append(
                Joint(
                    f"wheel{k}_joint",
                    JointKind.REVOLUTE,
                    PLATFORM,
                    f"wheel{k}",
                    origin_xyz=(0.0, side, r),
                    axis=(0, 1, 0),
                    coordinate=self.names[2 + k],
                )
            )
        return bodies, joints

    def pfaffian(self, qp: ca.SX) -> ca.SX:
        r, d = self.wheel_radius, self.half_track
        c, s = ca.cos(qp[2]), ca.sin(qp[2])
        return ca.vertcat(
            ca.horzcat(c, s, -d, -r, 0),
            ca.horzcat(c, s, d, 0, -r),
            ca.horzcat(s, -c, 0, 0, 0),
        )

    def null_basis(self, qp: ca.SX) -> ca.SX:
        r, d = self.wheel_radius, self.half_track
        c, s = ca.cos(qp[2]), ca.sin(qp[2])
        left = ca.vertcat(r / 2 * c, r / 2 * s, -r / (2 * d), 1, 0)
        right = ca.vertcat(r / 2 * c, r / 2 * s, r / (2 * d), 0, 1)
        return ca.horzcat(left, right)

    def actuation(self, qp: ca.SX) -> ca.SX:
        B = ca.SX.zeros(5, 2)
        B[3, 0] = 1
        B[4, 1] = 1
        return B


@dataclass(frozen=True)
class UnicycleDrive(Platform):
    """(2,0) platform without wheel coordinates: q_p = (x, y, phi).

    [AbdessemedDjebrani] section 2. One Pfaffian row, no lateral slip:
    ``sin(phi) dx - cos(phi) dy = 0`` ([AbdessemedDjebrani] eq. (2)). Actuators are the forward
    force and the yaw torque, so B = N.
    """

    body: Inertial
    names: tuple[str, str, str] = ("x", "y", "phi")

    @property
    def coordinates(self) -> tuple[str, ...]:
        return self.names

    @property
    def actuators(self) -> tuple[str, ...]:
        return ("drive", "yaw")

    def bodies_and_joints(self) -> tuple[list[Body], list[Joint]]:
        return _planar_bodies(self.body), _planar_joints(self.names)

    def pfaffian(self, qp: ca.SX) -> ca.SX:
        return ca.horzcat(ca.sin(qp[2]), -ca.cos(qp[2]), 0)

    def null_basis(self, qp: ca.SX) -> ca.SX:
        c, s = ca.cos(qp[2]), ca.sin(qp[2])
        return ca.horzcat(ca.vertcat(c, s, 0), ca.vertcat(0, 0, 1))

    def actuation(self, qp: ca.SX) -> ca.SX:
        return self.null_basis(qp)


@dataclass(frozen=True)
class KinematicCar(Platform):
    """Kinematic car ([JaniakTchon] section III): q_p = (x, y, phi, psi), psi front steering.

    Motion ``dx = u1 cos(phi) cos(psi)``, ``dy = u1 sin(phi) cos(psi)``,
    ``dphi = u1 sin(psi) / L``, ``dpsi = u2``; the two Pfaffian rows say that neither the
    rear nor the front wheel slips sideways. Actuators are the drive and the steering.
    """

    length: float
    body: Inertial
    steering: Inertial = STEERING_INERTIA
    names: tuple[str, str, str, str] = ("x", "y", "phi", "psi")

    @property
    def coordinates(self) -> tuple[str, ...]:
        return self.names

    @property
    def actuators(self) -> tuple[str, ...]:
        return ("drive", "steer")

    def bodies_and_joints(self) -> tuple[list[Body], list[Joint]]:
        bodies = [*_planar_bodies(self.body), Body("steering", self.steering)]
        joints = _planar_joints(self.names[:3])
        joints.append(
            Joint(
                "steering_joint",
                JointKind.REVOLUTE,
                PLATFORM,
                "steering",
                origin_xyz=(self.length, 0.0, 0.0),
                coordinate=self.names[3],
            )
        )
        return bodies, joints

    def pfaffian(self, qp: ca.SX) -> ca.SX:
        c, s = ca.cos(qp[2]), ca.sin(qp[2])
        cs, ss = ca.cos(qp[3]), ca.sin(qp[3])
        return ca.vertcat(
            ca.horzcat(s, -c, 0, 0),
            ca.horzcat(c * ss, s * ss, -self.length * cs, 0),
        )

    def null_basis(self, qp: ca.SX) -> ca.SX:
        c, s = ca.cos(qp[2]), ca.sin(qp[2])
        cs, ss = ca.cos(qp[3]), ca.sin(qp[3])
        drive = ca.vertcat(c * cs, s * cs, ss / self.length, 0)
        return ca.horzcat(drive, ca.vertcat(0, 0, 0, 1))

    def actuation(self, qp: ca.SX) -> ca.SX:
        return self.null_basis(qp)


@dataclass(frozen=True)
class Omnidirectional(Platform):
    """Omnidirectional platform: q_p = (x, y, theta), no constraints.

    [AbdessemedDjebrani] section 3. Actuators are generalized forces along world x, y and the yaw
    torque (B = N = I).
    """

    body: Inertial
    names: tuple[str, str, str] = ("x", "y", "theta")

    @property
    def coordinates(self) -> tuple[str, ...]:
        return self.names

    @property
    def actuators(self) -> tuple[str, ...]:
        return ("force_x", "force_y", "yaw")

    def bodies_and_joints(self) -> tuple[list[Body], list[Joint]]:
        return _planar_bodies(self.body), _planar_joints(self.names)

    def pfaffian(self, qp: ca.SX) -> ca.SX:
        return ca.SX(0, 3)

    def null_basis(self, qp: ca.SX) -> ca.SX:
        return ca.SX.eye(3)

    def actuation(self, qp: ca.SX) -> ca.SX:
        return ca.SX.eye(3)
