"""Dynamics M(q), c(q, dq) against Pinocchio (CRBA, RNEA) and physical invariants."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from mmplan.robot import get_robot, robot_names
from mmplan.robot.library import youbot_4r
from tests.pinocchio_model import build_pinocchio
from tests.robot.robots import robot_or_skip


@pytest.mark.parametrize("name", robot_names())
def test_mass_matrix_and_bias_match_pinocchio(name: str, rng: np.random.Generator) -> None:
    robot = robot_or_skip(name)
    model, order = build_pinocchio(robot)
    data = model.createData()
    assert model.nq == robot.n
    for _ in range(20):
        q = rng.uniform(-2.0, 2.0, robot.n)
        dq = rng.uniform(-2.0, 2.0, robot.n)
        ddq = rng.uniform(-2.0, 2.0, robot.n)
        qp, dqp, ddqp = q[order], dq[order], ddq[order]
        M_pin = pin.crba(model, data, qp)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        M = robot.mass_matrix(q)[np.ix_(order, order)]
        np.testing.assert_allclose(M, M_pin, atol=1e-9)
        tau_pin = pin.rnea(model, data, qp, dqp, ddqp)
        tau = (robot.mass_matrix(q) @ ddq + robot.bias(q, dq))[order]
        np.testing.assert_allclose(tau, tau_pin, atol=1e-9)


@pytest.mark.parametrize("name", robot_names())
def test_mass_matrix_is_symmetric_positive_definite(name: str, rng: np.random.Generator) -> None:
    robot = robot_or_skip(name)
    for _ in range(20):
        M = robot.mass_matrix(rng.uniform(-3, 3, robot.n))
        np.testing.assert_allclose(M, M.T, atol=1e-12)
        assert np.linalg.eigvalsh(M).min() > 0


@pytest.mark.parametrize("name", ["youbot-3r", "youbot-4r"])
def test_energy_balance_along_a_free_motion(name: str, rng: np.random.Generator) -> None:
    """Unactuated, unconstrained motion conserves kinetic + potential energy (RK4, small dt)."""
    robot = robot_or_skip(name)
    q, dq = rng.uniform(-1, 1, robot.n), rng.uniform(-1, 1, robot.n)

    def energy(q: np.ndarray, dq: np.ndarray) -> float:
        # potential: integrate the gravity torques along a straight line from q = 0
        # (Gauss-Legendre, exact to rounding for this smooth integrand)
        zero = np.zeros(robot.n)
        nodes, weights = np.polynomial.legendre.leggauss(30)
        s = (nodes + 1) / 2
        g = np.array([robot.bias(si * q, zero) for si in s])
        V = 0.5 * weights @ (g @ q)
        return float(0.5 * dq @ robot.mass_matrix(q) @ dq + V)

    def f(x: np.ndarray) -> np.ndarray:
        q, dq = x[: robot.n], x[robot.n :]
        return np.r_[dq, np.linalg.solve(robot.mass_matrix(q), -robot.bias(q, dq))]

    x, dt = np.r_[q, dq], 1e-3
    e0 = energy(q, dq)
    for _ in range(200):
        k1 = f(x)
        k2 = f(x + dt / 2 * k1)
        k3 = f(x + dt / 2 * k2)
        k4 = f(x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert energy(x[: robot.n], x[robot.n :]) == pytest.approx(e0, abs=1e-6 * max(1.0, abs(e0)))


def test_youbot_3r_gravity_torques_at_start_match_the_documented_ones() -> None:
    robot = get_robot("youbot-3r")
    q0 = np.array([0, -0.5, np.pi / 2, 0, 0, 0, -0.17, 0.35])
    tau = robot.actuator_efforts(q0, np.zeros(8), np.zeros(8))
    np.testing.assert_allclose(tau, [0, 0, 0, -8.98, -4.10], atol=5e-3)


@pytest.mark.parametrize("name", robot_names())
def test_actuator_efforts_realise_the_constrained_acceleration(
    name: str, rng: np.random.Generator
) -> None:
    """tau = (N^T B)^-1 N^T (M ddq + c) leaves only a constraint force (in the image of A^T)."""
    robot = robot_or_skip(name)
    q, dq, ddq = (rng.uniform(-1, 1, robot.n) for _ in range(3))
    tau = robot.actuator_efforts(q, dq, ddq)
    residual = robot.mass_matrix(q) @ ddq + robot.bias(q, dq) - robot.actuation(q) @ tau
    A = robot.pfaffian(q)
    if robot.h == 0:
        np.testing.assert_allclose(residual, 0, atol=1e-10)
    else:
        lam, *_ = np.linalg.lstsq(A.T, residual, rcond=None)
        np.testing.assert_allclose(A.T @ lam, residual, atol=1e-10)


def test_wheel_friction_adds_viscous_and_coulomb_terms() -> None:
    plain, rough = youbot_4r.build(), youbot_4r.build(friction=True)
    q, dq = np.zeros(9), np.zeros(9)
    dq[3] = 2.0
    extra = rough.bias(q, dq) - plain.bias(q, dq)
    assert extra[3] == pytest.approx(0.045 * 2.0 + 0.2 * np.tanh(2.0 / 1e-2))
    np.testing.assert_allclose(np.delete(extra, 3), 0, atol=1e-12)
