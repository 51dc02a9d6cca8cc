"""Which collision spheres the floor applies to (``mmplan.robot.ground``), checked numerically:
a sphere is a ground sphere exactly when its height changes as the arm moves."""

from __future__ import annotations

import numpy as np
import pytest

from mmplan.robot import Robot, robot_names
from mmplan.robot.ground import floor_clearance_sym, floor_clearances, ground_sphere_indices
from tests.robot.robots import robot_or_skip

#: Expected ground spheres per built-in robot: how many, and on which bodies.
EXPECTED = {
    "youbot-3r": (5, {"link2", "link3"}),
    "youbot-4r": (5, {"link2", "link3", "link4"}),
    "car-rtr": (5, {"forearm"}),
    "diffdrive-3dof": (6, {"link2", "link3"}),
    "omni-3dof": (6, {"link2", "link3"}),
    "base-6dof": (5, {"link3"}),
    "tiago": (59, {"torso_lift_link", *(f"arm_{i}_link" for i in range(1, 8))}),
    "ur5-omni": (14, {"upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link",
                      "wrist_3_link"}),
}


def random_configurations(robot: Robot, rng: np.random.Generator, k: int) -> np.ndarray:
    """k configurations (k, n): platform coordinates in [-3, 3], arm joints inside their
    limits (infinite ones taken as +-pi)."""
    q = rng.uniform(-3.0, 3.0, size=(k, robot.n))
    lo = np.clip(robot.limits.joint_min, -np.pi, np.pi)
    hi = np.clip(robot.limits.joint_max, -np.pi, np.pi)
    q[:, list(robot.arm_indices)] = lo + (hi - lo) * rng.random((k, len(lo)))
    return q


def heights(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Sphere centre heights (k, P) by the robot's numeric forward kinematics."""
    return np.array([robot.collision_points(x)[:, 2] for x in q])


@pytest.mark.parametrize("name", robot_names())
def test_ground_spheres_are_those_whose_height_moves_with_the_arm(name: str) -> None:
    """Independent of the symbolic rule: vary the arm joints only (platform fixed), then the
    platform only (arm fixed); a ground sphere's height changes with the first and never with
    the second, every other sphere's height never changes."""
    robot = robot_or_skip(name)
    rng = np.random.default_rng(7)
    q = random_configurations(robot, rng, 24)
    arm_only = q.copy()
    arm_only[:, : robot.n_platform] = q[0, : robot.n_platform]
    platform_only = q.copy()
    platform_only[:, list(robot.arm_indices)] = q[0, list(robot.arm_indices)]
    moved_by_arm = np.ptp(heights(robot, arm_only), axis=0) > 1e-9
    kept = set(ground_sphere_indices(robot))
    assert kept == set(np.flatnonzero(moved_by_arm).tolist())
    by_platform = np.ptp(heights(robot, platform_only), axis=0) > 1e-9
    bodies = [robot.collision[i].body for i in np.flatnonzero(by_platform)]
    assert all("wheel" in b for b in bodies), bodies  # only wheels spin with the platform
    count, names = EXPECTED[name]
    assert len(kept) == count and {robot.collision[i].body for i in kept} == names
    assert not any("wheel" in robot.collision[i].body for i in kept)


def test_tiago_wheels_are_left_out_although_their_height_depends_on_q() -> None:
    """TIAGo's wheel spheres spin with the wheel angles (their height depends on q) and reach
    below z = 0 in every pose: a floor on them would reject every start."""
    robot = robot_or_skip("tiago")
    wheels = [i for i, c in enumerate(robot.collision) if "wheel" in c.body]
    assert wheels and not set(wheels) & set(ground_sphere_indices(robot))
    q = random_configurations(robot, np.random.default_rng(3), 8)
    low = heights(robot, q)[:, wheels] - robot.collision_radii[wheels]
    assert (low.min(axis=1) < -0.015).all()  # 1.9 to 5.1 cm below in 300 random poses
    assert np.ptp(heights(robot, q)[:, wheels], axis=0).max() > 1e-3


@pytest.mark.parametrize("name", ["youbot-3r", "car-rtr", "ur5-omni"])
def test_floor_clearances_match_the_sphere_heights(name: str) -> None:
    robot = robot_or_skip(name)
    q = random_configurations(robot, np.random.default_rng(1), 5)
    idx = list(ground_sphere_indices(robot))
    expected = heights(robot, q)[:, idx] - robot.collision_radii[idx][None, :] - 0.3
    assert np.allclose(floor_clearances(robot, q, 0.3), expected, atol=1e-12)
    sym = floor_clearance_sym(robot, 0.3)
    import casadi as ca

    fn = ca.Function("c", [robot.symbols.q], [sym])
    assert np.allclose(np.asarray(fn(q[2])).ravel(), expected[2], atol=1e-12)
