"""Velocity and acceleration limits of the KUKA youBot (youbot-3r, youbot-4r), with sources.

The models keep the papers' (2,0) differential-drive reading of the youBot base ([PajakPajak],
[Pajak]); the real base is omnidirectional, and its published top speed bounds the platform's
planar speed and every wheel's rim speed alike:

* platform speed 0.8 m/s: KUKA youBot data sheet (KUKA's published base specification);
* wheel rate 0.8 m/s / r = 16 rad/s with the model's r = 0.05 m (derived);
* yaw rate 0.8 m/s / d (d the half track): both wheels at 16 rad/s in opposite senses, 5 rad/s
  for d = 0.16 m (derived);
* arm joints pi/2 rad/s (90 deg/s) each: the youBot arm's URDF (youbot_description,
  ``urdf/youbot_arm/arm.urdf.xacro``, ``<limit velocity="${M_PI / 2.0}">`` on arm joints 1-5),
  the 90 deg/s axis speed quoted from KUKA's arm specification;
* platform acceleration 1.0 m/s^2: an ASSUMPTION (no published value; 0 to 0.8 m/s in 0.8 s),
  wheel accelerations 1.0 / r = 20 rad/s^2 and yaw acceleration 1.0 / d derived from it;
* arm joint accelerations: off (no published value; the torque limits bound them where set).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from mmplan.robot.limits import RateLimits

#: Top speed of the youBot base [m/s] (KUKA youBot data sheet).
BASE_SPEED = 0.8
#: Speed of every youBot arm joint [rad/s] (youbot_description arm URDF: pi/2 = 90 deg/s).
ARM_JOINT_SPEED = math.pi / 2
#: Assumed acceleration of the base [m/s^2]: no published value.
BASE_ACCELERATION = 1.0

DATA_SHEET = "KUKA youBot data sheet: base max. speed 0.8 m/s"
ARM_URDF = ("youBot arm URDF (youbot_description urdf/youbot_arm/arm.urdf.xacro, velocity = "
            "pi/2 rad/s on arm joints 1-5; KUKA's arm specification: 90 deg/s)")
ASSUMED = "assumption (no published value): 1.0 m/s^2, 0 to 0.8 m/s in 0.8 s"


def youbot_rate_limits(wheel_radius: float, half_track: float, wheels: Sequence[str],
                       arm: Sequence[str]) -> RateLimits:
    """Rate limits of a youBot model with wheel radius r [m] and half track d [m].

    Args:
        wheel_radius: r of the model [m].
        half_track: d, half the distance between the wheels [m].
        wheels: Names of the wheel angle coordinates.
        arm: Names of the arm joint coordinates.
    """
    r, d = wheel_radius, half_track
    wheel_rate, wheel_acc = BASE_SPEED / r, BASE_ACCELERATION / r
    sources = {
        "platform_speed": DATA_SHEET,
        "platform_yaw_rate": f"derived: 0.8 m/s / d (d = {d:g} m half track) "
                             f"= {BASE_SPEED / d:.4g} rad/s",
        "platform_acceleration": ASSUMED,
        "platform_yaw_acceleration": f"derived from the assumed 1.0 m/s^2: 1.0 / d "
                                     f"(d = {d:g} m) = {BASE_ACCELERATION / d:.4g} rad/s^2",
    }
    for w in wheels:
        sources[f"velocity.{w}"] = (f"derived: 0.8 m/s / r (r = {r:g} m, the model's wheel "
                                    f"radius) = {wheel_rate:.4g} rad/s")
        sources[f"acceleration.{w}"] = (f"derived from the assumed 1.0 m/s^2: 1.0 / r "
                                        f"= {wheel_acc:.4g} rad/s^2")
    for j in arm:
        sources[f"velocity.{j}"] = ARM_URDF
        sources[f"acceleration.{j}"] = "off: no published value"
    return RateLimits(
        velocity={**{w: wheel_rate for w in wheels}, **{j: ARM_JOINT_SPEED for j in arm}},
        acceleration={w: wheel_acc for w in wheels},
        platform_speed=BASE_SPEED,
        platform_yaw_rate=BASE_SPEED / d,
        platform_acceleration=BASE_ACCELERATION,
        platform_yaw_acceleration=BASE_ACCELERATION / d,
        sources=sources,
    )
