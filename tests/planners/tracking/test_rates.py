"""Rate limits in the path trackers (tracking/result.py): a tracker cannot slow its path down, so
a path that needs more than a limit ends ``infeasible``, naming the quantity, time and limit."""

from __future__ import annotations

import dataclasses

import pytest

from mmplan.planners import get_planner
from mmplan.problem import Problem
from mmplan.robot.limits import RateLimits
from mmplan.scenario.loader import load_scenario
from mmplan.trajectory import PlanResult, Status


def plan(name: str, rates: RateLimits) -> tuple[Problem, PlanResult]:
    scenario = load_scenario(name)
    problem = scenario.build()
    robot = problem.robot
    problem = dataclasses.replace(
        problem, robot=robot.with_limits(dataclasses.replace(robot.limits, rates=rates))
    )
    return problem, get_planner(scenario.method)().plan(problem)


def test_pseudoinverse_within_the_limits_is_reached() -> None:
    """diffdrive3-track peaks at 0.16 m/s, theta1 0.93 rad/s: limits above that hold."""
    _, result = plan("diffdrive3-track", RateLimits(velocity={"theta1": 1.0},
                                                    platform_speed=0.2))  # fmt: skip
    assert result.status is Status.REACHED, result.message
    assert result.info["rate_limits_held"] is True


def test_pseudoinverse_path_faster_than_a_joint_limit_is_infeasible() -> None:
    """theta1 needs 0.93 rad/s (at the obstacle): a 0.5 rad/s limit makes the plan infeasible,
    the message says which joint, when and by how much; the whole trajectory is returned."""
    _, result = plan("diffdrive3-track", RateLimits(velocity={"theta1": 0.5}))
    assert result.status is Status.INFEASIBLE
    assert result.message.startswith("the path needs more than the rate limits: joint theta1 "
                                     "needs ")  # fmt: skip
    assert "rad/s at t = " in result.message and "limit 0.5" in result.message
    assert result.trajectory.t[-1] == pytest.approx(30.0)


def test_platform_speed_of_the_path_itself_is_infeasible() -> None:
    """The end effector moves at 0.1 m/s, the platform with it: a 0.05 m/s platform limit
    breaks from the start."""
    _, result = plan("diffdrive3-track", RateLimits(platform_speed=0.05))
    assert result.status is Status.INFEASIBLE
    assert "platform speed needs" in result.message and "m/s at t = 0." in result.message


def test_impedance_acceleration_limit_is_checked_on_the_finite_differences() -> None:
    """omni3-impedance: qa1 accelerates at up to 570 rad/s^2 (central differences of dq)."""
    _, result = plan("omni3-impedance", RateLimits(acceleration={"qa1": 100.0}))
    assert result.status is Status.INFEASIBLE
    assert "joint qa1 needs" in result.message and "rad/s^2" in result.message
    _, ok = plan("omni3-impedance", RateLimits(acceleration={"qa1": 1000.0}))
    assert ok.status is Status.REACHED
