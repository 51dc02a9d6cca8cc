"""A robot's limits: arm joint ranges, actuator efforts, velocities and accelerations.

Velocity and acceleration limits (:class:`RateLimits`) are absolute bounds
``|dq_i| <= v_i`` and ``|ddq_i| <= a_i`` on named coordinates (arm joints, wheel angles),
plus the platform's planar speed ``|(dx, dy)|``, yaw rate ``|dtheta|`` and their
accelerations. A limit that is absent or infinite is off. Each built-in robot names the
source of its numbers (data sheet, URDF) in ``sources``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from mmplan.arrays import Array


@dataclass(frozen=True)
class RateLimits:
    """Velocity and acceleration limits (all off by default).

    Attributes:
        velocity: ``|dq|`` bound by coordinate name [rad/s or m/s] (arm joints, wheel angles).
        acceleration: ``|ddq|`` bound by coordinate name [rad/s^2 or m/s^2].
        platform_speed: Bound of the platform origin's planar speed ``|(dx, dy)|`` [m/s].
        platform_yaw_rate: Bound of ``|dtheta/dt|`` [rad/s].
        platform_acceleration: Bound of ``|(ddx, ddy)|`` [m/s^2].
        platform_yaw_acceleration: Bound of ``|d2theta/dt2|`` [rad/s^2].
        sources: Where the numbers come from, by key (``"velocity.q1"``, ``"platform_speed"``,
            or ``"*"`` for all): a data sheet, the URDF, or a derivation.
    """

    velocity: Mapping[str, float] = field(default_factory=dict)
    acceleration: Mapping[str, float] = field(default_factory=dict)
    platform_speed: float = math.inf
    platform_yaw_rate: float = math.inf
    platform_acceleration: float = math.inf
    platform_yaw_acceleration: float = math.inf
    sources: Mapping[str, str] = field(default_factory=dict)

    @property
    def any(self) -> bool:
        """True when at least one limit is finite."""
        values = [*self.velocity.values(), *self.acceleration.values(), self.platform_speed,
                  self.platform_yaw_rate, self.platform_acceleration,
                  self.platform_yaw_acceleration]
        return any(math.isfinite(v) for v in values)

    def velocity_bounds(self, coordinates: Sequence[str]) -> Array:
        """``|dq_i|`` bounds in ``coordinates`` order, (n,); inf where off."""
        return np.array([self.velocity.get(c, math.inf) for c in coordinates], dtype=float)

    def acceleration_bounds(self, coordinates: Sequence[str]) -> Array:
        """``|ddq_i|`` bounds in ``coordinates`` order, (n,); inf where off."""
        return np.array([self.acceleration.get(c, math.inf) for c in coordinates], dtype=float)


@dataclass(frozen=True)
class Limits:
    """Joint limits of the arm coordinates, actuator effort limits and rate limits.

    Attributes:
        joint_min, joint_max: Arm joint limits (n_arm,) [rad or m].
        torque_min, torque_max: Actuator limits (n_act,) [N m or N]; +-inf where unlimited.
        rates: Velocity and acceleration limits (off by default).
    """

    joint_min: Array
    joint_max: Array
    torque_min: Array
    torque_max: Array
    rates: RateLimits = field(default_factory=RateLimits)

    @property
    def has_torque_limits(self) -> bool:
        """True when at least one actuator limit is finite."""
        return bool(np.isfinite(self.torque_min).any() or np.isfinite(self.torque_max).any())
