"""Plan folders of problems built in Python, without a scenario file: the folder records the
robot (a built-in name, or the URDF load arguments), limits, start, goal, obstacles and
settings, and ``mmplan check`` rebuilds the problem from it."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import mmplan
from mmplan import InputError, Problem, ReachPoint, get_robot, read_plan, write_plan
from mmplan.cli.main import main
from mmplan.robot import Limits, Robot
from mmplan.robot.robot import CollisionSphere, EndEffector
from mmplan.scenario.from_problem import scenario_from_problem
from mmplan.scene import Box, Scene, Sphere
from mmplan.task import DrawSegment, LinePath, PolynomialPath, Task, WaypointPath
from tests.eta_planner import EtaPlanner, EtaSettings
from tests.scenario.mini_urdf import write_mini


def unlimited_efforts(robot: Robot) -> Robot:
    """The robot without effort limits (the test planner writes no tau columns)."""
    lim, inf = robot.limits, np.full(len(robot.actuators), np.inf)
    return robot.with_limits(Limits(lim.joint_min, lim.joint_max, -inf, inf, lim.rates))


def drive_problem(robot: Robot, q0: np.ndarray, ahead: float, eta: list[float],
                  obstacles: tuple[Sphere | Box, ...] = ()) -> Problem:
    """Reach the point ``ahead`` m in front of the start's end effector, driving with eta."""
    goal = robot.ee_position(q0) + np.array([ahead, 0.0, 0.0])
    return Problem(robot, Scene(obstacles), ReachPoint(tuple(goal), 0.01), q0,
                   EtaSettings(eta=eta, t_max=2.0, dt=0.02))


def check_cli(folder: Path) -> tuple[int, str]:
    result = CliRunner().invoke(main, ["check", str(folder)])
    return result.exit_code, result.output


def test_urdf_robot_built_in_python_round_trip(tmp_path: Path) -> None:
    pytest.importorskip("pinocchio", reason="URDF robots need Pinocchio")
    from mmplan.robot.urdf import CollisionOptions, load_urdf_robot

    urdf = write_mini(tmp_path / "robots")
    robot = load_urdf_robot(urdf, platform={"kind": "differential-drive",
                                            "wheels": ["wheel_left_joint", "wheel_right_joint"]},
                            end_effector="tool", locked={"head_joint": -0.4},
                            collision=CollisionOptions(tolerance=0.03), name="my-mini")
    q0 = robot.source.reference.copy()
    q0[robot.index("joint2")] = 0.3
    problem = drive_problem(robot, q0, 0.15, [2.0, 2.0, 0.0, 0.0],
                            (Sphere((3.0, 2.0, 0.5), 0.2, influence=0.3),))
    result = EtaPlanner().plan(problem)
    assert result.reached
    out = write_plan(tmp_path / "plans" / "mini-run", result, problem)  # no scenario

    recorded = yaml.safe_load((out / "scenario.yaml").read_text())
    assert recorded["name"] == "mini-run"
    assert recorded["robot"]["urdf"] == str(urdf.resolve())
    assert recorded["robot"]["name"] == "my-mini"
    assert recorded["robot"]["locked"] == {"head_joint": -0.4}
    assert recorded["robot"]["collision"]["tolerance"] == 0.03
    assert recorded["obstacles"] == [{"shape": "sphere", "center": [3.0, 2.0, 0.5],
                                      "radius": 0.2, "influence": 0.3}]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["check_passed"], summary["check_failures"]
    assert summary["robot"] == "my-mini" and summary["scenario"] == "mini-run"
    assert summary["min_self_clearance_m"] > 0

    trajectory, sc = read_plan(out)  # rebuilt from the URDF file
    assert sc.robot is not robot and sc.robot.coordinates == robot.coordinates
    assert sc.robot.collision == robot.collision
    np.testing.assert_array_equal(trajectory.q, result.trajectory.q)
    np.testing.assert_array_equal(sc.start, q0)
    assert sc.task == problem.task and sc.scene == problem.scene
    code, output = check_cli(out)
    assert code == 0 and "check passed" in output, output
    if importlib.util.find_spec("matplotlib") is not None:  # the report extra
        result = CliRunner().invoke(main, ["report", str(out)])
        assert result.exit_code == 0 and (out / "report.html").is_file(), result.output
    # the self-clearance in summary.json is recomputed by mmplan check like every number
    summary["min_self_clearance_m"] += 0.01
    (out / "summary.json").write_text(json.dumps(summary))
    code, output = check_cli(out)
    assert code == 3 and "FAIL summary min_self_clearance_m:" in output, output


def test_tiago_built_in_python_round_trip(tmp_path: Path) -> None:
    from tests.robot.urdf_oracle import robot_data_dir

    robot_data_dir()  # skips (with the reason) without example-robot-data
    tiago = unlimited_efforts(get_robot("tiago"))
    q0 = tiago.source.reference.copy()  # type: ignore[attr-defined]
    q0[tiago.index("torso_lift_joint")] = 0.15
    q0[tiago.index("arm_1_joint")] = 0.2
    eta = [3.0, 3.0] + [0.0] * (tiago.n - tiago.h - 2)
    problem = drive_problem(tiago, q0, 0.2, eta)
    result = EtaPlanner().plan(problem)
    assert result.reached
    out = write_plan(tmp_path / "tiago-run", result, problem)
    recorded = yaml.safe_load((out / "scenario.yaml").read_text())
    assert recorded["robot"] == "tiago"  # the built-in robot, by name
    assert recorded["limits"]["torque"] == "unlimited"
    code, output = check_cli(out)
    assert code == 0 and "check passed" in output, output
    trajectory, sc = read_plan(out)
    np.testing.assert_array_equal(trajectory.q, result.trajectory.q)
    assert sc.robot.coordinates == tiago.coordinates
    assert mmplan.read_summary(out)["min_self_clearance_m"] > 0


def test_a_robot_that_cannot_be_recorded_writes_nothing(tmp_path: Path) -> None:
    youbot = get_robot("youbot-3r")
    changed = Robot("my-youbot", youbot.platform, [], [], EndEffector("platform", (0.1, 0, 0.3)),
                    Limits(np.zeros(0), np.zeros(0), -np.ones(2), np.ones(2)),
                    [CollisionSphere("platform", (0, 0, 0), 0.2)])
    q0 = np.zeros(changed.n)
    problem = drive_problem(changed, q0, 0.1, [1.0, 1.0])
    result = EtaPlanner().plan(problem)
    with pytest.raises(InputError, match="'my-youbot' cannot be recorded in a plan folder"):
        write_plan(tmp_path / "none", result, problem)
    assert not (tmp_path / "none").exists()


@pytest.mark.parametrize("task", [
    ReachPoint((1.0, 2.0, 0.3), 0.005),
    LinePath((0.5, 0.0, 0.7), (0.1, 0.0, 0.0), 30.0, 0.002),
    WaypointPath(((0.0, 0.0, 1.0), (0.5, 0.2, 1.1)), (0.0, 4.0), 0.001),
    PolynomialPath(((0.0, 0.0, 1.0), (0.1, 0.1, 0.1)), 2.5, 0.001),
    DrawSegment((0.0, 0.0, 0.32), (0.0, 0.6, 0.62), (1.0, 0.0, 0.0), 0.001),
])
def test_every_goal_kind_and_the_limits_survive_the_record(task: Task) -> None:
    youbot = get_robot("youbot-3r")
    lim = youbot.limits
    robot = youbot.with_limits(Limits(lim.joint_min - 0.1, lim.joint_max, lim.torque_min,
                                      lim.torque_max * 2, lim.rates))
    q0 = np.array([0.0, 0, 0, 0, 0, 0, -0.17, 0.35])
    problem = Problem(robot, Scene((Box((2.0, 1.0, 0.2), (0.4, 0.4, 0.4), 0.3),)), task, q0,
                      EtaSettings(eta=[0.1, 0, 0, 0, 0]))
    sc = scenario_from_problem(problem, name="recorded")
    again = mmplan.Scenario.from_dict(yaml.safe_load(sc.to_yaml()), require_planner=False)
    assert again.spec.robot == "youbot-3r"
    assert again.task == task and again.scene == problem.scene
    np.testing.assert_array_equal(again.start, q0)
    for name in ("joint_min", "joint_max", "torque_min", "torque_max"):
        np.testing.assert_array_equal(getattr(again.robot.limits, name),
                                      getattr(robot.limits, name))
    assert again.robot.limits.rates.velocity == robot.limits.rates.velocity
