"""Velocity and acceleration limits in the independent checker, on closed-form motions: at the
samples and between them (what every motion through the samples needs)."""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import pytest

from mmplan import Problem, Scenario, Trajectory, get_robot, interpolant
from mmplan.verify.check import check
from mmplan.verify.rates import DQ_TOL, RATE_REL_TOL, check_rates
from mmplan.verify.summary import summary_disagreements
from tests.eta_planner import METHOD

Q0 = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -0.17, 0.35]
R, D = 0.05, 0.16  # youbot-3r wheel radius and half track
ROBOT = get_robot("youbot-3r")


def straight(x: np.ndarray, v: np.ndarray, a: np.ndarray, t: np.ndarray,
             heading: float = 0.0) -> Trajectory:
    """youbot-3r driving a distance x(t) straight ahead at ``heading``, both wheels rolling
    (phi = x / r)."""
    q = np.tile(Q0, (len(t), 1))
    q[:, 2] = heading
    dq, ddq = np.zeros_like(q), np.zeros_like(q)
    c, s = math.cos(heading), math.sin(heading)
    for i, scale in ((0, c), (1, s), (3, 1 / R), (4, 1 / R)):
        q[:, i] += scale * x
        dq[:, i] = scale * v
        ddq[:, i] = scale * a
    ee = np.array([ROBOT.ee_position(row) for row in q])
    return Trajectory(ROBOT.coordinates, t, q, dq, ddq, ee)


def cruise(v: float, T: float = 1.0, dt: float = 0.01, heading: float = 0.0) -> Trajectory:
    t = np.arange(round(T / dt) + 1) * dt
    return straight(v * t, np.full_like(t, v), np.zeros_like(t), t, heading)


def accelerate(a: float, T: float = 0.5, dt: float = 0.01, heading: float = 0.0) -> Trajectory:
    t = np.arange(round(T / dt) + 1) * dt
    return straight(0.5 * a * t**2, a * t, np.full_like(t, a), t, heading)


def problem(limits: dict[str, Any] | None = None, robot: str = "youbot-3r") -> Problem:
    data: dict[str, Any] = {"name": "rates", "robot": robot, "start": Q0,
                            "goal": {"position": [5.0, 0.0, 0.3]},
                            "planner": {"method": METHOD, "eta": [0.0] * 5}}
    if limits is not None:
        data["limits"] = limits
    return Scenario.from_dict(data).build()


def rate_lines(failures: list[str]) -> list[str]:
    return [line for line in failures if line.startswith("rate limits:")]


def test_within_the_default_limits_passes_with_peaks_and_margins() -> None:
    """0.75 m/s (wheels 15 rad/s) after 0.9 m/s^2 (wheels 18 rad/s^2): inside 0.8, 16, 1, 20."""
    report = check(cruise(0.75), problem())
    assert rate_lines(report.failures()) == [], report.failures()
    r = report.rates
    assert r.peak_platform_speed_mps == pytest.approx(0.75, rel=1e-12)
    assert r.peak_velocity["phi1"] == pytest.approx(15.0, rel=1e-12)
    assert r.peak_velocity["q1"] == 0.0 and r.peak_platform_yaw_rate_radps == 0.0
    margins = r.limit_margins
    assert margins["platform_speed"] == pytest.approx(0.05, rel=1e-9)
    assert margins["velocity.phi1"] == pytest.approx(1.0, rel=1e-9)
    assert margins["velocity.q1"] == pytest.approx(math.pi / 2)
    assert "acceleration.q1" not in margins  # off by default: no margin
    speeding_up = check(accelerate(0.9), problem())
    assert rate_lines(speeding_up.failures()) == [], speeding_up.failures()
    assert speeding_up.rates.peak_platform_acceleration_mps2 == pytest.approx(0.9, rel=1e-12)
    assert speeding_up.rates.peak_acceleration["phi2"] == pytest.approx(18.0, rel=1e-12)


@pytest.mark.parametrize("heading", [0.0, 0.7])
def test_velocity_violation_names_coordinate_time_value_and_limit(heading: float) -> None:
    report = check(cruise(1.0, heading=heading), problem())  # 1 m/s, wheels 20 rad/s
    assert report.max_pfaffian_residual < 1e-12
    lines = rate_lines(report.failures())
    assert "rate limits: platform speed = 1 m/s > limit 0.8 m/s at t = 0 s" in lines
    assert "rate limits: |dq| phi1 = 20 rad/s > limit 16 rad/s at t = 0 s" in lines
    assert any(line.startswith("rate limits: |dq| phi2 = 20 rad/s") for line in lines)
    assert report.rates.limit_margins["platform_speed"] == pytest.approx(-0.2, rel=1e-9)
    assert not report.ok


@pytest.mark.parametrize("heading", [0.0, -2.0])
def test_acceleration_violation_is_caught(heading: float) -> None:
    report = check(accelerate(1.5, heading=heading), problem())  # top 0.75 m/s: only accelerations
    lines = rate_lines(report.failures())
    assert any(line.startswith("rate limits: platform acceleration = 1.5 m/s^2 > limit 1 m/s^2")
               for line in lines)
    assert any(line.startswith("rate limits: |ddq| phi1 = 30 rad/s^2 > limit 20 rad/s^2")
               for line in lines)
    assert not any("speed" in line or "|dq|" in line for line in lines)
    assert report.rates.limit_margins["platform_acceleration"] == pytest.approx(-0.5)


def test_arm_joint_and_yaw_rate_limits() -> None:
    tr = cruise(0.0)
    q, dq = tr.q.copy(), tr.dq.copy()
    q[:, 5] = 1.7 * tr.t  # q1 at 1.7 rad/s > pi/2
    dq[:, 5] = 1.7
    fast_arm = Trajectory(tr.coordinates, tr.t, q, dq, tr.ddq,
                          np.array([ROBOT.ee_position(row) for row in q]))
    assert any(line.startswith("rate limits: |dq| q1 = 1.7 rad/s > limit 1.571 rad/s")
               for line in check(fast_arm, problem()).failures())
    # turning on the spot, wheels at -+5 rad/s: dtheta = r (5 + 5) / (2 d) = 1.5625 rad/s
    q, dq = tr.q.copy(), np.zeros_like(tr.dq)
    w = R * 10 / (2 * D)
    q[:, 2], dq[:, 2] = w * tr.t, w
    q[:, 3], dq[:, 3] = -5 * tr.t, -5
    q[:, 4], dq[:, 4] = 5 * tr.t, 5
    spin = Trajectory(tr.coordinates, tr.t, q, dq, tr.ddq,
                      np.array([ROBOT.ee_position(row) for row in q]))
    assert not rate_lines(check(spin, problem()).failures())  # default 5 rad/s
    report = check(spin, problem({"velocity": {"platform_angular": 1.0}}))
    assert report.max_pfaffian_residual < 1e-12
    assert rate_lines(report.failures()) == [
        "rate limits: platform yaw rate = 1.562 rad/s > limit 1 rad/s at t = 0 s"]


def test_numerical_slack_is_relative_1e_6() -> None:
    limit = 0.75
    assert RATE_REL_TOL == 1e-6
    assert rate_lines(check(cruise(limit * (1 + 0.5e-6)), problem(
        {"velocity": {"platform_linear": limit}})).failures()) == []
    assert rate_lines(check(cruise(limit * (1 + 2e-6)), problem(
        {"velocity": {"platform_linear": limit}})).failures())


def test_dq_column_scaled_down_cannot_hide_a_speed_above_the_limit() -> None:
    """True motion 1 m/s (q), dq column halved to 0.5 m/s: within 0.8 on the column only."""
    honest = cruise(1.0)
    tampered = Trajectory(honest.coordinates, honest.t, honest.q, 0.5 * honest.dq, honest.ddq,
                          honest.ee)
    report = check(tampered, problem())
    lines = rate_lines(report.failures())
    assert report.rates.peak_platform_speed_mps == pytest.approx(0.5)  # the column itself
    assert ("rate limits: platform speed = 1 m/s > limit 0.8 m/s between the samples at t = 0 "
            "and 0.01 s (the secant of q; the dq/ddq columns understate it)") in lines
    assert any(line.startswith("rate limits: |dq| phi1 = 20 rad/s > limit 16 rad/s between the "
                               "samples") for line in lines)
    assert not report.ok
    # accelerations likewise: ddq scaled by 0.4 under 2 m/s^2 of true acceleration (dq honest)
    fast = accelerate(2.0, T=0.3)
    hidden = Trajectory(fast.coordinates, fast.t, fast.q, fast.dq, 0.4 * fast.ddq, fast.ee)
    lines = rate_lines(check(hidden, problem()).failures())
    assert any(line.startswith("rate limits: platform acceleration = 2 m/s^2 > limit 1 m/s^2 "
                               "between the samples at t = ") and line.endswith(
        "(the second difference of q; the dq/ddq columns understate it)") for line in lines)
    assert any(line.startswith("rate limits: |ddq| phi1 = 40 rad/s^2 > limit 20 rad/s^2 between ")
               and "(the least peak of any motion with those q, dq;" in line for line in lines)


def test_dq_halved_with_q_unchanged_fails_even_below_the_speed_limit() -> None:
    """0.6 m/s (within 0.8) with dq halved: no speed is broken, but no motion with those q and
    dq keeps the wheels' acceleration within 20 rad/s^2 (it would need 2400)."""
    honest = cruise(0.6)
    assert rate_lines(check(honest, problem()).failures()) == []
    tampered = Trajectory(honest.coordinates, honest.t, honest.q, 0.5 * honest.dq, honest.ddq,
                          honest.ee)
    lines = rate_lines(check(tampered, problem()).failures())
    assert any(line.startswith("rate limits: |ddq| phi1 = 2400 rad/s^2 > limit 20 rad/s^2 between")
               for line in lines), lines
    assert not any("speed" in line or "|dq|" in line for line in lines)


def test_step_bounds_of_an_honest_curve_stay_below_its_peak() -> None:
    """A secant is a mean rate and A* the least peak acceleration of any motion through the
    samples: q1 = A sin(w t) at its peak rate A w and acceleration A w^2 passes those limits,
    and the bounds come within 0.1 % of them."""
    t = np.linspace(0.0, 2.0, 201)
    A, w = 0.5, 3.0
    q = np.zeros((len(t), 8))
    dq, ddq = np.zeros_like(q), np.zeros_like(q)
    q[:, 5], dq[:, 5] = A * np.sin(w * t), A * w * np.cos(w * t)
    ddq[:, 5] = -A * w**2 * np.sin(w * t)
    limits = {"velocity": {"coordinates": {"q1": A * w}},
              "acceleration": {"coordinates": {"q1": A * w**2}}}
    rates = problem(limits).robot.limits.rates
    report = check_rates(t, q, dq, ddq, ROBOT.coordinates, rates)
    assert report.failures() == []
    checks = {c.key: c for c in report.checks}
    for key, peak in (("velocity.q1", A * w), ("acceleration.q1", A * w**2)):
        assert checks[key].step_peak <= peak
        assert checks[key].step_peak == pytest.approx(peak, rel=1e-3)


def test_least_acceleration_is_that_of_a_bang_bang_motion() -> None:
    """Two samples 0.1 s apart of a motion that accelerates at +a and then -a, the switch
    between them: A* is a (the least peak any motion through them needs), while the Hermite
    through the same samples needs more."""
    a, h, switch = 3.0, 0.1, 0.1 + 0.037
    t = np.array([0.1, 0.2])

    def motion(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        up = np.minimum(x, switch)
        down = np.maximum(x - switch, 0.0)
        return (0.5 * a * up**2 + a * switch * down - 0.5 * a * down**2,
                a * up - a * down)

    q, dq = np.zeros((2, 8)), np.zeros((2, 8))
    q[:, 5], dq[:, 5] = motion(t)
    limits = {"acceleration": {"coordinates": {"q1": a}}}
    report = check_rates(t, q, dq, np.zeros_like(q), ROBOT.coordinates,
                         problem(limits).robot.limits.rates)
    [check_q1] = [c for c in report.checks if c.key == "acceleration.q1"]
    assert check_q1.step_peak == pytest.approx(a, abs=6 * DQ_TOL / h)  # less the allowance
    assert (check_q1.step_start, check_q1.step_end) == pytest.approx((0.1, 0.2))
    assert report.failures() == []
    assert interpolant.peak_acceleration(t, q, dq, (5,))[0] > 1.2 * a


def test_a_resampled_motion_passes_where_its_own_hermite_would_not() -> None:
    """A plan whose Hermite holds |ddq| <= 20 (jumping from +20 to -20 at t = 0.5 s), sampled
    at 100 Hz from t = 0.003 s: every sample and every step bound holds, although the Hermite
    of the new samples overshoots on the step that contains t = 0.5 s (by a third of the
    40 rad/s^2 jump at worst; 33.2 rad/s^2 here, the jump at 0.7 of that step)."""
    L = 20.0
    t = np.array([0.0, 0.5, 1.0])
    q, dq = np.zeros((3, 8)), np.zeros((3, 8))
    q[:, 5] = [0.0, 0.5 * L * 0.25, L * 0.25]  # +L for 0.5 s, then -L: back at rest
    dq[:, 5] = [0.0, L * 0.5, 0.0]
    assert interpolant.peak_acceleration(t, q, dq, (5,)).max() == pytest.approx(L)
    times = np.append(np.arange(0.003, 1.0, 0.01), 1.0)
    qs, dqs, ddqs = interpolant.evaluate(t, q, dq, times)
    limits = {"velocity": None, "acceleration": {"coordinates": {"q1": L}}}
    rates = problem(limits).robot.limits.rates
    assert check_rates(times, qs, dqs, ddqs, ROBOT.coordinates, rates).failures() == []
    assert interpolant.peak_acceleration(times, qs, dqs, (5,)).max() == pytest.approx(33.2)


def test_dq_is_granted_rounding_but_not_more() -> None:
    """1 kHz at exactly the wheel limit (20 rad/s^2): the wheels' dq off by 4e-7 rad/s
    (alternating, or a constant offset; an export's projection moves them by 5.4e-8) passes,
    as it would not without the allowance (it reads as 20.0008 rad/s^2); off by 5e-5 rad/s it
    reads as 20.1 rad/s^2 and fails."""
    assert DQ_TOL == 1e-6
    fine = accelerate(1.0, T=0.2, dt=0.001)
    wiggle = np.where(np.arange(len(fine.t)) % 2 == 0, 1.0, -1.0)[:, None]
    for (size, ok), pattern in itertools.product(((4e-7, True), (5e-5, False)),
                                                 (wiggle, np.ones_like(wiggle))):
        dq = fine.dq + size * pattern * (np.arange(8) == 3)  # phi1 only
        noisy = Trajectory(fine.coordinates, fine.t, fine.q, dq, fine.ddq, fine.ee)
        lines = [line for line in check_rates(noisy.t, noisy.q, noisy.dq, noisy.ddq,
                                              ROBOT.coordinates, ROBOT.limits.rates).failures()]
        assert (lines == []) is ok, lines


def test_untimed_segment_plans_cannot_show_rate_limits() -> None:
    tr = cruise(0.1)
    report = check_rates(tr.t, tr.q, tr.dq, tr.ddq, ROBOT.coordinates, ROBOT.limits.rates,
                         timed=False)
    assert report.peak_platform_speed_mps is None and report.limit_margins == {}
    [line] = report.failures()
    assert "platform_speed" in line and "t is the segment parameter" in line
    off = problem({"velocity": None, "acceleration": None}).robot.limits.rates
    assert check_rates(tr.t, tr.q, tr.dq, tr.ddq, ROBOT.coordinates, off,
                       timed=False).failures() == []


def test_check_of_a_segment_task_does_not_take_t_for_time() -> None:
    """A segment task's t is the segment parameter: the youBot's limits cannot be shown."""
    segment = {"segment": {"start": [1.0, 0.0, 0.3], "end": [1.0, 0.5, 0.3],
                           "normal": [1.0, 0.0, 0.0]}}
    data: dict[str, Any] = {"name": "seg", "robot": "youbot-3r", "start": Q0, "goal": segment,
                            "planner": {"method": METHOD, "eta": [0.0] * 5}}
    report = check(cruise(0.1), Scenario.from_dict(data).build())
    assert not report.rates.timed and report.rates.peak_velocity == {}
    assert any("t is the segment parameter" in line for line in report.failures())
    data["limits"] = {"velocity": None, "acceleration": None}
    report = check(cruise(0.1), Scenario.from_dict(data).build())
    assert rate_lines(report.failures()) == []


def test_robot_without_limits_reports_peaks_and_checks_nothing() -> None:
    t = np.linspace(0.0, 1.0, 11)
    q = np.zeros((11, 6))
    q[:, 1] = 3.0 * t
    dq = np.zeros_like(q)
    dq[:, 1] = 3.0
    robot = get_robot("omni-3dof")
    report = check_rates(t, q, dq, np.zeros_like(q), robot.coordinates, robot.limits.rates)
    assert report.checks == () and report.failures() == [] and report.limit_margins == {}
    assert report.peak_platform_speed_mps == 3.0 and report.peak_velocity["y"] == 3.0


def test_summary_reports_the_peaks_and_mmplan_check_compares_them() -> None:
    report = check(cruise(1.0), problem())
    summary = report.summary(status="timeout", planner=METHOD, compute_time_s=0.1)
    assert summary["peak_platform_speed_mps"] == pytest.approx(1.0)
    assert summary["peak_platform_yaw_rate_radps"] == 0.0
    assert summary["peak_platform_acceleration_mps2"] == 0.0
    assert summary["peak_velocity"]["phi1"] == pytest.approx(20.0)
    assert set(summary["peak_velocity"]) == set(summary["peak_acceleration"]) == set(
        ROBOT.coordinates)
    assert summary["limit_margins"]["velocity.phi1"] == pytest.approx(-4.0)
    assert summary_disagreements(summary, report, METHOD) == []
    edited = {**summary, "peak_velocity": {**summary["peak_velocity"], "phi1": 15.0}}
    assert summary_disagreements(edited, report, METHOD) == [
        "summary peak_velocity.phi1: 15 but recomputed 20"]
    edited = {**summary, "limit_margins": {"platform_speed": 0.1}}
    assert summary_disagreements(edited, report, METHOD)[0].startswith(
        "summary limit_margins: names ['platform_speed'] but recomputed")
    edited = dict(summary)
    del edited["peak_platform_speed_mps"]
    assert summary_disagreements(edited, report, METHOD) == [
        "summary peak_platform_speed_mps: missing"]


def test_limits_on_unknown_coordinates_are_an_input_error() -> None:
    from mmplan import InputError
    from mmplan.robot import RateLimits

    tr = cruise(0.1)
    with pytest.raises(InputError, match="unknown coordinates"):
        check_rates(tr.t, tr.q, tr.dq, tr.ddq, ROBOT.coordinates, RateLimits(velocity={"q7": 1}))


def test_dq_allowance_covers_a_switch_inside_every_step() -> None:
    """1 kHz samples of q1 switching between +20 and -20 rad/s^2 in the middle of every step
    (dq equal at all samples, so only e_k tells the acceleration: A* = 4|e_k|/h^2 = 20
    exactly): dq offset by 9e-7 rad/s passes (without the allowance on e_k it would read as
    20.0036), by 5e-5 it fails."""
    L, h = 20.0, 1e-3
    t = np.arange(41) * h
    q = np.zeros((len(t), 8))
    q[:, 5] = L * h**2 / 4 * (np.arange(len(t)) % 2)  # up a step, down the next
    limits = {"velocity": None, "acceleration": {"coordinates": {"q1": L}}}
    rates = problem(limits).robot.limits.rates
    for offset, ok in ((0.0, True), (9e-7, True), (5e-5, False)):
        dq = np.zeros_like(q)
        dq[:, 5] = offset
        lines = check_rates(t, q, dq, np.zeros_like(q), ROBOT.coordinates, rates).failures()
        assert (lines == []) is ok, (offset, lines)
