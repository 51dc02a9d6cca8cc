"""The floor in the endogenous planner (``mmplan.planners.endogenous.floor``): a second phase
with the floor output lifts a plan that goes through the floor; the paper plans are unchanged."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
import yaml

import mmplan
from mmplan import Scenario, builtin_scenarios, load_scenario
from mmplan.planners.endogenous.floor import FLOOR_MARGIN, floor_verdict, independent
from mmplan.trajectory import Status
from mmplan.verify.check import check

#: car-rtr from the arm (x1, x2, x3) = (0, 0.36, -0.261) to a goal 0.29 m high: the plain
#: theta-iteration ends with the forearm 0.17 m below the floor.
X0 = [0.0, 0.36, -0.261]
GOAL = [0.636, 0.253, 0.289]


def scenario(ground: float | None) -> dict[str, Any]:
    data = yaml.safe_load(builtin_scenarios()["car-rtr-free"].read_text())
    data["start"] = data["start"][:4] + X0
    data["goal"] = {"position": GOAL, "tolerance": 1e-4}
    data["ground"] = ground
    return data


def forearm_low(result: mmplan.PlanResult) -> float:
    """Independent of the planner and checker: the forearm spheres' lowest point [m]."""
    robot = mmplan.get_robot("car-rtr")
    fore = [i for i, c in enumerate(robot.collision) if c.body == "forearm"]
    return float(min((robot.collision_points(q)[fore, 2] - robot.collision_radii[fore]).min()
                     for q in result.trajectory.q))


def plan(data: dict[str, Any]) -> tuple[mmplan.PlanResult, mmplan.Problem]:
    sc = Scenario.from_dict(data)
    problem = sc.build()
    return mmplan.get_planner(sc.method)().plan(problem), problem


def test_floor_output_lifts_the_forearm_off_the_floor() -> None:
    without, _ = plan(scenario(None))
    assert without.status is Status.REACHED and forearm_low(without) < -0.17
    assert "min_floor_clearance_m" not in without.info
    result, problem = plan(scenario(0.0))
    assert result.status is Status.REACHED, result.message
    assert "after lifting the arm off the floor" in result.message
    low = forearm_low(result)
    assert low >= 0 and low == pytest.approx(FLOOR_MARGIN, abs=2e-4)
    assert result.info["min_floor_clearance_m"] == pytest.approx(low, abs=1e-9)
    assert result.info["final_error_m"] < 1e-4
    report = check(result.trajectory, problem, status=result.status)
    assert report.ok, report.failures()


@pytest.mark.parametrize("name", ["car-rtr-free", "car-rtr-steer60", "car-rtr-steer30"])
def test_paper_plans_are_unchanged_by_the_floor(name: str) -> None:
    sc = load_scenario(name)
    planner = mmplan.get_planner(sc.method)()
    with_floor = planner.plan(sc.build())
    without = planner.plan(Scenario.from_dict({**sc.resolved_dict(), "ground": None}).build())
    assert with_floor.status is Status.REACHED and without.status is Status.REACHED
    assert np.array_equal(with_floor.trajectory.q, without.trajectory.q)
    assert with_floor.info["min_floor_clearance_m"] > 0.9


def test_a_reached_plan_below_the_floor_is_infeasible() -> None:
    sc = load_scenario("car-rtr-free")
    result = mmplan.get_planner(sc.method)().plan(sc.build())
    problem = sc.build()
    low = forearm_low(result)
    raised = dataclasses.replace(problem, scene=dataclasses.replace(problem.scene,
                                                                    ground=low + 0.1))
    traj = result.trajectory
    status, message, info = floor_verdict(raised, traj.q, traj.t, Status.REACHED, "ok")
    assert status is Status.INFEASIBLE and "0.1 m below the floor" in message
    assert info["min_floor_clearance_m"] == pytest.approx(-0.1, abs=1e-9)
    assert floor_verdict(problem, traj.q, traj.t, Status.REACHED, "ok")[0] is Status.REACHED
    none = dataclasses.replace(problem, scene=dataclasses.replace(problem.scene, ground=None))
    assert floor_verdict(none, traj.q, traj.t, Status.REACHED, "ok") == (Status.REACHED, "ok",
                                                                          {})


def test_independent_rows() -> None:
    rng = np.random.default_rng(2)
    J = rng.normal(size=(4, 11))
    assert independent(J, rng.normal(size=11))
    assert not independent(J, 0.3 * J[1] - 2.0 * J[3])
