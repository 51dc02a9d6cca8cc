"""Default velocity and acceleration limits of the built-in robots: numbers and their sources."""

from __future__ import annotations

import math

import pytest

from mmplan import get_robot, robot_names
from mmplan.robot import RateLimits
from mmplan.robot.library import youbot_3r, youbot_4r

PLATFORM_KEYS = ("platform_speed", "platform_yaw_rate", "platform_acceleration",
                 "platform_yaw_acceleration")


def finite_keys(rates: RateLimits) -> list[str]:
    keys = [f"{kind}.{name}" for kind in ("velocity", "acceleration")
            for name, value in getattr(rates, kind).items() if math.isfinite(value)]
    return keys + [k for k in PLATFORM_KEYS if math.isfinite(getattr(rates, k))]


@pytest.mark.parametrize("name", robot_names())
def test_every_default_limit_names_its_source(name: str) -> None:
    robot = get_robot(name)
    rates = robot.limits.rates
    assert rates.sources, f"{name}: no sources"
    for key in finite_keys(rates):
        assert rates.sources.get(key, "").strip(), f"{name}: {key} has no source"
    for kind in ("velocity", "acceleration"):  # bounds only on coordinates the robot has,
        for coordinate in getattr(rates, kind):  # never on the platform pose (x, y, heading)
            assert coordinate in robot.coordinates[3:], (name, kind, coordinate)
    if not rates.any:  # all off: say why
        assert "off" in rates.sources["*"], name


@pytest.mark.parametrize("name", ["car-rtr", "diffdrive-3dof", "omni-3dof", "base-6dof"])
def test_robots_without_a_data_sheet_have_no_rate_limits(name: str) -> None:
    rates = get_robot(name).limits.rates
    assert not rates.any
    assert "off" in rates.sources["*"]


@pytest.mark.parametrize(("name", "module", "arm"), [
    ("youbot-3r", youbot_3r, ("q1", "q2", "q3")),
    ("youbot-4r", youbot_4r, ("q1", "q2", "q3", "q4")),
])
def test_youbot_limits_follow_the_data_sheet_and_the_model_geometry(
        name: str, module: object, arm: tuple[str, ...]) -> None:
    rates = get_robot(name).limits.rates
    r, d = module.WHEEL_RADIUS, module.HALF_TRACK  # type: ignore[attr-defined]
    assert rates.platform_speed == 0.8
    assert "data sheet" in rates.sources["platform_speed"]
    # wheel rims at the base's top speed: 0.8 / 0.05 = 16 rad/s; opposite wheels: 0.8 / d
    assert rates.velocity["phi1"] == rates.velocity["phi2"] == pytest.approx(16.0, rel=1e-15)
    assert rates.velocity["phi1"] == pytest.approx(0.8 / r, rel=1e-15)
    assert rates.platform_yaw_rate == pytest.approx(0.8 / d, rel=1e-15)
    for joint in arm:  # youBot arm URDF: pi/2 rad/s (90 deg/s)
        assert rates.velocity[joint] == pytest.approx(math.pi / 2, rel=1e-15)
        assert "URDF" in rates.sources[f"velocity.{joint}"]
        assert joint not in rates.acceleration
    # accelerations: 1 m/s^2 is an assumption, said so; wheels and yaw derived from it
    assert rates.platform_acceleration == 1.0
    assert "assumption" in rates.sources["platform_acceleration"]
    assert rates.acceleration["phi1"] == pytest.approx(1.0 / r, rel=1e-15)
    assert rates.platform_yaw_acceleration == pytest.approx(1.0 / d, rel=1e-15)
    assert set(rates.velocity) == {"phi1", "phi2", *arm}
