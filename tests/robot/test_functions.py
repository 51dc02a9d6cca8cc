"""Robot.functions: each function made on first use from the symbolic model, shared by copies."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from mmplan.robot import get_robot
from mmplan.robot.library import youbot_3r

NAMES = ["ee_position", "jacobian", "pfaffian", "null_basis", "actuation", "mass_matrix", "bias",
         "manipulability", "collision_points", "tau", "ee_acceleration"]


def test_every_function_is_its_symbolic_expression(rng: np.random.Generator) -> None:
    robot = youbot_3r.build()
    s = robot.symbols
    expressions = {"ee_position": s.ee_position, "jacobian": s.jacobian, "pfaffian": s.pfaffian,
                   "null_basis": s.null_basis, "actuation": s.actuation,
                   "mass_matrix": s.mass_matrix, "bias": s.bias,
                   "manipulability": s.manipulability, "collision_points": s.collision_points,
                   "tau": s.tau}
    assert list(robot.functions) == NAMES and len(robot.functions) == len(NAMES)
    q, dq, ddq = (rng.normal(size=robot.n) for _ in range(3))
    for name, expr in expressions.items():
        fn = robot.functions[name]
        inputs = [q, dq, ddq][:fn.n_in()]
        reference = ca.Function("ref", [s.q, s.dq, s.ddq][:fn.n_in()], [expr])
        np.testing.assert_array_equal(np.asarray(fn(*inputs)), np.asarray(reference(*inputs)))


def test_the_ee_acceleration_is_the_second_derivative_of_the_ee_position(
    rng: np.random.Generator,
) -> None:
    """J ddq + (dJ/dt) dq against central differences of k(q(t)) along q(t) = q + dq t +
    ddq t^2 / 2 (whose velocity and acceleration at t = 0 are dq and ddq)."""
    robot = youbot_3r.build()
    fn = robot.functions["ee_acceleration"]
    h = 1e-4
    for _ in range(5):
        q, dq, ddq = (rng.normal(size=robot.n) for _ in range(3))
        k = [robot.ee_position(q + dq * t + 0.5 * ddq * t**2) for t in (-h, 0.0, h)]
        fd = (k[2] - 2.0 * k[1] + k[0]) / h**2
        np.testing.assert_allclose(np.asarray(fn(q, dq, ddq)).ravel(), fd, atol=2e-5, rtol=1e-5)


def test_functions_are_made_once_and_shared_by_copies() -> None:
    robot = get_robot("youbot-3r")
    copy = robot.with_limits(robot.limits)
    assert copy.functions["tau"] is robot.functions["tau"]
    assert robot.functions["ee_position"] is robot.functions["ee_position"]
    with pytest.raises(KeyError):
        robot.functions["no-such-function"]
