"""The scenario key ``ground`` (floor height): parsing, one-line errors, the start against the
floor, and its record in the resolved scenario and plan folders."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from mmplan import Scenario, ScenarioError, builtin_scenarios, get_robot, load_scenario
from mmplan.robot.ground import floor_clearances
from mmplan.scenario.from_problem import scenario_from_problem

BASE: dict[str, Any] = {
    "name": "unit",
    "robot": "youbot-3r",
    "start": [0, 0, 0, 0, 0, 0, -0.17, 0.35],
    "goal": {"position": [1.5, 0.5, 0.3], "tolerance": 0.001},
    "planner": {"method": "extended-jacobian", "t_max": 10},
}
#: A youbot-3r start with the arm bent down: its lowest arm sphere 0.0821 m below z = 0.
LOW = [0, 0, 0, 0, 0, 0, 0.5, 0.35]


def scenario(**changes: Any) -> Scenario:
    data = copy.deepcopy(BASE)
    data.update(changes)
    return Scenario.from_dict(data, "s.yaml")


def test_default_floor_is_z0_and_null_removes_it() -> None:
    assert scenario().scene.ground == 0.0
    assert scenario(ground=None).scene.ground is None
    assert scenario(ground=-0.25).scene.ground == -0.25
    lowered = scenario(ground=-1).scene.ground  # an integer is a height too
    assert lowered == -1.0 and isinstance(lowered, float)
    for name in builtin_scenarios():  # every built-in scenario keeps the default floor
        assert load_scenario(name).scene.ground == 0.0, name


@pytest.mark.parametrize(("value", "problem"), [
    (True, "valid number"),
    ("0.1", "valid number"),
    ([0.0], "valid number"),
    ({"z": 0}, "valid number"),
    (float("nan"), "finite"),
    (float("inf"), "finite"),
    (100.5, "less than or equal to 100"),
    (-1e9, "greater than or equal to -100"),
])
def test_bad_ground_is_a_one_line_error_naming_the_key(value: Any, problem: str) -> None:
    with pytest.raises(ScenarioError) as err:
        scenario(ground=value)
    message = str(err.value)
    assert "\n" not in message and message.startswith("s.yaml: ground: "), message
    assert problem in message and len(message) < 300


def test_start_below_the_floor_is_rejected_like_a_collision() -> None:
    robot = get_robot("youbot-3r")
    below = float(floor_clearances(robot, np.array(LOW, float), 0.0).min())
    points = robot.collision_points(np.array(LOW, float))  # independent: the arm spheres
    arm = [i for i, c in enumerate(robot.collision) if c.body != "platform"]
    assert below == pytest.approx(float(np.min(points[arm, 2] - robot.collision_radii[arm])))
    assert below == pytest.approx(-0.0821, abs=1e-4)
    with pytest.raises(ScenarioError) as err:
        scenario(start=LOW)
    message = str(err.value)
    assert "\n" not in message and message.startswith("s.yaml: start: in collision with the floor")
    assert f"{-below:.6g} m below the floor z = 0" in message and "(on link3)" in message
    # lowered past it, or removed: accepted; a floor raised above the arm at rest: rejected
    assert scenario(start=LOW, ground=-0.1).scene.ground == -0.1
    assert scenario(start=LOW, ground=None).scene.ground is None
    with pytest.raises(ScenarioError, match="in collision with the floor"):
        scenario(ground=0.3)
    # mmplan check loads plans without start checks: the checker reports it instead
    assert Scenario.from_dict({**BASE, "start": LOW}, check_start=False).scene.ground == 0.0


@pytest.mark.parametrize("ground", [0.0, -0.5, None])
def test_resolved_scenario_records_the_floor(ground: float | None, tmp_path: Path) -> None:
    sc = scenario(ground=ground)
    resolved = sc.resolved_dict()
    assert "ground" in resolved and resolved["ground"] == ground
    path = tmp_path / "scenario.yaml"
    path.write_text(sc.to_yaml())
    assert yaml.safe_load(path.read_text())["ground"] == ground
    assert load_scenario(path).scene.ground == ground
    # a problem built in Python records it too (write_plan without a scenario)
    assert scenario_from_problem(sc.build()).scene.ground == ground
