"""Symbolic core of the extended-Jacobian planner: every derivative against finite differences.

Covers H, g (eq. (11) of 000), de_I/dq, v1 (third derivatives of k), the generator's error
dynamics (eq. (16)), the wheel-metric projector, the obstacle push and the torque split
tau = T0 + Tm ddq, and that g = 0 at a constrained optimum does not depend on the partition.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from mmplan.planners.ej_criterion import Partition, build_criterion, choose_partition
from mmplan.planners.ej_dynamics import ObstacleTerm, build_functions, wheel_metric_inverse
from mmplan.robot.library import get_robot
from mmplan.robot.robot import Robot

Q0_3R = np.array([0.0, -0.5, np.pi / 2, 0.0, 0.0, 0.0, -0.17, 0.35])
P_F = np.array([3.5, 4.0, 0.16])
GAINS = (1.75, 2.78, 1.0)


class Ellipsoid:
    """Test-local smooth obstacle: radial distance to an ellipsoid (superellipsoid e1 = e2 = 1)."""

    def __init__(
        self, center: tuple[float, float, float], axes: tuple[float, float, float]
    ) -> None:
        self.c = np.asarray(center)
        self.a = np.asarray(axes)

    def radial_distance_sym(self, p: ca.SX) -> ca.SX:
        d = (p - self.c) / self.a
        F = ca.sumsqr(d)
        return ca.norm_2(p - self.c) * (1 - F ** (-0.5))


@pytest.fixture(scope="module")
def robot() -> Robot:
    return get_robot("youbot-3r")


@pytest.fixture(scope="module")
def crit(robot: Robot):  # type: ignore[no-untyped-def]
    return build_criterion(robot, choose_partition(robot, Q0_3R))


def _rand_state(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    q = Q0_3R + rng.uniform(-0.3, 0.3, 8)
    return q, rng.normal(size=8)


def test_partition_rule_matches_spec(robot: Robot) -> None:
    part = choose_partition(robot, Q0_3R)
    assert part.names(robot) == (("x", "y", "theta", "phi1", "phi2", "q2"), ("q1", "q3"))


def test_criterion_and_transversality_against_numpy(robot: Robot, crit) -> None:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(1)
    H = ca.Function("H", [crit.q], [crit.H])
    g = ca.Function("g", [crit.q], [crit.g])
    for _ in range(3):
        q, _dq = _rand_state(rng)
        h = 1e-6
        Hq = np.array([(float(H(q + h * e)) - float(H(q - h * e))) / (2 * h) for e in np.eye(8)])
        lo, hi = robot.limits.joint_min, robot.limits.joint_max
        qa = q[5:]
        mu = robot.manipulability(q)
        assert float(H(q)) == pytest.approx(
            -mu + np.sum(0.01 / (qa - lo) + 0.01 / (hi - qa)), rel=1e-12
        )
        Jc = np.vstack([robot.jacobian(q), robot.pfaffian(q)])
        R, F = [0, 1, 2, 3, 4, 6], [5, 7]
        expected = Hq[F] - np.linalg.solve(Jc[:, R], Jc[:, F]).T @ Hq[R]
        np.testing.assert_allclose(np.asarray(g(q)).ravel(), expected, atol=1e-7)


def test_error_jacobian_and_v1_against_finite_differences(crit) -> None:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(2)
    e = ca.Function("e", [crit.q, crit.p_f], [crit.e_I])
    De = ca.Function("De", [crit.q, crit.p_f], [crit.De])
    v1 = ca.Function("v1", [crit.q, crit.dq, crit.p_f], [crit.v1])
    A = ca.Function("A", [crit.q], [crit.E[5:, :]])
    for _ in range(3):
        q, dq = _rand_state(rng)
        h = 1e-6
        fd = np.column_stack(
            [
                (np.asarray(e(q + h * c, P_F)) - np.asarray(e(q - h * c, P_F))).ravel() / (2 * h)
                for c in np.eye(8)
            ]
        )
        np.testing.assert_allclose(np.asarray(De(q, P_F)), fd, atol=2e-6)
        # v1 = d/dt(De) dq and d/dt(A) dq along q(t) = q + t dq.
        h = 1e-5
        dDe = (np.asarray(De(q + h * dq, P_F)) - np.asarray(De(q - h * dq, P_F))) / (2 * h)
        dA = (np.asarray(A(q + h * dq)) - np.asarray(A(q - h * dq))) / (2 * h)
        expected = np.concatenate([dDe @ dq, dA @ dq])
        np.testing.assert_allclose(
            np.asarray(v1(q, dq, P_F)).ravel(), expected, rtol=1e-5, atol=1e-5
        )


def test_generator_realizes_error_dynamics(robot: Robot, crit) -> None:  # type: ignore[no-untyped-def]
    """ddq = f0 + fv gives de_I'' + L_V de_I' + L_P e_I = 0 and e_II' + L_II e_II = 0 (eq. (14))."""
    fns = build_functions(robot, crit, [])
    e = ca.Function("e", [crit.q, crit.p_f], [crit.e_I])
    A = ca.Function("A", [crit.q], [crit.E[5:, :]])
    rng = np.random.default_rng(3)
    q, dq = _rand_state(rng)
    p = np.concatenate([P_F, GAINS])
    out = fns.terms(q, dq, p)
    ddq = np.asarray(out[0] + out[1]).ravel()
    h = 1e-4
    # e_I along q(t) = q + t dq + t^2/2 ddq, by central differences.
    path = [q + s * dq + 0.5 * s * s * ddq for s in (-h, 0.0, h)]
    ev = [np.asarray(e(x, P_F)).ravel() for x in path]
    d1, d2 = (ev[2] - ev[0]) / (2 * h), (ev[2] - 2 * ev[1] + ev[0]) / h**2
    np.testing.assert_allclose(
        d2 + GAINS[1] * d1 + GAINS[0] * ev[1], 0.0, atol=2e-4 * max(1.0, np.abs(d2).max())
    )
    # e_II = A(q) dq with dq(t) = dq + t ddq.
    eII = [
        np.asarray(A(q + s * dq + 0.5 * s * s * ddq)).reshape(3, 8) @ (dq + s * ddq)
        for s in (-h, h)
    ]
    de2 = (eII[1] - eII[0]) / (2 * h)
    np.testing.assert_allclose(de2 + GAINS[2] * np.asarray(A(q)).reshape(3, 8) @ dq, 0.0, atol=1e-5)


def test_transversality_zero_set_does_not_depend_on_partition(robot: Robot, crit) -> None:  # type: ignore[no-untyped-def]
    """Solve e_I = 0 (partition R = {.., q2}) by Gauss-Newton; g of R = {.., q3} vanishes there."""
    other = build_criterion(robot, Partition((0, 1, 2, 3, 4, 7), (5, 6)))
    e = ca.Function("e", [crit.q, crit.p_f], [crit.e_I, crit.De])
    g2 = ca.Function("g2", [other.q], [other.g])
    p_f = np.array([0.5, 0.3, 0.2])
    q = Q0_3R.copy()
    for _ in range(60):
        val, jac = (np.asarray(x) for x in e(q, p_f))
        step = np.linalg.lstsq(jac, -val.ravel(), rcond=None)[0]
        q = q + step
        if np.linalg.norm(val) < 1e-12:
            break
    assert np.linalg.norm(np.asarray(e(q, p_f)[0])) < 1e-10
    assert np.linalg.norm(np.asarray(g2(q))) < 1e-8
    # ... and is not trivially zero elsewhere.
    assert np.linalg.norm(np.asarray(g2(Q0_3R))) > 1e-3


def test_projector_push_damping_and_torque_split(robot: Robot, crit) -> None:  # type: ignore[no-untyped-def]
    obstacle = ObstacleTerm(Ellipsoid((0.15, 0.75, 0.1), (0.3, 0.3, 0.15)), 0.35)
    fns = build_functions(robot, crit, [obstacle], varrho=1.0, arm_weight=0.3)
    q = Q0_3R.copy()
    dq = np.zeros(8)
    p = np.concatenate([P_F, GAINS])
    _f0, _fv, fp, S_, T0, Tm, err_, _Tg, gK = (np.asarray(x) for x in fns.terms(q, dq, p))
    S, err = S_.item(), err_.item()
    assert S > 0.0  # the start lies inside obstacle 1's neighbourhood (SPEC)
    # Independent K and its gradient by finite differences of the numeric penalty.
    s = ca.SX.sym("p", 3)
    C = ca.Function("C", [s], [obstacle.model.radial_distance_sym(s)])

    def K(x: np.ndarray) -> float:
        total = 0.0
        for point in robot.collision_points(x):
            c = float(C(point))
            total += ((0.35 - c) / c) ** 2 if c < 0.35 else 0.0
        return total

    assert pytest.approx(K(q), rel=1e-10) == S
    h = 1e-6
    grad = np.array([(K(q + h * e) - K(q - h * e)) / (2 * h) for e in np.eye(8)])
    np.testing.assert_allclose(gK.ravel(), grad, rtol=1e-5, atol=1e-7)
    grad[5:] *= 0.3
    A = robot.pfaffian(q)
    winv = wheel_metric_inverse(robot)
    P = np.eye(8) - (winv[:, None] * A.T) @ np.linalg.solve(A @ (winv[:, None] * A.T), A)
    np.testing.assert_allclose(fp.ravel(), P @ (-grad), rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(A @ fp.ravel(), 0.0, atol=1e-10)
    np.testing.assert_allclose(P @ P, P, atol=1e-12)
    # The projected push is not shrunk ~800x on the platform (wheel metric, SPEC pitfall).
    assert np.linalg.norm(fp.ravel()[:2]) > 0.3 * np.linalg.norm(grad[:2])
    # tau = T0 + Tm ddq equals the robot's efforts (eq. (22) of 000).
    rng = np.random.default_rng(4)
    dq, ddq = rng.normal(size=8), rng.normal(size=8)
    out = fns.terms(q, dq, p)
    T0, Tm, Tg = np.asarray(out[4]), np.asarray(out[5]), np.asarray(out[7])
    np.testing.assert_allclose(Tg.ravel(), robot.actuator_efforts(q, 0 * dq, 0 * ddq), atol=1e-10)
    np.testing.assert_allclose(
        T0.ravel() + Tm @ ddq, robot.actuator_efforts(q, dq, ddq), atol=1e-10
    )
    assert err == pytest.approx(np.linalg.norm(robot.ee_position(q) - P_F))


def test_repartition_finds_a_better_conditioned_partition(robot: Robot) -> None:
    from mmplan.planners.ej_criterion import repartition, stacked_jacobian

    singular = Partition((0, 1, 2, 3, 4, 5), (6, 7))  # q1 cannot move the end effector's z
    better = repartition(robot, Q0_3R, singular)
    assert better is not None
    Jc = stacked_jacobian(robot, Q0_3R)
    assert np.linalg.cond(Jc[:, list(better.R)]) < 1e3
    assert sorted(better.R + better.F) == list(range(8))
    assert repartition(robot, Q0_3R, better) is None  # already the best
