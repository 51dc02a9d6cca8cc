"""Vectorized PUMA IK, Jacobian and manipulability against the robot model (base-6dof)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from mmplan.errors import ModelError
from mmplan.robot.library import base_6dof_ik as puma_ik
from mmplan.robot.library import get_robot
from mmplan.robot.library.base_6dof_ik import PumaGeometry

GEOM = PumaGeometry.base_6dof()
BRANCHES = [(s, e, f) for s in (1, -1) for e in (1, -1) for f in (False, True)]


@pytest.fixture(scope="module")
def fk() -> ca.Function:
    """Robot-model FK: q (9,) -> (tool tip (3,), flange rotation (3, 3)), batched by map."""
    robot = get_robot("base-6dof")
    s = robot.symbols
    return ca.Function("fk", [s.q], [s.ee_position, s.ee_rotation])


def model_pose(fk: ca.Function, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World tool tip (N, 3) and flange rotation (N, 3, 3) of the robot model."""
    p, R = fk.map(len(q))(q.T)
    p = np.asarray(p).T
    R = np.asarray(R).reshape(3, len(q), 3).transpose(1, 0, 2)  # columns stacked by map
    return p, R


def random_configs(rng: np.random.Generator, n: int) -> np.ndarray:
    base = np.column_stack([rng.uniform(-1, 1, n), rng.uniform(-1, 1, n),
                            rng.uniform(-np.pi, np.pi, n)])
    return np.column_stack([base, rng.uniform(-np.pi, np.pi, (n, 6))])


def test_model_pose_layout(fk: ca.Function) -> None:
    """The batched reshaping of ee_rotation matches a single evaluation."""
    q = np.linspace(0.1, 0.9, 9)
    p1, R1 = fk(q)
    p, R = model_pose(fk, np.stack([q, q]))
    np.testing.assert_allclose(R[1], np.asarray(R1), atol=1e-15)
    np.testing.assert_allclose(p[0], np.asarray(p1).ravel(), atol=1e-15)


def test_forward_matches_robot_model(fk: ca.Function, rng: np.random.Generator) -> None:
    """puma_ik's DH chain (arm frame) + base transform = the robot's symbolic tree."""
    q = random_configs(rng, 50)
    p_model, R_model = model_pose(fk, q)
    p_arm, R_arm = puma_ik.tool_pose(GEOM, q[:, 3:])
    for i in range(len(q)):
        x, y, th = q[i, :3]
        Rz = np.array([[np.cos(th), -np.sin(th), 0], [np.sin(th), np.cos(th), 0], [0, 0, 1]])
        np.testing.assert_allclose(Rz @ p_arm[i] + [x, y, GEOM.shoulder_height], p_model[i],
                                   atol=1e-12)
        np.testing.assert_allclose(Rz @ R_arm[i], R_model[i], atol=1e-12)


@pytest.mark.parametrize("branch", BRANCHES)
def test_ik_reproduces_pose_through_model_fk(fk: ca.Function, rng: np.random.Generator,
                                              branch: tuple[int, int, bool]) -> None:
    """FK of the robot model at the IK solution gives back the pose (1e-9) at random poses."""
    q = random_configs(rng, 300)
    p_world, R_world = model_pose(fk, q)
    sol = []
    for i in range(len(q)):  # base poses differ per sample: express each in its arm frame
        p_arm, R_arm = puma_ik.base_to_arm(GEOM, q[i, :2], q[i, 2], p_world[i], R_world[i])
        sol.append((p_arm[0], R_arm))
    P = np.array([s[0] for s in sol])
    R = np.array([s[1] for s in sol])
    out = puma_ik.inverse(GEOM, P, R, *branch)
    assert out.reachable.all()  # every FK pose is reachable in every branch (generic poses)
    q_ik = np.column_stack([q[:, :3], out.q])
    p2, R2 = model_pose(fk, q_ik)
    assert np.abs(p2 - p_world).max() < 1e-9
    assert np.abs(R2 - R_world).max() < 1e-9
    assert np.all(np.abs(out.q) <= np.pi + 1e-12)


def test_branches_differ_and_follow_their_definition(rng: np.random.Generator) -> None:
    q = random_configs(rng, 100)[:, 3:]
    p, R = puma_ik.tool_pose(GEOM, q)
    sols = {b: puma_ik.inverse(GEOM, p, R, *b).q for b in BRANCHES}
    default = sols[(1, 1, False)]
    a2, a3, d4 = GEOM.a[1], GEOM.a[2], GEOM.d[3]
    q2, q23 = default[:, 1], default[:, 1] + default[:, 2]
    r = a2 * np.cos(q2) + a3 * np.cos(q23) - d4 * np.sin(q23)
    assert np.all(r > 0)  # shoulder +: wrist centre in front of axis 1
    assert np.all(default[:, 4] <= 1e-12)  # no flip: s5 <= 0
    assert np.all(sols[(1, 1, True)][:, 4] >= -1e-12)
    # the elbow branches differ in q3
    assert np.abs(default[:, 2] - sols[(1, -1, False)][:, 2]).min() > 1e-6


def test_pose_manipulability_equals_full_ik(rng: np.random.Generator) -> None:
    """The grid's fast path (no wrist angles) = closed-form w of the full IK solution."""
    P = rng.uniform(-0.4, 0.4, (3000, 3))
    R = puma_ik.tool_pose(GEOM, rng.uniform(-np.pi, np.pi, (1, 6)))[1][0]
    for b in BRANCHES:
        sol = puma_ik.inverse(GEOM, P, R, *b)
        w, ok = puma_ik.pose_manipulability(GEOM, P, R, b[0], b[1])
        assert 0.1 < ok.mean() < 0.9
        np.testing.assert_array_equal(ok, sol.reachable)
        np.testing.assert_allclose(w, np.where(ok, puma_ik.manipulability(GEOM, sol.q), 0.0),
                                   atol=1e-15)


def test_unreachable_poses_are_flagged() -> None:
    R = np.eye(3)
    P = np.array([
        [2.0, 0.0, 0.0],            # beyond the reach
        [0.0, 0.0, 0.0],            # wrist centre on axis 1 (closer than d3)
        [0.0, 0.0, 1.0],            # above the reach
        [0.25, 0.05, 0.1],          # a reachable one
    ])
    out = puma_ik.inverse(GEOM, P, R)
    assert out.reachable.tolist() == [False, False, False, True]
    assert np.all(out.q[~out.reachable] == 0.0)
    assert np.isfinite(out.q).all()


def test_jacobian_matches_finite_differences_of_model_fk(fk: ca.Function,
                                                         rng: np.random.Generator) -> None:
    """6x6 tool Jacobian (v, omega) vs central differences of the robot model's FK."""
    q = random_configs(rng, 10)
    h = 1e-6
    J = puma_ik.jacobian(GEOM, q[:, 3:])
    for i in range(len(q)):
        th = q[i, 2]
        Rz = np.array([[np.cos(th), -np.sin(th), 0], [np.sin(th), np.cos(th), 0], [0, 0, 1]])
        fd = np.zeros((6, 6))
        R0 = model_pose(fk, q[i][None])[1]
        for j in range(6):
            e = np.zeros(9)
            e[3 + j] = h
            pp, Rp = model_pose(fk, (q[i] + e)[None])
            pm, Rm = model_pose(fk, (q[i] - e)[None])
            fd[:3, j] = (pp[0] - pm[0]) / (2 * h)
            W = (Rp[0] - Rm[0]) / (2 * h) @ R0[0].T  # skew(omega)
            fd[3:, j] = [W[2, 1], W[0, 2], W[1, 0]]
        J_world = np.block([[Rz, np.zeros((3, 3))], [np.zeros((3, 3)), Rz]]) @ J[i]
        np.testing.assert_allclose(J_world, fd, atol=1e-8)
        w_fd = np.sqrt(np.linalg.det(fd @ fd.T))
        assert abs(puma_ik.manipulability(GEOM, q[i, 3:][None])[0] - w_fd) < 1e-9


def test_closed_form_manipulability_equals_det(rng: np.random.Generator) -> None:
    q = rng.uniform(-np.pi, np.pi, (2000, 6))
    J = puma_ik.jacobian(GEOM, q)
    np.testing.assert_allclose(puma_ik.manipulability(GEOM, q), np.abs(np.linalg.det(J)),
                               atol=1e-15)
    # singular configurations: wrist (q5 = 0) and elbow (d4 c3 + a3 s3 = 0)
    q[:10, 4] = 0.0
    q[10:20, 2] = np.arctan2(-GEOM.d[3], GEOM.a[2])
    assert np.allclose(puma_ik.manipulability(GEOM, q[:20]), 0.0, atol=1e-15)


def test_geometry_rejects_other_structures() -> None:
    g = PumaGeometry.base_6dof()
    with pytest.raises(ModelError):
        PumaGeometry(g.d, (0.1, *g.a[1:]), g.alpha, g.tool, g.shoulder_height)
    with pytest.raises(ModelError):
        PumaGeometry(g.d, g.a, (0.0, *g.alpha[1:]), g.tool, g.shoulder_height)


def test_joint_rates_match_finite_differences_of_ik(rng: np.random.Generator) -> None:
    """dq/ds, d2q/ds2 of the IK solution along a tool line moving at v with acceleration a."""
    q0 = np.array([0.3, -0.6, -1.0, 0.4, -0.8, 0.5])
    p0, R = puma_ik.tool_pose(GEOM, q0[None])
    v = np.array([0.05, -0.1, 0.08])
    acc = np.array([0.2, 0.1, -0.3])

    def q_at(s: float) -> np.ndarray:
        return puma_ik.inverse(GEOM, p0 + s * v + 0.5 * s**2 * acc, R[0]).q[0]

    q = q_at(0.0)
    np.testing.assert_allclose(q, q0, atol=1e-12)  # q0 is on the default branch
    dq, ddq = puma_ik.joint_rates(GEOM, q[None], v[None], acc[None])
    h = 1e-4
    fd1 = (q_at(h) - q_at(-h)) / (2 * h)
    fd2 = (q_at(h) - 2 * q + q_at(-h)) / h**2
    np.testing.assert_allclose(dq[0], fd1, atol=1e-7)
    np.testing.assert_allclose(ddq[0], fd2, atol=1e-5)
