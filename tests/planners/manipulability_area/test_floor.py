"""The floor in the manipulability-area planner: a path whose IK arm configurations reach
below it is infeasible; the paper plan keeps 0.29 m clear of the floor and is unchanged."""

from __future__ import annotations

import numpy as np
import pytest

import mmplan
from mmplan import Scenario, load_scenario
from mmplan.trajectory import Status


def plan(ground: float | None) -> mmplan.PlanResult:
    sc = Scenario.from_dict({**load_scenario("wall-segment").resolved_dict(), "ground": ground})
    return mmplan.get_planner(sc.method)().plan(sc.build())


def lowest_link3(result: mmplan.PlanResult) -> float:
    """Independent of the planner: link3's lowest sphere over the plan, by the robot's FK."""
    robot = mmplan.get_robot("base-6dof")
    link3 = [i for i, c in enumerate(robot.collision) if c.body == "link3"]
    return float(min((robot.collision_points(q)[link3, 2] - robot.collision_radii[link3]).min()
                     for q in result.trajectory.q))


def test_paper_plan_keeps_clear_and_is_unchanged() -> None:
    with_floor, without = plan(0.0), plan(None)
    assert with_floor.status is Status.REACHED and without.status is Status.REACHED
    assert np.array_equal(with_floor.trajectory.q, without.trajectory.q)
    low = lowest_link3(with_floor)
    assert low > 0.29 and with_floor.info["min_floor_clearance_m"] == pytest.approx(low)
    assert without.info["min_floor_clearance_m"] is None


def test_a_path_through_a_raised_floor_is_infeasible() -> None:
    low = lowest_link3(plan(0.0))  # 0.2944 m
    result = plan(round(low + 0.005, 4))  # the floor 5 mm above the arm's lowest point
    assert result.status is Status.INFEASIBLE
    assert "the arm reaches" in result.message and "below the floor" in result.message
    assert result.info["min_floor_clearance_m"] == pytest.approx(low - round(low + 0.005, 4))
