"""Velocity and acceleration limits in the extended-Jacobian planner (time_scaling.py).

With rate limits the plan is always re-timed: time mode (torque limits with obstacles, or no
torque control) scales the free generator path under efforts and rates together; feedback
mode re-times its virtual-control plan. Limits here are youBot-like: platform 0.8 m/s (KUKA's
published speed), wheels 16 rad/s (0.8 m/s at r = 0.05 m), arm joints 1.57 rad/s.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.problem import Problem
from mmplan.robot.limits import RateLimits
from mmplan.scenario.loader import load_scenario
from mmplan.time_scaling.rates import RateModel
from mmplan.trajectory import PlanResult, Status
from mmplan.verify.check import check


def youbot_rates(coordinates: tuple[str, ...], **more: object) -> RateLimits:
    arm = {c: 1.57 for c in coordinates if c.startswith("q")}
    return RateLimits(velocity={"phi1": 16.0, "phi2": 16.0, **arm}, platform_speed=0.8,
                      **more)  # type: ignore[arg-type]  # fmt: skip


def problem_with(name: str, rates: RateLimits | None, **settings: object) -> Problem:
    """Scenario ``name`` with the robot's rate limits replaced (None: none at all)."""
    problem = load_scenario(name).build()
    robot = problem.robot
    robot = robot.with_limits(dataclasses.replace(robot.limits, rates=rates or RateLimits()))
    new = problem.settings.model_copy(update=settings) if settings else problem.settings
    return dataclasses.replace(problem, robot=robot, settings=new)


def plan(problem: Problem) -> PlanResult:
    return ExtendedJacobian().plan(problem)


def speed(result: PlanResult) -> np.ndarray:
    dq = result.trajectory.dq
    return np.asarray(np.hypot(dq[:, 0], dq[:, 1]))


@pytest.fixture(scope="module")
def torque_runs() -> tuple[Problem, PlanResult, PlanResult]:
    """youbot3r-obstacles-torque without and with the youBot's rate limits."""
    free = plan(problem_with("youbot3r-obstacles-torque", None))
    problem = problem_with("youbot3r-obstacles-torque",
                           youbot_rates(load_scenario("youbot3r-obstacles-torque").build()
                                        .robot.coordinates))  # fmt: skip
    return problem, free, plan(problem)


def test_torque_scenario_with_real_limits_reaches_within_every_limit(
    torque_runs: tuple[Problem, PlanResult, PlanResult],
) -> None:
    """The [PajakPajak] task with torque limits and youBot rate limits: reached, platform speed
    <= 0.8 m/s (2.0 m/s unlimited, 1.41 with torque limits only), every limit held at every
    sample by the planner's verdict and by the independent checker."""
    problem, free, limited = torque_runs
    assert free.status is Status.REACHED and limited.status is Status.REACHED
    assert speed(free).max() > 1.2
    assert speed(limited).max() <= 0.8 * (1 + 1e-9)
    tr = limited.trajectory
    model = RateModel.of(problem.robot)
    assert model.first_violation(tr.t, tr.dq, tr.ddq) is None
    assert np.abs(tr.dq[:, 3:5]).max() == pytest.approx(16.0, rel=1e-9)  # the wheels bind
    report = check(tr, problem, status=limited.status)
    assert report.ok, report.failures()
    lo, hi = problem.robot.limits.torque_min, problem.robot.limits.torque_max
    assert tr.tau is not None
    assert np.all(tr.tau >= lo - 1e-9) and np.all(tr.tau <= hi + 1e-9)
    assert limited.info["max_rate_ratio"] <= 1 + 1e-9
    assert limited.info["time_scaling"] == "torque+rates"


def test_rate_limits_keep_the_path_and_only_slow_it(
    torque_runs: tuple[Problem, PlanResult, PlanResult],
) -> None:
    """Same geometric path (q samples) as the torque-only plan, w <= 1, slower (14.50 ->
    15.37 s); with rate limits w_0 > 0 (still at rest, q'_0 = 0), without it is 0."""
    _, free, limited = torque_runs
    a, b = free.trajectory, limited.trajectory
    np.testing.assert_allclose(a.q, b.q)
    assert b.u is not None and np.all(b.u <= 1.0) and b.u[0] > 0.0
    assert a.u is not None and a.u[0] == 0.0
    assert np.all(b.dq[0] == 0.0)
    assert b.t[-1] > a.t[-1] + 0.5


def test_without_torque_control_the_free_path_is_scaled() -> None:
    """youbot4r-reach (no torque limits) with rate limits: time mode on the free path, u = w;
    with limits far above the plan's rates the plan is the generator's, sample for sample."""
    name = "youbot4r-reach"
    coords = load_scenario(name).build().robot.coordinates
    result = plan(problem_with(name, youbot_rates(coords), t_max=12))
    assert result.status is Status.REACHED
    assert result.info["time_scaling"] == "rates"
    assert speed(result).max() <= 0.8 * (1 + 1e-9)
    wide = plan(problem_with(name, RateLimits(platform_speed=100.0), t_max=12))
    base = plan(problem_with(name, None, t_max=12))
    assert wide.trajectory.u is not None and wide.trajectory.u.min() == 1.0
    np.testing.assert_allclose(wide.trajectory.t, base.trajectory.t, rtol=1e-12)
    np.testing.assert_array_equal(wide.trajectory.dq, base.trajectory.dq)


def test_feedback_mode_is_re_timed_and_keeps_its_virtual_control() -> None:
    """youbot4r-reach-smooth (feedback mode, wheel torques +-0.2 N m): a platform limit of
    0.3 m/s binds; u stays the virtual control, the extra column w is the time rate; a limit
    that does not bind leaves the plan as it was (same times, w = 1)."""
    name = "youbot4r-reach-smooth"
    base = plan(problem_with(name, None))
    tight = plan(problem_with(name, RateLimits(platform_speed=0.3)))
    loose = plan(problem_with(name, RateLimits(platform_speed=5.0)))
    assert base.status is tight.status is loose.status is Status.REACHED
    assert speed(base).max() > 0.45
    assert speed(tight).max() <= 0.3 * (1 + 1e-9)
    tr = tight.trajectory
    assert tr.u is not None and base.trajectory.u is not None
    np.testing.assert_array_equal(tr.u, base.trajectory.u)
    w = tr.extra["w"]
    assert w.min() < 0.7 and w.max() == 1.0
    assert tr.tau is not None and np.abs(tr.tau[:, :2]).max() <= 0.2 + 1e-9
    assert tr.t[-1] > base.trajectory.t[-1]
    np.testing.assert_array_equal(loose.trajectory.t, base.trajectory.t)
    np.testing.assert_array_equal(loose.trajectory.extra["w"], 1.0)


def test_acceleration_limits_hold_at_every_sample() -> None:
    """Wheel and platform acceleration limits (polygon rows) with torque limits."""
    name = "youbot3r-obstacles-torque"
    coords = load_scenario(name).build().robot.coordinates
    rates = youbot_rates(coords, acceleration={"phi1": 30.0, "phi2": 30.0},
                         platform_acceleration=1.0)  # fmt: skip
    problem = problem_with(name, rates)
    result = plan(problem)
    assert result.status is Status.REACHED
    tr = result.trajectory
    assert np.hypot(tr.ddq[:, 0], tr.ddq[:, 1]).max() <= 1.0 * (1 + 1e-9)
    assert np.abs(tr.ddq[:, 3:5]).max() <= 30.0 * (1 + 1e-9)
    assert RateModel.of(problem.robot).first_violation(tr.t, tr.dq, tr.ddq) is None


def test_stalled_steps_do_not_run_the_re_timing_out_of_rounds() -> None:
    """youbot3r-obstacles: one step stayed over a wheel's acceleration limit by the same
    amount round after round (its tightened rows did not bind), the re-timing ran out of its
    rounds and slowed the whole motion (15.79 s). With x capped on a stalled step it converges
    in a few rounds, within every limit, and no slower."""
    from mmplan.time_scaling.retime import MAX_ROUNDS

    problem = load_scenario("youbot3r-obstacles").build()
    result = ExtendedJacobian().plan(problem)
    assert result.status == Status.REACHED
    assert result.info["time_scaling_rounds"] < MAX_ROUNDS
    assert result.trajectory.t[-1] < 15.75
    report = check(result.trajectory, problem, status=result.status)
    assert report.ok, report.failures()
