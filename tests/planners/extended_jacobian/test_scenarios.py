"""The four extended-Jacobian scenario files load, validate and plan with the real scene.

Full runs of the youbot-3r scenarios take about 6000 steps; here they run a short horizon
(the full runs, with their figures, are in bench/bench_extended_jacobian.py).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mmplan.planners.extended_jacobian.planner import ExtendedJacobian, ExtendedJacobianSettings
from mmplan.scenario.loader import load_scenario
from mmplan.task import ReachPoint
from mmplan.trajectory import Status

NAMES = (
    "youbot4r-reach",
    "youbot4r-reach-smooth",
    "youbot3r-obstacles",
    "youbot3r-obstacles-torque",
)


@pytest.mark.parametrize("name", NAMES)
def test_scenario_files_load(name: str) -> None:
    scenario = load_scenario(name)
    problem = scenario.build()
    settings = problem.settings
    assert isinstance(settings, ExtendedJacobianSettings)
    assert isinstance(problem.task, ReachPoint) and problem.task.tolerance == 1e-3
    robot = problem.robot
    if name == "youbot4r-reach-smooth":
        assert settings.virtual_control.growth == "distance" and settings.dt == 0.005
        np.testing.assert_allclose(robot.limits.torque_max[:2], 0.2)
        assert np.isinf(robot.limits.torque_max[2:]).all()
    if name == "youbot3r-obstacles-torque":
        assert settings.virtual_control.enabled and robot.limits.has_torque_limits
    if name == "youbot3r-obstacles":
        assert not robot.limits.has_torque_limits
    if name.startswith("youbot3r"):
        assert [ob.influence for ob in problem.scene.obstacles] == [0.35, 0.15, 0.35]


def test_youbot3r_obstacles_torque_file_first_seconds() -> None:
    """Real scene: the first 1.5 s keep every effort inside its limits and clear obstacles."""
    problem = load_scenario("youbot3r-obstacles-torque").build()
    settings = problem.settings
    assert isinstance(settings, ExtendedJacobianSettings)
    problem = dataclasses.replace(problem, settings=settings.model_copy(update={"t_max": 1.5}))
    result = ExtendedJacobian().plan(problem)
    tr, robot = result.trajectory, problem.robot
    assert result.status is Status.TIMEOUT and tr.is_finite()
    assert tr.tau is not None and tr.u is not None
    assert np.all(tr.tau >= robot.limits.torque_min - 1e-9)
    assert np.all(tr.tau <= robot.limits.torque_max + 1e-9)
    points = np.vstack([robot.collision_points(q) for q in tr.q[::5]])
    assert float(problem.scene.distances(points).min()) > 0.0
    err = np.linalg.norm(tr.ee - np.asarray(problem.task.position), axis=1)  # type: ignore[attr-defined]
    assert err[-1] < err[0] - 0.1  # it is on its way
