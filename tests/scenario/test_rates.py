"""Scenario limits.velocity / limits.acceleration: overrides of the robot's defaults, errors,
resolved output."""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import pytest
import yaml

from mmplan import InputError, Scenario, ScenarioError, get_robot, load_scenario
from mmplan.scenario.rates import SCENARIO_SOURCE
from tests.eta_planner import METHOD

BASE: dict[str, Any] = {
    "name": "rates",
    "robot": "youbot-3r",
    "start": [0, -0.5, 1.5708, 0, 0, 0, -0.17, 0.35],
    "goal": {"position": [3.5, 4.0, 0.16]},
    "planner": {"method": METHOD, "eta": [0.1, 0.0, 0.0, 0.0, 0.0]},
}
DEFAULT = get_robot("youbot-3r").limits.rates


def scenario(limits: Any, robot: str | None = None) -> Scenario:
    data = copy.deepcopy(BASE)
    data["limits"] = limits
    if robot == "car-rtr":
        data.update(robot=robot, start=[0.0] * 7,
                    planner={"method": METHOD, "eta": [0.0] * 5})
    return Scenario.from_dict(data, "s.yaml")


def test_no_rate_keys_keep_the_robot_defaults() -> None:
    assert scenario({"torque": "unlimited"}).robot.limits.rates == DEFAULT
    assert Scenario.from_dict(BASE).robot.limits.rates == DEFAULT


def test_keys_given_override_and_the_rest_keeps_the_defaults() -> None:
    rates = scenario({
        "velocity": {"coordinates": {"q1": 1.0, "phi1": 10}, "platform_linear": 0.5},
        "acceleration": {"platform_angular": 3.0},
    }).robot.limits.rates
    assert rates.velocity == {**DEFAULT.velocity, "q1": 1.0, "phi1": 10.0}
    assert rates.platform_speed == 0.5
    assert rates.platform_yaw_rate == DEFAULT.platform_yaw_rate  # not given: default
    assert rates.acceleration == DEFAULT.acceleration
    assert rates.platform_acceleration == DEFAULT.platform_acceleration
    assert rates.platform_yaw_acceleration == 3.0
    for key in ("velocity.q1", "velocity.phi1", "platform_speed", "platform_yaw_acceleration"):
        assert rates.sources[key] == SCENARIO_SOURCE
    assert rates.sources["velocity.q2"] == DEFAULT.sources["velocity.q2"]


def test_null_turns_one_limit_off_and_a_null_kind_turns_all_off() -> None:
    rates = scenario({"velocity": {"coordinates": {"q1": None}, "platform_linear": None}}
                     ).robot.limits.rates
    assert "q1" not in rates.velocity and "velocity.q1" not in rates.sources
    assert rates.velocity["q2"] == DEFAULT.velocity["q2"]
    assert math.isinf(rates.platform_speed) and "platform_speed" not in rates.sources
    assert rates.platform_yaw_rate == DEFAULT.platform_yaw_rate
    off = scenario({"velocity": None}).robot.limits.rates
    assert off.velocity == {} and math.isinf(off.platform_speed)
    assert math.isinf(off.platform_yaw_rate)
    assert off.acceleration == DEFAULT.acceleration  # the other kind untouched
    both = scenario({"velocity": None, "acceleration": None}).robot.limits.rates
    assert not both.any
    assert not any(k.startswith(("velocity.", "acceleration.", "platform_"))
                   for k in both.sources)


def test_limits_on_a_robot_without_defaults() -> None:
    rates = scenario({"velocity": {"coordinates": {"psi": 0.5}}}, robot="car-rtr"
                     ).robot.limits.rates
    assert rates.velocity == {"psi": 0.5}  # a car's steering angle is bounded by name
    assert math.isinf(rates.platform_speed) and not rates.acceleration


@pytest.mark.parametrize(("limits", "field", "problem"), [
    ({"velocity": {"coordinates": {"q9": 1.0}}}, "limits.velocity.coordinates.q9",
     "unknown coordinate 'q9' of youbot-3r; valid: phi1, phi2, q1, q2, q3"),
    ({"acceleration": {"coordinates": {"x": 1.0}}}, "limits.acceleration.coordinates.x",
     "x is a platform pose coordinate; bound the platform with acceleration.platform_linear"),
    ({"velocity": {"coordinates": {"theta": 1.0}}}, "limits.velocity.coordinates.theta",
     "platform_angular (theta)"),
    ({"velocity": {"coordinates": {"q1": -1.5}}}, "limits.velocity.coordinates.q1",
     "must be > 0, got -1.5; null turns the limit off"),
    ({"velocity": {"platform_linear": 0}}, "limits.velocity.platform_linear",
     "must be > 0, got 0"),
    ({"acceleration": {"platform_angular": float("nan")}}, "limits.acceleration.platform_angular",
     "expected a finite number, got nan"),
    ({"velocity": {"platform_linear": float("inf")}}, "limits.velocity.platform_linear",
     "expected a finite number, got inf"),
    ({"velocity": {"coordinates": {"q1": "fast"}}}, "limits.velocity.coordinates.q1",
     "valid number, got 'fast'"),
    ({"velocity": {"platform_linear": "0.8"}}, "limits.velocity.platform_linear",
     "valid number, got '0.8'"),
    ({"velocity": {"coordinates": {"q1": True}}}, "limits.velocity.coordinates.q1",
     "valid number, got True"),
    ({"velocity": {"platform_speed": 0.8}}, "limits.velocity.platform_speed", "unknown key"),
    ({"velocity": 0.8}, "limits.velocity", "expected {coordinates: {name: bound}, "
                                           "platform_linear: bound, platform_angular: bound} "
                                           "or null, got 0.8"),
    ({"velocity": {"coordinates": [1.0]}}, "limits.velocity.coordinates",
     "valid dictionary, got [1.0]"),
    ({"velocity": {"platform_linear": 2e6}}, "limits.velocity.platform_linear", "out of range"),
])
def test_bad_rate_limits_name_the_key_path(limits: Any, field: str, problem: str) -> None:
    with pytest.raises(ScenarioError) as info:
        scenario(limits)
    assert info.value.field == field
    assert problem in info.value.problem
    assert str(info.value).startswith(f"s.yaml: {field}: ")
    assert "\n" not in str(info.value)
    assert info.value.exit_code == 2 and isinstance(info.value, InputError)


def test_resolved_scenario_holds_the_effective_limits_and_reloads_to_them(
        tmp_path: Path) -> None:
    sc = scenario({"velocity": {"coordinates": {"q1": None, "q2": 1.0}, "platform_angular": 2.0},
                   "acceleration": None})
    limits = sc.resolved_dict()["limits"]
    assert limits["velocity"] == {
        "coordinates": {"phi1": 16.0, "phi2": 16.0, "q1": None, "q2": 1.0, "q3": math.pi / 2},
        "platform_linear": 0.8, "platform_angular": 2.0}
    assert limits["acceleration"] is None
    path = tmp_path / "resolved.yaml"
    path.write_text(sc.to_yaml())
    again = load_scenario(path)
    assert again.robot.limits.rates.velocity == sc.robot.limits.rates.velocity
    for attr in ("acceleration", "platform_speed", "platform_yaw_rate", "platform_acceleration",
                 "platform_yaw_acceleration"):
        assert getattr(again.robot.limits.rates, attr) == getattr(sc.robot.limits.rates, attr)
    assert again.resolved_dict() == sc.resolved_dict()
    defaults = Scenario.from_dict(BASE).resolved_dict()["limits"]
    assert defaults["acceleration"] == {
        "coordinates": {"phi1": 20.0, "phi2": 20.0, "q1": None, "q2": None, "q3": None},
        "platform_linear": 1.0, "platform_angular": 6.25}
    assert yaml.safe_load(Scenario.from_dict(BASE).to_yaml())["limits"] == defaults


def test_robot_without_limits_resolves_to_null() -> None:
    limits = scenario({}, robot="car-rtr").resolved_dict()["limits"]
    assert limits["velocity"] is None and limits["acceleration"] is None
