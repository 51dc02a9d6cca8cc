"""Symbolic core of the extended-Jacobian planner: every derivative against finite differences.

Covers H, g ([PajakPajak] eq. (11)), de_I/dq, v1 (third derivatives of k), the generator's error
dynamics (eq. (16)), the wheel-metric projector, the obstacle push and the torque split
tau = T0 + Tm ddq, and that g = 0 at a constrained optimum does not depend on the partition;
the cheaper structured forms (structure.py) against the straightforward reference build.
"""

from __future__ import annotations

import itertools

import casadi as ca
import numpy as np
import pytest

from mmplan.errors import InputError
from mmplan.planners.extended_jacobian.criterion import Partition, build_criterion, choose_partition
from mmplan.planners.extended_jacobian.generator import (
    ObstacleTerm,
    build_functions,
    wheel_metric_inverse,
)
from mmplan.planners.extended_jacobian.structure import (
    reduced_manipulability,
    rigid_coordinates,
    structured_solve,
)
from mmplan.robot.library import get_robot, robot_names
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
        # what the generator's parameter vector takes of a model (parameters.py)
        self.center, self.semi_axes, self.exponents, self.yaw = center, axes, (1.0, 1.0), 0.0

    def radial_distance_sym(self, p: ca.SX) -> ca.SX:
        d = (p - self.c) / self.a
        F = ca.sumsqr(d)
        return ca.norm_2(p - self.c) * (1 - F ** (-0.5))

    def radial_distance(self, points: np.ndarray) -> np.ndarray:
        r = np.asarray(points, dtype=float) - self.c
        F = np.sum((r / self.a) ** 2, axis=-1)
        return np.asarray(np.linalg.norm(r, axis=-1) * (1 - F ** (-0.5)))


@pytest.fixture(scope="module")
def robot() -> Robot:
    return get_robot("youbot-3r")


@pytest.fixture(scope="module")
def crit(robot: Robot):  # type: ignore[no-untyped-def]
    return build_criterion(robot, choose_partition(robot, Q0_3R))


def _rand_state(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    q = Q0_3R + rng.uniform(-0.3, 0.3, 8)
    return q, rng.normal(size=8)


def test_partition_rule_matches_the_documented_choice(robot: Robot) -> None:
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
    p = fns.layout.pack(P_F, GAINS)
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
    p = fns.layout.pack(P_F, GAINS, [(obstacle.model, obstacle.influence)])
    _f0, _fv, fp, S_, T0, Tm, err_, _Tg, gK = (np.asarray(x) for x in fns.terms(q, dq, p))
    S, err = S_.item(), err_.item()
    assert S > 0.0  # the start lies inside obstacle 1's neighbourhood
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
    # The push is not shrunk ~800x on the platform (wheel metric, docs/extended_jacobian.md).
    assert np.linalg.norm(fp.ravel()[:2]) > 0.3 * np.linalg.norm(grad[:2])
    # tau = T0 + Tm ddq equals the robot's efforts ([PajakPajak] eq. (22)).
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
    from mmplan.planners.extended_jacobian.criterion import repartition, stacked_jacobian

    singular = Partition((0, 1, 2, 3, 4, 5), (6, 7))  # q1 cannot move the end effector's z
    better = repartition(robot, Q0_3R, singular)
    assert better is not None
    Jc = stacked_jacobian(robot, Q0_3R)
    assert np.linalg.cond(Jc[:, list(better.R)]) < 1e3
    assert sorted(better.R + better.F) == list(range(8))
    assert repartition(robot, Q0_3R, better) is None  # already the best


# --------------------------------------------------------------------------- structured forms
def _states(robot: Robot, rng: np.random.Generator, count: int) -> list[np.ndarray]:
    """Seeded random configurations, arm joints inside the central 60 % of their range."""
    lo, hi = robot.limits.joint_min, robot.limits.joint_max
    out = []
    for _ in range(count):
        q = rng.uniform(-2.0, 2.0, robot.n)
        q[list(robot.arm_indices)] = lo + (hi - lo) * rng.uniform(0.2, 0.8, len(lo))
        out.append(q)
    return out


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def _partition(robot: Robot, q: np.ndarray) -> Partition:
    """The planner's rule, or the best-conditioned Jc_R where it has none (omni bases)."""
    try:
        return choose_partition(robot, q)
    except InputError:
        Jc = np.vstack([robot.jacobian(q), robot.pfaffian(q)])
        R = min(
            itertools.combinations(range(robot.n), Jc.shape[0]),
            key=lambda c: np.linalg.cond(Jc[:, list(c)]),
        )
        return Partition(R, tuple(i for i in range(robot.n) if i not in R))


@pytest.mark.parametrize("name", robot_names())
def test_structured_criterion_equals_the_reference(name: str) -> None:
    """H, g, e_I, E = [de_I/dq; A] and v1 of the structured build equal the straightforward
    one (robot's mu, symbolic (m+h) solve) at seeded random states, for every robot.

    Tolerance 1e-9 relative: the reference's sqrt(det(J J^T)) loses digits where mu is
    small (most states agree to 1e-14)."""
    robot = get_robot(name)
    rng = np.random.default_rng(11)
    partition = _partition(robot, _states(robot, rng, 1)[0])
    fast = build_criterion(robot, partition)
    ref = build_criterion(robot, partition, structured=False)
    outs = [lambda c: c.H, lambda c: c.g, lambda c: c.e_I, lambda c: c.E, lambda c: c.v1]
    f_fast = ca.Function("f", [fast.q, fast.dq, fast.p_f], [o(fast) for o in outs])
    f_ref = ca.Function("f", [ref.q, ref.dq, ref.p_f], [o(ref) for o in outs])
    # The structured form is really used (and smaller) on every built-in robot.
    g_ops = [ca.Function("g", [c.q], [c.g]).n_instructions() for c in (fast, ref)]
    assert g_ops[0] < g_ops[1]
    for q in _states(robot, rng, 4):
        dq, p_f = rng.normal(size=robot.n), rng.normal(size=3)
        for a, b in zip(f_fast(q, dq, p_f), f_ref(q, dq, p_f), strict=True):
            assert _rel(np.asarray(a), np.asarray(b)) < 1e-9


@pytest.mark.parametrize("name", ["youbot-3r", "youbot-4r"])
def test_structured_generator_terms_equal_the_reference(name: str) -> None:
    """f0 = -E^-1 v1 and fv = -E^-1 v2 (eq. (16)) agree with the reference build."""
    robot = get_robot(name)
    rng = np.random.default_rng(12)
    partition = choose_partition(robot, _states(robot, rng, 1)[0])
    fns = [
        build_functions(robot, build_criterion(robot, partition, structured=flag), [])
        for flag in (True, False)
    ]
    assert fns[0].record is not None and fns[1].record is not None
    assert 2 * fns[0].record.n_instructions() < fns[1].record.n_instructions()
    for q in _states(robot, rng, 4):
        dq = rng.normal(size=robot.n)
        goal = rng.normal(size=3)
        (f0, fv), (g0, gv) = (
            [np.asarray(x) for x in f.terms(q, dq, f.layout.pack(goal, GAINS))[:2]] for f in fns
        )
        assert _rel(f0, g0) < 1e-10 and _rel(fv, gv) < 1e-10


def test_rigid_coordinates_and_fallback(robot: Robot) -> None:
    """mu ignores the planar pose and the arm's base joint; a partition with a platform
    coordinate in F keeps the reference transversality (same expression)."""
    assert rigid_coordinates(robot) == (0, 1, 2, 5)
    s = robot.symbols
    mu = ca.Function("mu", [s.q], [reduced_manipulability(robot), s.manipulability])
    rng = np.random.default_rng(13)
    for q in _states(robot, rng, 3):
        a, b = (float(v) for v in mu(q))
        assert a == pytest.approx(b, rel=1e-12)
        moved = q + np.where(np.isin(np.arange(8), [0, 1, 2, 5]), rng.normal(size=8), 0.0)
        assert float(mu(moved)[1]) == pytest.approx(b, rel=1e-10)
    other = Partition((0, 1, 3, 4, 5, 6), (2, 7))  # theta in F: the solve, reduced mu
    fast, ref = (build_criterion(robot, other, structured=flag) for flag in (True, False))
    g = ca.Function("g", [s.q], [fast.g, ref.g])
    for q in _states(robot, rng, 3):
        g_fast, g_ref = (np.asarray(v) for v in g(q))
        assert _rel(g_fast, g_ref) < 1e-10
    ops = [ca.Function("g", [s.q], [c.g]).n_instructions() for c in (fast, ref)]
    assert ops[0] < ops[1]


@pytest.mark.parametrize("name", ["youbot-3r", "youbot-4r", "diffdrive-3dof", "omni-3dof"])
def test_structured_solve_equals_the_dense_solve(name: str) -> None:
    """E^-1 B through ker A equals CasADi's (n) solve of E = [De; A] at seeded states."""
    robot = get_robot(name)
    rng = np.random.default_rng(14)
    crit = build_criterion(robot, _partition(robot, _states(robot, rng, 1)[0]))
    B = ca.SX.sym("B", robot.n, 3)
    E = ca.substitute(crit.E, crit.p_f, ca.DM.zeros(3))
    solves = ca.Function("x", [crit.q, B], [structured_solve(robot, E, B), ca.solve(E, B)])
    for q in _states(robot, rng, 4):
        a, b = (np.asarray(v) for v in solves(q, rng.normal(size=(robot.n, 3))))
        assert _rel(a, b) < 1e-10
