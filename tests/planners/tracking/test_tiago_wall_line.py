"""Built-in tiago-wall-line: TIAGo draws a line on a wall by pseudoinverse tracking, with the
robot's own (URDF) rate limits. Skipped without example-robot-data."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from mmplan.planners import get_planner
from mmplan.scenario.loader import Scenario, builtin_scenarios, load_scenario
from mmplan.trajectory import Status
from mmplan.verify.check import check
from tests.robot.urdf_oracle import robot_data_dir

WALL_X = 0.8  # the wall's face


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    robot_data_dir()  # skips without example-robot-data
    return load_scenario("tiago-wall-line")


def test_reached_and_checked_with_the_urdf_rate_limits(scenario: Scenario) -> None:
    problem = scenario.build()
    robot = problem.robot
    assert "torso_lift_joint" not in robot.coordinates  # locked
    assert robot.limits.rates.velocity["arm_1_joint"] == pytest.approx(2.7)  # from the URDF
    result = get_planner(scenario.method)().plan(problem)
    assert result.status is Status.REACHED, result.message
    assert result.info["rate_limits_held"] is True
    tr = result.trajectory
    assert tr.t[-1] == pytest.approx(12.0)
    # the pen tip stays on the wall's face, the hand off the wall, the body off itself
    assert np.abs(tr.ee[:, 0] - WALL_X).max() < 1e-3
    assert result.info["min_clearance_m"] > 0.0
    report = check(tr, problem, result.status.value)
    assert report.failures() == []
    assert report.min_self_clearance_m is not None and report.min_self_clearance_m > 0.0
    # every velocity within its URDF limit, recomputed here from the dq columns
    for name, limit in robot.limits.rates.velocity.items():
        assert np.abs(tr.dq[:, robot.index(name)]).max() <= limit, name


def test_with_the_torso_free_the_path_breaks_its_rate_limit(scenario: Scenario) -> None:
    """Why the torso is locked: free (starting at the locked value), the tracker drives it at
    more than its URDF limit of 0.07 m/s, and the plan is infeasible, naming the joint."""
    data = yaml.safe_load(builtin_scenarios()["tiago-wall-line"].read_text())
    del data["robot"]["locked"]
    data["start"]["torso_lift_joint"] = 0.25
    problem = Scenario.from_dict(data, "tiago-wall-line-free-torso").build()
    result = get_planner("pseudoinverse")().plan(problem)
    assert result.status is Status.INFEASIBLE, result.message
    assert "torso_lift_joint" in result.message and "limit 0.07" in result.message
