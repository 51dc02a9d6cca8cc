"""Forward kinematics of the built-in robots against the papers' printed closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from mmplan.robot import get_robot, robot_names
from mmplan.robot.library import base_6dof
from tests.robot.robots import robot_or_skip

N_RANDOM = 1000


def _random_q(rng: np.random.Generator, n: int, count: int) -> np.ndarray:
    return rng.uniform(-np.pi, np.pi, size=(count, n)) * np.r_[[3.0, 3.0], np.ones(n - 2)]


def _batch_fk(name: str, Q: np.ndarray) -> np.ndarray:
    fn = get_robot(name).functions["ee_position"].map(Q.shape[0])
    return np.asarray(fn(Q.T)).T


def test_youbot_3r_matches_printed_closed_form(rng: np.random.Generator) -> None:
    Q = _random_q(rng, 8, N_RANDOM)
    x, y, th, q1, q2, q3 = Q[:, 0], Q[:, 1], Q[:, 2], Q[:, 5], Q[:, 6], Q[:, 7]
    alpha = th - q1
    R = 0.03 + 0.16 * np.cos(q2) + 0.34 * np.cos(q2 + q3)
    expected = np.c_[
        x + 0.17 * np.cos(th) + R * np.cos(alpha),
        y + 0.17 * np.sin(th) + R * np.sin(alpha),
        0.25 - 0.16 * np.sin(q2) - 0.34 * np.sin(q2 + q3),
    ]
    np.testing.assert_allclose(_batch_fk("youbot-3r", Q), expected, atol=1e-12)


def test_youbot_3r_matches_the_pajakpajak_expanded_form(rng: np.random.Generator) -> None:
    """The form as printed in [PajakPajak] (with c_th12 = cos(-th+q1+q2) + cos(th-q1+q2), ...)."""
    Q = _random_q(rng, 8, 200)
    x, y, th, q1, q2, q3 = Q[:, 0], Q[:, 1], Q[:, 2], Q[:, 5], Q[:, 6], Q[:, 7]
    c123 = np.cos(-th + q1 + q2 + q3) + np.cos(th - q1 + q2 + q3)
    c12 = np.cos(-th + q1 + q2) + np.cos(th - q1 + q2)
    s123 = np.sin(-th + q1 + q2 + q3) - np.sin(th - q1 + q2 + q3)
    s12 = np.sin(-th + q1 + q2) - np.sin(th - q1 + q2)
    expected = np.c_[
        0.17 * c123 + 0.08 * c12 + 0.03 * np.cos(-th + q1) + 0.17 * np.cos(th) + x,
        -0.17 * s123 - 0.08 * s12 - 0.03 * np.sin(-th + q1) + 0.17 * np.sin(th) + y,
        -0.34 * np.sin(q2 + q3) - 0.16 * np.sin(q2) + 0.25,
    ]
    np.testing.assert_allclose(_batch_fk("youbot-3r", Q), expected, atol=1e-12)


def test_youbot_4r_matches_printed_closed_form(rng: np.random.Generator) -> None:
    Q = _random_q(rng, 9, N_RANDOM)
    x, y, th = Q[:, 0], Q[:, 1], Q[:, 2]
    q1, q2, q3, q4 = Q[:, 5], Q[:, 6], Q[:, 7], Q[:, 8]
    l1, l2, l3, l4 = 0.033, 0.155, 0.135, 0.1708
    xr, yr, zc, zr = 0.167, 0.0, 0.084, 0.161
    alpha = th - q1
    L = l1 + l2 * np.cos(q2) + l3 * np.cos(q2 + q3) + l4 * np.cos(q2 + q3 + q4)
    expected = np.c_[
        x + xr * np.cos(th) - yr * np.sin(th) + L * np.cos(alpha),
        y + xr * np.sin(th) + yr * np.cos(th) + L * np.sin(alpha),
        zc + zr - l2 * np.sin(q2) - l3 * np.sin(q2 + q3) - l4 * np.sin(q2 + q3 + q4),
    ]
    np.testing.assert_allclose(_batch_fk("youbot-4r", Q), expected, atol=1e-12)


def test_youbot_4r_start_position_and_manipulability() -> None:
    robot = get_robot("youbot-4r")
    q0 = np.array([0, 0, 0, 0, 0, 0, -np.pi / 8, np.pi / 8, 0])
    np.testing.assert_allclose(robot.ee_position(q0), [0.649, 0.0, 0.304], atol=5e-4)
    assert robot.manipulability(q0) == pytest.approx(0.0100, abs=5e-5)


def test_youbot_3r_start_manipulability_matches_the_reference_runs() -> None:
    robot = get_robot("youbot-3r")
    q0 = np.array([0, -0.5, np.pi / 2, 0, 0, 0, -0.17, 0.35])
    assert robot.manipulability(q0) == pytest.approx(0.00974, abs=5e-6)


def test_car_rtr_matches_janiaktchon(rng: np.random.Generator) -> None:
    Q = _random_q(rng, 7, N_RANDOM)
    x, y, phi, x1, x2, x3 = Q[:, 0], Q[:, 1], Q[:, 2], Q[:, 4], Q[:, 5], Q[:, 6]
    reach = 0.5 + 0.5 * np.cos(x3)
    expected = np.c_[
        x + reach * np.cos(phi + x1), y + reach * np.sin(phi + x1), x2 + 0.5 * np.sin(x3)
    ]
    np.testing.assert_allclose(_batch_fk("car-rtr", Q), expected, atol=1e-12)


def test_diffdrive_3dof_matches_abdessemeddjebrani_eq_2(rng: np.random.Generator) -> None:
    Q = _random_q(rng, 6, N_RANDOM)
    x, y, phi, t1, t2, t3 = Q.T
    reach = 0.4 * np.cos(t2) + 0.3 * np.cos(t2 + t3)
    expected = np.c_[
        x + np.cos(t1 + phi) * reach,
        y + np.sin(t1 + phi) * reach,
        0.6 - 0.4 * np.sin(t2) - 0.3 * np.sin(t2 + t3),
    ]
    np.testing.assert_allclose(_batch_fk("diffdrive-3dof", Q), expected, atol=1e-12)


def test_omni_3dof_matches_abdessemeddjebrani_eq_33(rng: np.random.Generator) -> None:
    Q = _random_q(rng, 6, N_RANDOM)
    x, y, th, q1, q2, q3 = Q.T
    a, b, a1, a2, a3 = 0.2, 0.0, 0.6, 0.4, 0.3
    reach = a3 * np.cos(q2 + q3) + a2 * np.cos(q2)
    u, v = a + np.cos(q1) * reach, b + np.sin(q1) * reach
    expected = np.c_[
        x + u * np.cos(th) - v * np.sin(th),
        y + u * np.sin(th) + v * np.cos(th),
        a1 - a2 * np.sin(q2) - a3 * np.sin(q2 + q3),
    ]
    np.testing.assert_allclose(_batch_fk("omni-3dof", Q), expected, atol=1e-12)


def _dh(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    ct, st, ca_, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array(
        [
            [ct, -st * ca_, st * sa, a * ct],
            [st, ct * ca_, -ct * sa, a * st],
            [0, sa, ca_, d],
            [0, 0, 0, 1],
        ]
    )


def test_base_6dof_matches_standard_dh_product(rng: np.random.Generator) -> None:
    robot = get_robot("base-6dof")
    for _ in range(50):
        q = rng.uniform(-np.pi, np.pi, 9)
        T = np.eye(4)
        T[:3, :3] = [[np.cos(q[2]), -np.sin(q[2]), 0], [np.sin(q[2]), np.cos(q[2]), 0], [0, 0, 1]]
        T[:3, 3] = [q[0], q[1], base_6dof.SHOULDER_HEIGHT]
        for qi, (d, a, alpha) in zip(q[3:], base_6dof.dh_scaled(), strict=True):
            T = T @ _dh(qi, d, a, alpha)
        tip = T[:3, :3] @ [0, 0, base_6dof.TOOL] + T[:3, 3]
        np.testing.assert_allclose(robot.ee_position(q), tip, atol=1e-12)


@pytest.mark.parametrize("name", robot_names())
def test_collision_points_follow_the_platform(name: str) -> None:
    robot = robot_or_skip(name)
    q = np.zeros(robot.n)
    P0 = robot.collision_points(q)
    q[0], q[1] = 1.5, -2.0
    np.testing.assert_allclose(robot.collision_points(q), P0 + [1.5, -2.0, 0.0], atol=1e-12)
    assert P0.shape == (len(robot.collision), 3)


def test_base_6dof_pose_manipulability_matches_closed_form(rng: np.random.Generator) -> None:
    """The tree's 6x6 tool-Jacobian measure equals [Nagatani]'s closed form
    a2 |s5| |d4 c3 + a3 s3| |r|."""
    from mmplan.robot.library.base_6dof_ik import PumaGeometry, manipulability

    robot = get_robot("base-6dof")
    Q = rng.uniform(-np.pi, np.pi, size=(100, 9))
    expected = manipulability(PumaGeometry.base_6dof(), Q[:, 3:])
    fn = robot.functions["manipulability"].map(Q.shape[0])
    np.testing.assert_allclose(np.asarray(fn(Q.T)).ravel(), expected, atol=1e-12)
