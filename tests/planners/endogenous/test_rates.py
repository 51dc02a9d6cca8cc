"""Rate limits in the endogenous planner (planner.py, output.py): the plan is re-timed
uniformly, t -> c t, with the smallest c that keeps every limit; beyond t_max it is infeasible.

car-rtr-steer60 (horizon 1 s) peaks at 27.4 m/s platform speed, psi at 8.6 rad/s and
69 rad/s^2.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mmplan.planners import get_planner
from mmplan.problem import Problem
from mmplan.robot.limits import RateLimits
from mmplan.scenario.loader import load_scenario
from mmplan.time_scaling.rates import RateModel
from mmplan.trajectory import PlanResult, Status

NAME = "car-rtr-steer60"


def plan(rates: RateLimits | None, **settings: object) -> tuple[Problem, PlanResult]:
    problem = load_scenario(NAME).build()
    robot = problem.robot
    if rates is not None:
        robot = robot.with_limits(dataclasses.replace(robot.limits, rates=rates))
    new = problem.settings.model_copy(update=settings) if settings else problem.settings
    problem = dataclasses.replace(problem, robot=robot, settings=new)
    return problem, get_planner("endogenous")().plan(problem)


@pytest.fixture(scope="module")
def base() -> PlanResult:
    return plan(None)[1]


def test_stretched_plan_keeps_the_path_and_every_limit(base: PlanResult) -> None:
    """Platform 2 m/s and psi 20 rad/s^2: c = max(27.4 / 2, sqrt(69 / 20)) = 13.7; same q
    samples, t, dq, ddq and the controls scaled by c, 1/c, 1/c^2, 1/c."""
    rates = RateLimits(acceleration={"psi": 20.0}, platform_speed=2.0)
    problem, result = plan(rates)
    assert result.status is Status.REACHED, result.message
    a, b = base.trajectory, result.trajectory
    c = result.info["time_scale"]
    peak = float(np.hypot(a.dq[:, 0], a.dq[:, 1]).max())
    assert c >= peak / 2.0 and c == pytest.approx(peak / 2.0, rel=2e-2)
    assert result.info["horizon_s"] == pytest.approx(c * 1.0)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_allclose(b.t, c * a.t)
    np.testing.assert_allclose(b.dq, a.dq / c)
    np.testing.assert_allclose(b.ddq, a.ddq / c**2)
    np.testing.assert_allclose(b.extra["u1"], a.extra["u1"] / c)
    np.testing.assert_allclose(result.artifacts["lambda"], base.artifacts["lambda"] / c)
    model = RateModel.of(problem.robot)
    assert model.first_violation(b.t, b.dq, b.ddq, b.q) is None
    assert np.hypot(b.dq[:, 0], b.dq[:, 1]).max() <= 2.0 * (1 + 1e-9)
    assert "re-timed x" in result.message


def test_acceleration_alone_needs_the_square_root(base: PlanResult) -> None:
    """An acceleration limit k times below the peak stretches by sqrt(k) (2 here)."""
    peak = float(np.abs(base.trajectory.ddq[:, 3]).max())
    _, result = plan(RateLimits(acceleration={"psi": peak / 4.0}))
    assert result.status is Status.REACHED
    assert result.info["time_scale"] == pytest.approx(2.0, rel=2e-2)


def test_limits_that_hold_change_nothing(base: PlanResult) -> None:
    _, result = plan(RateLimits(platform_speed=100.0))
    assert result.info["time_scale"] == 1.0
    np.testing.assert_array_equal(result.trajectory.t, base.trajectory.t)


def test_horizon_beyond_t_max_is_infeasible() -> None:
    """c = 27.4 / 0.2 = 137 s > t_max = 60 s: infeasible, saying so (the stretched plan, within
    the limits, is returned)."""
    _, result = plan(RateLimits(platform_speed=0.2), t_max=60.0)
    assert result.status is Status.INFEASIBLE
    assert "above t_max = 60 s" in result.message
    assert result.trajectory.t[-1] > 60.0
