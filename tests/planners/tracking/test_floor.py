"""The floor in the trackers: a half-space term of the obstacle potential V_2 (pseudoinverse),
in the planners' clearance (stop rule); the paper plans are unchanged by it."""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np
import pytest

import mmplan
from mmplan import Scenario, load_scenario
from mmplan.planners.tracking.potentials import barrier_term, floor_distances, obstacle_potential
from mmplan.robot.ground import ground_sphere_indices
from mmplan.verify.check import check

#: youbot-4r with the arm folded low (wrist near the floor) tracking a line that ends 5 mm
#: above the floor: without the floor term the wrist (link3) dips 2.2 mm below it.
ARM = [0.0, 0.4, 1.6, 1.2]


def low_line(ground: float | None, end_z: float = 0.005) -> dict[str, Any]:
    robot = mmplan.get_robot("youbot-4r")
    q0 = [0.0] * 5 + ARM
    ee = robot.ee_position(np.array(q0))
    return {
        "name": "low-line", "robot": "youbot-4r", "start": q0, "ground": ground,
        "goal": {"path": {"kind": "line", "start": [float(v) for v in ee],
                          "velocity": [0.0, 0.03, (end_z - float(ee[2])) / 6.0],
                          "duration": 6.0}, "tolerance": 0.001},
        "limits": {"torque": "unlimited", "velocity": None, "acceleration": None},
        "planner": {"method": "pseudoinverse", "dt": 0.01, "gain": 2.0, "beta1": 0.5,
                    "beta2": 1.0, "k1": 0.002, "d0": 0.15},
    }


def plan_and_check(data: dict[str, Any]) -> tuple[mmplan.PlanResult, mmplan.CheckReport]:
    sc = Scenario.from_dict(data)
    result = mmplan.get_planner(sc.method)().plan(sc.build())
    judged = Scenario.from_dict({**data, "ground": 0.0}, check_start=False).build()
    return result, check(result.trajectory, judged, status=result.status)


def lowest_arm_sphere(result: mmplan.PlanResult) -> float:
    """Independent of the checker: the arm spheres' heights from the robot's FK."""
    robot = mmplan.get_robot("youbot-4r")
    arm = [i for i, c in enumerate(robot.collision) if c.body != "platform"]
    z = np.array([robot.collision_points(x)[arm, 2] - robot.collision_radii[arm]
                  for x in result.trajectory.q])
    return float(z.min())


def test_the_floor_term_keeps_the_wrist_above_the_floor() -> None:
    without, report_without = plan_and_check(low_line(None))
    assert without.status.value == "reached"
    assert lowest_arm_sphere(without) < -0.002  # the wrist goes through the floor
    assert any(f.startswith("floor: clearance") for f in report_without.failures())
    with_floor, report = plan_and_check(low_line(0.0))
    assert with_floor.status.value == "reached" and report.ok, report.failures()
    assert lowest_arm_sphere(with_floor) >= 0.0
    assert report.min_floor_clearance_m == pytest.approx(0.005, abs=2e-4)  # the path's end


def test_a_path_through_the_floor_stops_at_contact() -> None:
    """The end effector itself must go 3 cm below the floor: the tracker stops at the
    contact (its clearance includes the floor) instead of reporting the path as tracked."""
    result, report = plan_and_check(low_line(0.0, end_z=-0.03))
    assert result.status.value != "reached" and "collision" in result.message
    assert report.min_floor_clearance_m is not None and report.min_floor_clearance_m > -0.01
    unbounded, _ = plan_and_check(low_line(None, end_z=-0.03))
    assert unbounded.status.value == "reached"


@pytest.mark.parametrize("name", ["diffdrive3-track", "omni3-impedance"])
def test_paper_tracking_plans_are_unchanged_by_the_floor(name: str) -> None:
    sc = load_scenario(name)
    assert sc.scene.ground == 0.0
    planner = mmplan.get_planner(sc.method)()
    with_floor = planner.plan(sc.build())
    data = {**sc.resolved_dict(), "ground": None}
    without = planner.plan(Scenario.from_dict(data).build())
    assert with_floor.status.value == without.status.value == "reached"
    assert np.array_equal(with_floor.trajectory.q, without.trajectory.q)
    report = check(with_floor.trajectory, sc.build(), status=with_floor.status)
    assert report.min_floor_clearance_m is not None and report.min_floor_clearance_m > 0.5
    assert report.ok, report.failures()


def test_floor_potential_is_the_barrier_of_each_ground_sphere_height() -> None:
    """V_2 with the floor minus V_2 without it = sum over the ground spheres of the barrier of
    their height above the floor (computed here from the numeric FK), and its gradient matches
    central differences."""
    robot = mmplan.get_robot("youbot-4r")
    s = robot.symbols
    k1, d0, d_floor, h = 0.002, 0.15, 0.005, 0.02
    V, _ = obstacle_potential(s.collision_points, robot.collision_radii, (), k1, d0, d_floor,
                              floor_distances(robot, h))
    fn = ca.Function("V", [s.q], [V, ca.gradient(V, s.q)])
    barrier = ca.Function("b", [d := ca.SX.sym("d")], [barrier_term(d, k1, d0, d_floor)])
    idx = list(ground_sphere_indices(robot))
    rng = np.random.default_rng(5)
    active = 0
    for _ in range(5):
        q = np.r_[rng.uniform(-1, 1, 5), rng.uniform([-1, 0.3, 1.0, 0.5], [1, 0.8, 1.6, 1.5])]
        heights = robot.collision_points(q)[idx, 2] - robot.collision_radii[idx] - h
        expected = sum(float(barrier(x)) for x in heights)
        active += expected > 0
        value, grad = (np.asarray(v, float).ravel() for v in fn(q))
        assert value[0] == pytest.approx(expected, rel=1e-9, abs=1e-15)
        eps = 1e-6
        fd = [(float(fn(q + eps * e)[0]) - float(fn(q - eps * e)[0])) / (2 * eps)
              for e in np.eye(robot.n)]
        assert np.allclose(grad, fd, rtol=1e-5, atol=1e-7)
    assert active >= 3  # the floor acts at most of these configurations
    assert floor_distances(robot, None) == []
