"""Robot.collision_points_at: the collision points at many states in one call."""

from __future__ import annotations

import numpy as np
import pytest

import mmplan


@pytest.mark.parametrize("compiled", [True, False])
def test_points_at_many_states_equal_one_state_at_a_time(
    compiled: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same numbers as ``collision_points`` state by state, with the compiled library and
    on the virtual machine (its mapped function's (3, N P) layout turned into (N, P, 3))."""
    robot = mmplan.load_scenario("youbot3r-obstacles").build().robot
    if not compiled:
        monkeypatch.setattr(robot, "compiled", lambda: None)
    Q = np.random.default_rng(1).normal(size=(7, robot.n))
    many = robot.collision_points_at(Q)
    assert many.shape == (7, len(robot.collision), 3)
    one = np.array([robot.collision_points(q) for q in Q])
    np.testing.assert_allclose(many, one, rtol=0, atol=1e-12)
    assert robot.collision_points_at(np.zeros((0, robot.n))).shape == (0, len(robot.collision), 3)
