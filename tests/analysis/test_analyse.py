"""mmplan.analysis.analyse: studies after planning never fail on an absurd plan."""

from __future__ import annotations

import dataclasses

import numpy as np

import mmplan
from mmplan.analysis import MAX_STUDY_DURATION_S, analyse
from mmplan.trajectory import PlanResult, Status, Trajectory


def test_a_diverged_plan_with_absurd_times_skips_the_study_instead_of_failing() -> None:
    """A diverged extended-Jacobian plan once carried times up to 3e49 s and the vibration
    study raised 'Maximum allowed size exceeded' out of plan(); now it is skipped, said so."""
    problem = mmplan.load_scenario("youbot4r-reach-smooth").build()
    n = problem.robot.n
    t = np.array([0.0, 1.0, 3e49])
    q = np.tile(problem.start, (3, 1))
    traj = Trajectory(problem.robot.coordinates, t, q, np.zeros((3, n)), np.zeros((3, n)),
                      np.zeros((3, 3)))
    result = PlanResult(Status.DIVERGED, traj, "extended-jacobian", "diverged")
    out = analyse(result, problem)
    assert out.status is Status.DIVERGED and "skipped" in str(out.info["analysis"])
    assert "vibration_rms" not in out.info
    assert MAX_STUDY_DURATION_S < 3e49


def test_the_study_runs_when_the_settings_ask_for_it() -> None:
    problem = mmplan.load_scenario("youbot4r-reach-smooth-unlimited").build()
    result = mmplan.get_planner(problem.settings.method)().plan(problem)
    assert "vibration_rms" in analyse(result, problem).info
    off = dataclasses.replace(problem, settings=problem.settings.model_copy(
        update={"vibration": False}))
    assert analyse(result, off) is result
