"""Manipulability areas on a general arm: TIAGo's 7 joints by numeric IK (built-in
tiago-wall-segment), a differential drive that moves only along its heading. Skipped
without example-robot-data."""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest

from mmplan.errors import InputError
from mmplan.planners import get_planner
from mmplan.planners.manipulability_area.settings import ManipulabilityAreaSettings
from mmplan.problem import Problem
from mmplan.robot.library import get_robot
from mmplan.scenario.loader import load_scenario
from mmplan.task import DrawSegment
from mmplan.trajectory import PlanResult, Status
from mmplan.verify.check import check
from tests.robot.urdf_oracle import robot_data_dir


@pytest.fixture(scope="module")
def planned() -> tuple[Problem, PlanResult]:
    robot_data_dir()  # skips without example-robot-data
    problem = load_scenario("tiago-wall-segment").build()
    return problem, get_planner("manipulability-area")().plan(problem)


def test_reached_and_checked(planned: tuple[Problem, PlanResult]) -> None:
    problem, result = planned
    assert result.status is Status.REACHED, result.message
    assert result.info["path_kind"] == "straight" and result.info["path_length_m"] > 0.1
    assert result.info["manipulability_min"] >= result.info["manipulability_threshold"]
    report = check(result.trajectory, problem, result.status.value)
    assert report.failures() == []


def test_pen_on_the_segment_and_along_the_wall_normal(
        planned: tuple[Problem, PlanResult]) -> None:
    """By the robot's forward kinematics (not the IK's residual): the pen tip on the segment
    at every row, the hand's axis (arm_7_link z) into the wall (-normal), joints within their
    limits and continuous from row to row."""
    problem, result = planned
    robot, task, tr = problem.robot, problem.task, result.trajectory
    assert isinstance(task, DrawSegment)
    s = robot.symbols
    pose = ca.Function("pose", [s.q], [s.ee_position, s.ee_rotation[:, 2]])
    p, z = (np.asarray(v, dtype=float).T for v in pose.map(len(tr.q))(tr.q.T))
    a, b = np.asarray(task.start), np.asarray(task.end)
    np.testing.assert_allclose(p, a + tr.t[:, None] * (b - a), atol=1e-5)
    np.testing.assert_allclose(z, np.tile(-np.asarray(task.normal), (len(z), 1)), atol=1e-5)
    arm = list(robot.arm_indices)
    assert np.all(tr.q[:, arm] >= robot.limits.joint_min - 1e-12)
    assert np.all(tr.q[:, arm] <= robot.limits.joint_max + 1e-12)
    assert np.abs(np.diff(tr.q[:, arm], axis=0)).max() <= 0.2


def test_the_base_drives_along_its_heading(planned: tuple[Problem, PlanResult]) -> None:
    """Differential drive: x and theta constant, y along the heading, and both wheels turn
    by the distance over the wheel radius (0.0985 m, derived from the URDF)."""
    problem, result = planned
    q, robot = result.trajectory.q, problem.robot
    np.testing.assert_allclose(q[:, 2], np.pi / 2, atol=1e-12)
    np.testing.assert_allclose(q[:, 0], q[0, 0], atol=1e-12)
    travelled = q[:, 1] - q[0, 1]
    for wheel in ("wheel_left_joint", "wheel_right_joint"):
        k = robot.index(wheel)
        np.testing.assert_allclose(q[:, k] - q[0, k], travelled / 0.0985, atol=1e-6)
    residual = max(float(np.abs(robot.pfaffian(qk) @ dqk).max())
                   for qk, dqk in zip(q, result.trajectory.dq, strict=True))
    assert residual < 1e-9


def test_a_base_that_would_move_sideways_is_refused() -> None:
    """Heading by default faces the wall: a differential drive cannot follow the wall then;
    the planner says so instead of writing a sideways motion."""
    robot_data_dir()
    problem = load_scenario("tiago-wall-segment").build()
    settings = problem.settings
    assert isinstance(settings, ManipulabilityAreaSettings)
    problem = dataclasses.replace(
        problem, settings=settings.model_copy(update={"heading": None, "layers": 5}))
    result = get_planner("manipulability-area")().plan(problem)
    assert result.status is Status.INFEASIBLE
    assert "along the heading" in result.message and "omnidirectional" in result.message


def test_arms_without_a_tool_pose_or_with_limits_off_are_input_errors() -> None:
    scenario = load_scenario("wall-segment")
    problem = scenario.build()
    small = dataclasses.replace(problem, robot=get_robot("youbot-3r"), start=np.zeros(8))
    with pytest.raises(InputError, match=">= 6 joints"):
        get_planner("manipulability-area")().plan(small)
    robot_data_dir()
    tiago = load_scenario("tiago-wall-segment").build()
    settings = tiago.settings
    assert isinstance(settings, ManipulabilityAreaSettings)
    off = dataclasses.replace(
        tiago, settings=settings.model_copy(update={"respect_joint_limits": False}))
    with pytest.raises(InputError, match="respect_joint_limits"):
        get_planner("manipulability-area")().plan(off)


def test_aligning_rotation(rng: np.random.Generator) -> None:
    """_aligning(a, b): a proper rotation taking a to b, also for b = a and b = -a."""
    from mmplan.planners.manipulability_area.arms import _aligning

    pairs = [tuple(v / np.linalg.norm(v) for v in rng.normal(size=(2, 3))) for _ in range(20)]
    a0 = np.array([0.0, 0.0, 1.0])
    pairs += [(a0, a0), (a0, -a0), (np.array([1.0, 0.0, 0.0]), np.array([-1.0, 0.0, 0.0]))]
    for a, b in pairs:
        R = _aligning(a, b)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(R @ a, b, atol=1e-12)
