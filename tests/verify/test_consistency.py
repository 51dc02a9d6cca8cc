"""The checker's consistency checks (mmplan.verify.consistency) on hand-made trajectories:
start, required columns, tau vs the model (with friction), ddq vs the interpolant, status."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

from mmplan import Scenario, Status, Trajectory, get_robot
from mmplan.problem import Problem
from mmplan.robot.library import youbot_4r
from mmplan.verify.check import check
from mmplan.verify.consistency import DDQ_LOCAL_TOL, DDQ_REL_TOL, START_TOL
from tests.eta_planner import METHOD
from tests.verify.test_check import Q0, drive, problem


def _lines(report: Any, prefix: str) -> list[str]:
    return [line for line in report.failures() if line.startswith(prefix)]


def test_first_sample_must_be_the_scenarios_start_at_time_zero() -> None:
    tr = drive()
    assert check(tr, problem()).consistency.start_deviation == 0.0
    for offset, fails in ((0.5 * START_TOL, False), (1e-6, True)):
        q = np.array(tr.q)
        q[:, 6] += offset  # q2, the whole motion (ee and tau follow)
        report = check(drive(q=q), problem())
        assert report.consistency.start_deviation == pytest.approx(offset, rel=1e-6)
        assert bool(_lines(report, "start: q at the first sample")) == fails
        if fails:
            assert "(q2;" in _lines(report, "start:")[0]
    late = drive(t=tr.t + 0.5)
    assert _lines(check(late, problem()), "start: the trajectory begins at t = 0.5 s")


def test_a_segment_task_chooses_its_own_start() -> None:
    """The manipulability-area planner picks the base start: q_0 is not compared."""
    tr = drive()
    seg = {"segment": {"start": tr.ee[0].tolist(), "end": (tr.ee[0] + [0, 0.5, 0]).tolist(),
                       "normal": [1.0, 0.0, 0.0]}}
    q = np.array(tr.q)
    q[:, 1] += 0.3  # the whole motion moved sideways
    report = check(drive(q=q, t=np.linspace(0.0, 1.0, len(tr.t))), problem(seg))
    assert report.consistency.start_deviation is None
    assert not _lines(report, "start")


@pytest.mark.parametrize("status", [s.value for s in Status])
def test_every_status_name_is_accepted(status: str) -> None:
    report = check(drive(), problem(), status=status)
    assert not any("is not one of" in line for line in report.failures())


def test_a_status_that_is_no_status_name_fails() -> None:
    report = check(drive(), problem(), status="bogus")
    lines = _lines(report, "status:")
    assert lines == ["status: 'bogus' is not one of reached, stalled, diverged, infeasible, "
                     "timeout"]


def _ej_problem(**extra: Any) -> Problem:
    """youbot-3r without torque limits, planned (as the scenario says) by extended-jacobian."""
    data = {"name": "ej", "robot": "youbot-3r", "start": Q0,
            "goal": {"position": [5.0, 0.0, 0.3]}, "limits": {"torque": "unlimited"},
            "planner": {"method": "extended-jacobian"}, **extra}
    return Scenario.from_dict(data).build()


def test_extended_jacobian_plans_carry_tau_and_u() -> None:
    prob = _ej_problem()
    bare = check(drive(tau=None), prob)
    assert bare.consistency.required == ("tau.*", "u")
    lines = _lines(bare, "columns:")
    assert len(lines) == 2
    assert "effort columns missing (method extended-jacobian writes its efforts)" in lines[0]
    assert "column u missing" in lines[1]
    tr = drive()
    full = dataclasses.replace(tr, u=np.ones(len(tr.t)))
    assert check(full, prob).ok, check(full, prob).failures()
    # the eta planner writes neither: nothing is required without torque limits
    assert check(drive(tau=None), problem(limits={"torque": "unlimited"})).ok


def test_effort_columns_must_name_the_robots_actuators_in_order() -> None:
    tr = drive()
    robot = get_robot("youbot-3r")
    swapped = dataclasses.replace(tr, actuators=robot.actuators[::-1],
                                  tau=np.array(tr.tau)[:, ::-1])
    lines = _lines(check(swapped, problem()), "columns: effort columns tau.q3, tau.q2")
    assert lines and "expected tau.wheel1, tau.wheel2, tau.q1, tau.q2, tau.q3" in lines[0]


def test_friction_is_part_of_the_model_efforts() -> None:
    """youbot-4r with [Pajak]'s wheel friction: each wheel needs 0.045 w + 0.2 tanh(w / 0.01)
    N m more; efforts written without it are 0.38 N m off at w = 4 rad/s."""
    plain, rough = youbot_4r.build(), youbot_4r.build(friction=True)
    start = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -np.pi / 8, np.pi / 8, 0.0]
    prob = Scenario.from_dict({"name": "f", "robot": "youbot-4r", "start": start,
                               "goal": {"position": [5.0, 0.0, 0.3]},
                               "planner": {"method": METHOD, "eta": [0.0] * 6}}).build()
    prob = dataclasses.replace(prob, robot=rough)
    v, t = 0.2, np.linspace(0.0, 1.0, 101)
    q = np.tile(start, (len(t), 1))
    dq = np.zeros_like(q)
    for i, rate in ((0, v), (3, v / 0.05), (4, v / 0.05)):
        q[:, i] += rate * t
        dq[:, i] = rate
    ddq = np.zeros_like(q)
    ee = np.array([rough.ee_position(x) for x in q])

    def with_efforts(robot: Any) -> Trajectory:
        tau = np.array([robot.actuator_efforts(*x) for x in zip(q, dq, ddq, strict=True)])
        return Trajectory(rough.coordinates, t, q, dq, ddq, ee, rough.actuators, tau)

    assert check(with_efforts(rough), prob).ok
    report = check(with_efforts(plain), prob)
    assert report.tau_model_deviation == pytest.approx(0.045 * 4 + 0.2 * np.tanh(400), rel=1e-9)
    assert _lines(report, "tau vs model")


def _sine(scale: float = 1.0, at: int | None = None, bump: float = 0.0) -> Trajectory:
    """q1 = A sin(w t) with exact dq; ddq exact times ``scale``, plus ``bump`` at sample
    ``at``."""
    tr = drive()
    A, w = 0.5, 2.0
    q, dq, ddq = np.array(tr.q), np.array(tr.dq), np.array(tr.ddq)
    q[:, 5] = A * np.sin(w * tr.t)
    dq[:, 5] = A * w * np.cos(w * tr.t)
    ddq[:, 5] = -scale * A * w**2 * np.sin(w * tr.t)
    if at is not None:
        ddq[at, 5] += bump
    return drive(q=q, dq=dq, ddq=ddq)


def test_ddq_must_lie_in_the_interpolants_range() -> None:
    """Exact accelerations of q1 = A sin(w t) sit on the Hermite's (within O(h^2)); scaled by
    5 they leave it by 4 A w^2 sin(w t) at the peak, where the acceleration hardly varies:
    the allowance there is little more than DDQ_REL_TOL A w^2."""
    peak = 0.5 * 2.0**2
    ok = check(_sine(), problem())
    assert ok.consistency.ddq_excess < 1e-3 * peak and ok.ok, ok.failures()
    bad = check(_sine(scale=5.0), problem())
    assert bad.consistency.ddq_excess == pytest.approx(4 * peak, rel=0.01)
    assert DDQ_REL_TOL * peak <= bad.consistency.ddq_allowed < 2 * DDQ_REL_TOL * peak
    lines = _lines(bad, "ddq consistency")
    assert lines and "q1 at t = " in lines[0]


def _allowance(k: int, dt: float = 0.01, A: float = 0.5, w: float = 2.0) -> float:
    """Independent: DDQ_LOCAL_TOL x the spread of the exact acceleration -A w^2 sin(w t) over
    the four steps around sample k (monotone there) + DDQ_REL_TOL x its peak A w^2."""
    t = k * dt
    spread = A * w**2 * abs(np.sin(w * (t + 2 * dt)) - np.sin(w * (t - 2 * dt)))
    return DDQ_LOCAL_TOL * spread + DDQ_REL_TOL * A * w**2


@pytest.mark.parametrize(("fraction", "fails"), [(0.9, False), (1.1, True)])
@pytest.mark.parametrize("k", [50, 150])  # sin(1), sin(3): acceleration varying fast and slow
def test_ddq_allowance_is_the_local_spread_and_a_fraction_of_the_peak(
        fraction: float, fails: bool, k: int) -> None:
    """One sample's ddq moved below the range by 0.9 / 1.1 times the allowance (the range's
    lower end there is the exact acceleration at the adjacent sample, within O(h^2))."""
    dt, A, w = 0.01, 0.5, 2.0
    exact = -A * w**2 * np.sin(w * dt * np.array([k - 1, k, k + 1]))
    low = exact.min()
    bump = (low - exact[1]) - fraction * _allowance(k)
    report = check(_sine(at=k, bump=bump), problem())
    assert bool(_lines(report, "ddq consistency")) == fails, report.consistency.ddq_where


def test_a_jump_of_ddq_at_a_sample_is_allowed() -> None:
    """Bang-bang: +a until t = 1 s, -a after; the written ddq is the one-sided value of the
    step starting at the sample (-a at t = 1 s), which the adjacent steps' range covers."""
    tr = drive()
    a = 0.4
    q, dq, ddq = np.array(tr.q), np.array(tr.dq), np.array(tr.ddq)
    t = tr.t
    up = t < 1.0 - 1e-12
    q[:, 5] = np.where(up, 0.5 * a * t**2, 0.5 * a + a * (t - 1) - 0.5 * a * (t - 1) ** 2)
    dq[:, 5] = np.where(up, a * t, a - a * (t - 1))
    ddq[:, 5] = np.where(up, a, -a)
    report = check(drive(q=q, dq=dq, ddq=ddq), problem())
    assert report.consistency.ddq_excess < 1e-9 and report.ok, report.failures()
