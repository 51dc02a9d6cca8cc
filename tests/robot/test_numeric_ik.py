"""Numeric IK of a general arm (mmplan.robot.numeric_ik) against independent references.

* base-6dof: the closed-form PUMA IK and its closed-form manipulability (a separate
  derivation, :mod:`mmplan.robot.library.base_6dof_ik`);
* TIAGo (7-dof arm, no closed form): targets made by forward kinematics of random joints
  within the limits, solutions checked by the robot's FK and by Pinocchio's frame placement
  of the same URDF (skipped without example-robot-data).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from mmplan.errors import InputError
from mmplan.robot.library import base_6dof_ik as puma_ik
from mmplan.robot.library import get_robot
from mmplan.robot.library.base_6dof_ik import PumaGeometry
from mmplan.robot.numeric_ik import ArmIK, planar_inverse
from mmplan.robot.urdf import UrdfRobot
from tests.robot.urdf_oracle import build_oracle, robot_data_dir


def _rz(theta: np.ndarray) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    R = np.zeros((len(theta), 3, 3))
    R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1.0
    return R


def _world_targets(ik: ArmIK, q_arm: np.ndarray, base: np.ndarray) -> tuple[np.ndarray, ...]:
    """World pose of the end effector at arm joints q_arm with platforms at base."""
    p, R = ik.forward(q_arm)
    Rz = _rz(base[:, 2])
    pw = np.einsum("nij,nj->ni", Rz, p) + np.column_stack([base[:, :2], np.zeros(len(base))])
    return pw, Rz @ R


def _full_q(robot: object, base: np.ndarray, q_arm: np.ndarray) -> np.ndarray:
    n = robot.n  # type: ignore[attr-defined]
    q = np.zeros((len(base), n))
    q[:, :3] = base
    q[:, list(robot.arm_indices)] = q_arm  # type: ignore[attr-defined]
    return q


def test_planar_inverse_undoes_the_platform_pose(rng: np.random.Generator) -> None:
    base = rng.uniform(-2, 2, (10, 3))
    p, R = rng.normal(size=(10, 3)), _rz(rng.uniform(-3, 3, 10))
    p_loc, R_loc = planar_inverse(base, p, R)
    Rz = _rz(base[:, 2])
    back = np.einsum("nij,nj->ni", Rz, p_loc) + np.column_stack([base[:, :2], np.zeros(10)])
    np.testing.assert_allclose(back, p, atol=1e-12)
    np.testing.assert_allclose(Rz @ R_loc, R, atol=1e-12)


def test_base_6dof_matches_the_closed_form(rng: np.random.Generator) -> None:
    """Full pose IK of the PUMA arm: the numeric solution reaches the pose (robot FK), and
    its w equals the closed-form manipulability of the same joints."""
    robot = get_robot("base-6dof")
    ik = ArmIK(robot, "full")
    q_true = ik.random_seeds(40, seed=3)
    base = np.column_stack([rng.uniform(-1, 1, (40, 2)), rng.uniform(-3, 3, 40)])
    pw, Rw = _world_targets(ik, q_true, base)
    res = ik.solve(base, pw, Rw, random_seeds=8, iterations=300)
    assert res.ok.mean() >= 0.9, res.ok.mean()
    q = _full_q(robot, base, res.q)
    for k in np.flatnonzero(res.ok):
        np.testing.assert_allclose(robot.ee_position(q[k]), pw[k], atol=2e-6)
    geom = PumaGeometry.base_6dof()
    np.testing.assert_allclose(ik.manipulability(res.q), puma_ik.manipulability(geom, res.q),
                               rtol=1e-9, atol=1e-12)


def test_unreachable_targets_are_not_ok_and_stay_in_the_limits() -> None:
    robot = get_robot("base-6dof")
    ik = ArmIK(robot, "none")
    res = ik.solve(np.zeros(3), np.array([[5.0, 0.0, 0.5], [0.0, 0.0, 4.0]]), random_seeds=3)
    assert not res.ok.any()
    assert (res.position_error > 1.0).all()
    assert np.all(res.q >= robot.limits.joint_min - 1e-12)
    assert np.all(res.q <= robot.limits.joint_max + 1e-12)


def test_bad_axis_and_no_seeds_raise_input_errors() -> None:
    robot = get_robot("base-6dof")
    with pytest.raises(InputError, match="axis"):
        ArmIK(robot, "axis", axis=(0.0, 0.0, 0.0))
    with pytest.raises(InputError, match="seeds"):
        ArmIK(robot, "none").solve(np.zeros(3), np.ones(3), random_seeds=0)


@pytest.mark.parametrize("orientation", ["full", "axis", "none"])
def test_tiago_arm_against_fk_and_pinocchio(orientation: str, rng: np.random.Generator) -> None:
    """TIAGo's 7-dof arm: every converged solution puts arm_tool_link where Pinocchio says
    the target is (1e-6 m) and the end-effector body arm_7_link (whose frame is the robot's
    ee_rotation) in the target orientation (or its z axis, the hand's axis, 2e-6), inside the
    limits; most targets (made reachable by FK) converge with a few seeds."""
    robot_data_dir()
    robot = get_robot("tiago")
    assert isinstance(robot, UrdfRobot)
    ik = ArmIK(robot, orientation, axis=(0.0, 0.0, 1.0))  # type: ignore[arg-type]
    N = 30
    q_true = ik.random_seeds(N, seed=11)
    base = np.column_stack([rng.uniform(-1, 1, (N, 2)), rng.uniform(-3, 3, N)])
    pw, Rw = _world_targets(ik, q_true, base)
    res = ik.solve(base, pw, Rw, random_seeds=8, iterations=200)
    assert res.ok.mean() >= 0.8, res.ok.mean()
    lo, hi = robot.limits.joint_min, robot.limits.joint_max
    assert np.all((res.q >= lo - 1e-12) & (res.q <= hi + 1e-12))
    from mmplan.robot.robot_data import robot_data_file

    oracle = build_oracle(robot, robot_data_file("tiago_description/robots/tiago.urdf"))
    tool, body = oracle.model.getFrameId("arm_tool_link"), oracle.model.getFrameId("arm_7_link")
    q = _full_q(robot, base, res.q)
    for k in np.flatnonzero(res.ok):
        pin.framesForwardKinematics(oracle.model, oracle.data, oracle.q(q[k]))
        np.testing.assert_allclose(oracle.data.oMf[tool].translation, pw[k], atol=1e-6)
        np.testing.assert_allclose(robot.ee_position(q[k]), pw[k], atol=1e-6)
        rotation = oracle.data.oMf[body].rotation
        if orientation == "full":
            np.testing.assert_allclose(rotation, Rw[k], atol=2e-6)
        elif orientation == "axis":
            np.testing.assert_allclose(rotation[:, 2], Rw[k][:, 2], atol=2e-6)
            # the hand's axis is arm_tool_link's x axis
            np.testing.assert_allclose(oracle.data.oMf[tool].rotation[:, 0], Rw[k][:, 2],
                                       atol=2e-6)


def test_score_chooses_among_converged_seeds() -> None:
    """With a score, the kept solution is the best converged seed: here the largest w, which
    is at least that of the first converged seed."""
    robot = get_robot("base-6dof")
    ik = ArmIK(robot, "none")
    target = ik.forward(ik.random_seeds(1, seed=5))[0]
    first = ik.solve(np.zeros(3), target, random_seeds=12)
    best = ik.solve(np.zeros(3), target, random_seeds=12, score=ik.manipulability)
    assert first.ok[0] and best.ok[0]
    assert ik.manipulability(best.q)[0] >= ik.manipulability(first.q)[0] - 1e-12


@pytest.mark.parametrize("name", ["base-6dof", "tiago"])
def test_reach_bounds_every_configuration(name: str) -> None:
    """No configuration puts the end effector horizontally farther from the platform origin
    than reach() (20,000 random joint vectors within the limits), and the bound is not loose
    by more than a factor 2."""
    if name == "tiago":
        robot_data_dir()
    ik = ArmIK(get_robot(name), "none")
    p, _ = ik.forward(ik.random_seeds(20_000, seed=2))
    far = float(np.linalg.norm(p[:, :2], axis=1).max())
    assert far <= ik.reach() <= 2 * far


def test_a_compiled_ik_is_loaded_again_without_its_symbolic_build(
    tmp_path: object, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The audit: every process built the arm's symbolic model again (and generated the C to
    find the library by its source). Now the library's key is the model's description; the
    loaded functions give the same numbers."""
    from mmplan.compile import codegen

    if codegen.compiler() is None:
        pytest.skip("no C compiler")
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    robot = get_robot("base-6dof")
    first = ArmIK(robot, "axis", axis=(0.0, 0.0, 1.0))
    builds: list[int] = []
    build = ArmIK._build
    monkeypatch.setattr(ArmIK, "_build", lambda self: builds.append(1) or build(self))
    again = ArmIK(robot, "axis", axis=(0.0, 0.0, 1.0))
    assert builds == [] and again.backend == first.backend == "c"
    other = ArmIK(robot, "full")
    assert builds == [1] and other.backend == "c"
    q = np.linspace(-0.4, 0.5, 2 * len(robot.arm_indices)).reshape(2, -1)
    for got, want in zip(again.forward(q), first.forward(q), strict=True):
        np.testing.assert_array_equal(got, want)
    vm = ArmIK(robot, "axis", axis=(0.0, 0.0, 1.0), compiled=False)
    np.testing.assert_allclose(again.manipulability(q), vm.manipulability(q), atol=1e-12)
