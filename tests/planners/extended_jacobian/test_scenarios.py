"""The extended-Jacobian scenario files load, validate and plan with the real scene: the four
paper tasks within the youBot's real rate limits and their ``-unlimited`` paper variants.

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

TASKS = (
    "youbot4r-reach",
    "youbot4r-reach-smooth",
    "youbot3r-obstacles",
    "youbot3r-obstacles-torque",
)
NAMES = TASKS + tuple(f"{t}-unlimited" for t in TASKS)


@pytest.mark.parametrize("name", NAMES)
def test_scenario_files_load(name: str) -> None:
    scenario = load_scenario(name)
    problem = scenario.build()
    assert problem.robot.limits.rates.any is not name.endswith("-unlimited")
    if not name.endswith("-unlimited"):
        assert problem.robot.limits.rates.platform_speed == 0.8  # the youBot's data sheet
    name = name.removesuffix("-unlimited")
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


@pytest.mark.parametrize("name", TASKS)
def test_unlimited_variant_is_the_same_task_without_rate_limits(name: str) -> None:
    """Same resolved scenario but for the name and the velocity/acceleration limits."""
    limited = load_scenario(name).resolved_dict()
    paper = load_scenario(f"{name}-unlimited").resolved_dict()
    assert paper.pop("name") == f"{name}-unlimited" and limited.pop("name") == name
    for d in (limited, paper):
        d["limits"].pop("velocity", None)
        d["limits"].pop("acceleration", None)
    assert limited == paper


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
