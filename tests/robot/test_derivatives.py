"""Every derivative the robot model exposes, against central finite differences."""

from __future__ import annotations

from collections.abc import Callable

import casadi as ca
import numpy as np
import pytest

from mmplan.robot import robot_names
from tests.robot.robots import robot_or_skip

H = 1e-6


def fd_jacobian(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray) -> np.ndarray:
    cols = []
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = H
        cols.append((np.ravel(f(x + e)) - np.ravel(f(x - e))) / (2 * H))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("name", robot_names())
def test_jacobian_matches_finite_differences(name: str, rng: np.random.Generator) -> None:
    robot = robot_or_skip(name)
    for _ in range(5):
        q = rng.uniform(-2, 2, robot.n)
        np.testing.assert_allclose(robot.jacobian(q), fd_jacobian(robot.ee_position, q), atol=1e-8)


@pytest.mark.parametrize("name", robot_names())
def test_pfaffian_derivative_matches_finite_differences(
    name: str, rng: np.random.Generator
) -> None:
    robot = robot_or_skip(name)
    s = robot.symbols
    dA = ca.Function("dA", [s.q], [ca.jacobian(ca.vec(s.pfaffian), s.q)])
    for _ in range(5):
        q = rng.uniform(-2, 2, robot.n)
        expected = fd_jacobian(lambda x: robot.pfaffian(x).ravel(order="F"), q)
        np.testing.assert_allclose(np.asarray(dA(q)), expected, atol=1e-8)


@pytest.mark.parametrize("name", robot_names())
def test_manipulability_gradient_matches_finite_differences(
    name: str, rng: np.random.Generator
) -> None:
    robot = robot_or_skip(name)
    s = robot.symbols
    grad = ca.Function("dmu", [s.q], [ca.gradient(s.manipulability, s.q)])
    for _ in range(5):
        q = rng.uniform(-2, 2, robot.n)
        if robot.manipulability(q) < 1e-3:
            continue
        expected = fd_jacobian(lambda x: np.array([robot.manipulability(x)]), q).ravel()
        np.testing.assert_allclose(np.asarray(grad(q)).ravel(), expected, atol=1e-7)


@pytest.mark.parametrize("name", robot_names())
def test_mass_matrix_derivative_matches_finite_differences(
    name: str, rng: np.random.Generator
) -> None:
    robot = robot_or_skip(name)
    s = robot.symbols
    dM = ca.Function("dM", [s.q], [ca.jacobian(ca.vec(s.mass_matrix), s.q)])
    q = rng.uniform(-2, 2, robot.n)
    expected = fd_jacobian(lambda x: robot.mass_matrix(x).ravel(order="F"), q)
    np.testing.assert_allclose(np.asarray(dM(q)), expected, atol=1e-6)


@pytest.mark.parametrize("name", robot_names())
def test_null_basis_spans_kernel_of_pfaffian(name: str, rng: np.random.Generator) -> None:
    robot = robot_or_skip(name)
    for _ in range(20):
        q = rng.uniform(-3, 3, robot.n)
        A, N, B = robot.pfaffian(q), robot.null_basis(q), robot.actuation(q)
        np.testing.assert_allclose(A @ N, 0, atol=1e-12)
        assert np.linalg.matrix_rank(N) == robot.n - robot.h
        assert abs(np.linalg.det(N.T @ B)) > 1e-6
        if robot.h:
            assert np.linalg.matrix_rank(A) == robot.h


@pytest.mark.parametrize("name", robot_names())
def test_bias_derivatives_match_finite_differences(name: str, rng: np.random.Generator) -> None:
    """dc/dq and dc/d(dq), which the extended-Jacobian generator differentiates through."""
    robot = robot_or_skip(name)
    s = robot.symbols
    dc = ca.Function("dc", [s.q, s.dq], [ca.jacobian(s.bias, s.q), ca.jacobian(s.bias, s.dq)])
    q, dq = rng.uniform(-2, 2, robot.n), rng.uniform(-2, 2, robot.n)
    dc_dq, dc_ddq = (np.asarray(v) for v in dc(q, dq))
    np.testing.assert_allclose(dc_dq, fd_jacobian(lambda x: robot.bias(x, dq), q), atol=1e-6)
    np.testing.assert_allclose(dc_ddq, fd_jacobian(lambda v: robot.bias(q, v), dq), atol=1e-6)


@pytest.mark.parametrize("name", robot_names())
def test_null_basis_derivative_matches_finite_differences(
    name: str, rng: np.random.Generator
) -> None:
    robot = robot_or_skip(name)
    s = robot.symbols
    dN = ca.Function("dN", [s.q], [ca.jacobian(ca.vec(s.null_basis), s.q)])
    q = rng.uniform(-2, 2, robot.n)
    expected = fd_jacobian(lambda x: robot.null_basis(x).ravel(order="F"), q)
    np.testing.assert_allclose(np.asarray(dN(q)), expected, atol=1e-8)
