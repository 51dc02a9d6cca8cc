"""The generator's effort split tau = T0 + Tm ddq (effort.py, kinetic-energy form of the bias)
equals the robot's own actuator efforts (N^T B)^-1 N^T (M ddq + c), built from M and c."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from mmplan.planners.extended_jacobian.effort import effort_split
from mmplan.robot.library import get_robot


@pytest.mark.parametrize("name", ["youbot-3r", "youbot-4r", "diffdrive-3dof"])
def test_effort_split_equals_the_robot_efforts(name: str) -> None:
    robot = get_robot(name)
    T0, Tm = effort_split(robot)
    s = robot.symbols
    ddq = ca.SX.sym("ddq", robot.n)
    fn = ca.Function("tau", [s.q, s.dq, ddq], [T0 + Tm @ ddq])
    rng = np.random.default_rng(3)
    for _ in range(20):
        q, dq, a = rng.normal(size=(3, robot.n))
        want = robot.actuator_efforts(q, dq, a)
        got = np.asarray(fn(q, dq, a), dtype=float).ravel()
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10 * max(1.0, np.abs(want).max()))


def test_gravity_efforts_of_the_compiled_generator_equal_the_robot_efforts() -> None:
    """The start check reads the holding efforts off the generator (checks.check_gravity)."""
    import mmplan

    sc = mmplan.load_scenario("youbot3r-obstacles-torque")
    problem = sc.build()
    planner = mmplan.get_planner(sc.method)()
    fns = planner._prepare(problem).fns  # type: ignore[attr-defined]
    robot = problem.robot
    rng = np.random.default_rng(4)
    for _ in range(10):
        q = problem.start + 0.3 * rng.normal(size=robot.n)
        want = robot.actuator_efforts(q, np.zeros(robot.n), np.zeros(robot.n))
        got = fns.gravity_efforts(q)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(want).max()))
