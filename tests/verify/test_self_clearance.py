"""Self-collision in the independent checker: a motion folding the arm into the platform fails
with the pair and the time; min_self_clearance_m is the robot's own sphere-pair distance."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mmplan import Problem, ReachPoint, Trajectory
from mmplan.robot.urdf import CollisionOptions, UrdfRobot, load_urdf_robot
from mmplan.scene import Scene
from mmplan.verify.check import check
from tests.eta_planner import EtaSettings
from tests.scenario.mini_urdf import write_mini

pytest.importorskip("pinocchio", reason="URDF robots need Pinocchio (pip install 'mmplan[urdf]')")


@pytest.fixture(scope="module")
def mini(tmp_path_factory: pytest.TempPathFactory) -> UrdfRobot:
    urdf = write_mini(tmp_path_factory.mktemp("mini"))
    return load_urdf_robot(urdf, platform={"kind": "differential-drive",
                                           "wheels": ["wheel_left_joint", "wheel_right_joint"]},
                           end_effector="tool", collision=CollisionOptions(tolerance=0.02))


def fold(robot: UrdfRobot, joint2_end: float, T: float = 2.0, dt: float = 0.02) -> Problem:
    """joint2 from 0 to ``joint2_end`` at constant speed (dq, ddq exact), arm otherwise still."""
    t = np.arange(round(T / dt) + 1) * dt
    q0 = robot.source.reference.copy()
    j = robot.index("joint2")
    q = np.tile(q0, (len(t), 1))
    q[:, j] = joint2_end * t / T
    dq = np.zeros_like(q)
    dq[:, j] = joint2_end / T
    ee = np.array([robot.ee_position(row) for row in q])
    problem = Problem(robot, Scene(()), ReachPoint(tuple(ee[-1]), 0.01), q0,
                      EtaSettings(eta=[0.0] * (robot.n - robot.h)))
    return problem, Trajectory(robot.coordinates, t, q, dq, np.zeros_like(q), ee)


def test_folding_into_the_platform_fails_with_pair_and_time(mini: UrdfRobot) -> None:
    problem, traj = fold(mini, np.pi / 2)
    report = check(traj, problem, status="reached")
    assert report.min_self_clearance_m is not None and report.min_self_clearance_m < -0.1
    # the same number as the robot's own model at the worst sample
    per_sample = [mini.self_collision_distances(q).min() for q in traj.q]
    k = int(np.argmin(per_sample))
    assert report.min_self_clearance_m == pytest.approx(per_sample[k], abs=1e-12)
    lines = [f for f in report.failures() if f.startswith("self-collision")]
    assert lines == [f"self-collision: {report.min_self_clearance_m:.4g} m < 0, "
                     f"platform vs link2 at t = {traj.t[k]:.4g} s"]
    assert traj.t[k] > 1.0 and per_sample[0] > 0  # folded late, clear at the start
    summary = report.summary(status="reached", planner="test-eta", compute_time_s=0.0)
    assert summary["min_self_clearance_m"] == report.min_self_clearance_m


def test_a_motion_that_stays_clear_passes(mini: UrdfRobot) -> None:
    problem, traj = fold(mini, 0.5)
    report = check(traj, problem, status="reached")
    assert report.min_self_clearance_m is not None and report.min_self_clearance_m > 0
    expected = min(mini.self_collision_distances(q).min() for q in traj.q)
    assert report.min_self_clearance_m == pytest.approx(expected, abs=1e-12)
    assert not [f for f in report.failures() if f.startswith("self-collision")]
    assert report.ok, report.failures()


def test_robots_without_pairs_report_none(tmp_path: Path) -> None:
    from mmplan import get_robot

    robot = get_robot("youbot-3r")
    q0 = np.array([0.0, 0, 0, 0, 0, 0, -0.17, 0.35])
    traj = Trajectory(robot.coordinates, np.array([0.0, 1.0]), np.tile(q0, (2, 1)),
                      np.zeros((2, 8)), np.zeros((2, 8)), np.tile(robot.ee_position(q0), (2, 1)))
    problem = Problem(robot, Scene(()), ReachPoint(tuple(robot.ee_position(q0)), 0.01), q0,
                      EtaSettings(eta=[0.0] * 5))
    report = check(traj, problem)
    assert report.min_self_clearance_m is None
    assert report.summary(status="reached", planner="x", compute_time_s=0.0)[
        "min_self_clearance_m"] is None
