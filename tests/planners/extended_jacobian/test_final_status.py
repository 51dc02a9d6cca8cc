"""The status is the final trajectory's (issue 16): a run cut by ``t_max`` inside the
tolerance is ``reached``, a ``reached`` run outside it is not, and the checker agrees.

The rollout stops at half the tolerance, so ``t_max`` can end a run between 0.5 and 1 mm from
the goal: before this fix such a run said ``timeout`` (the checker: "planner says 'timeout'
but the task is completed"; a random youbot-3r scene ended so at 0.68 mm).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mmplan
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian, final_status
from mmplan.task import ReachPoint
from mmplan.trajectory import Status, Trajectory
from mmplan.verify.check import check


def test_run_cut_by_t_max_inside_the_tolerance_is_reached() -> None:
    problem = mmplan.load_scenario("youbot3r-obstacles-unlimited").build()
    full = ExtendedJacobian().plan(problem)
    error = full.history["error"]  # per generator step of dt
    dt = problem.settings.dt  # type: ignore[attr-defined]
    k1 = int(np.flatnonzero(error < 1e-3)[0])
    k_half = int(np.flatnonzero(error < 5e-4)[0])
    assert k_half - k1 > 20  # room to stop between 1 mm and 0.5 mm
    t_max = (k1 + (k_half - k1) // 2) * dt
    cut = replace(problem, settings=problem.settings.model_copy(update={"t_max": t_max}))
    result = ExtendedJacobian().plan(cut)
    report = check(result.trajectory, cut, result.status)
    assert 5e-4 < report.final_error_m < 1e-3
    assert result.status is Status.REACHED, result.message
    assert "t_max" in result.message  # why the run ended is kept
    assert report.ok, report.failures()


def _trajectory(ee_end: tuple[float, float, float]) -> Trajectory:
    n = 2
    return Trajectory(("a", "b"), np.array([0.0, 1.0]), np.zeros((2, n)), np.zeros((2, n)),
                      np.zeros((2, n)), np.array([[0.0, 0.0, 0.0], ee_end]))


@pytest.mark.parametrize(
    ("status", "ee_end", "expected"),
    [
        (Status.TIMEOUT, (1.0, 0.0, 0.0007), Status.REACHED),
        (Status.STALLED, (1.0, 0.0, 0.0009), Status.REACHED),
        (Status.REACHED, (1.0, 0.0, 0.002), Status.STALLED),
        (Status.TIMEOUT, (1.0, 0.0, 0.002), Status.TIMEOUT),
        (Status.REACHED, (1.0, 0.0, 0.0004), Status.REACHED),
        (Status.INFEASIBLE, (1.0, 0.0, 0.0), Status.INFEASIBLE),  # a broken limit stands
        (Status.DIVERGED, (1.0, 0.0, 0.0), Status.DIVERGED),
    ],
)
def test_final_status_follows_the_trajectory(
    status: Status, ee_end: tuple[float, float, float], expected: Status
) -> None:
    task = ReachPoint((1.0, 0.0, 0.0), 1e-3)
    got, message = final_status(status, "why", task, _trajectory(ee_end))
    assert got is expected
    assert "why" in message
