"""The command line with URDF robots: ``mmplan robots`` without example-robot-data, and
``plan`` + ``check`` + ``report`` of scenario files whose ``robot`` is a URDF (the unmodified
tiago.urdf of example-robot-data; a small URDF next to the scenario file)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml
from click.testing import CliRunner, Result

from mmplan.cli.main import main
from mmplan.extras import install_command
from mmplan.robot import library, robot_data
from tests.eta_planner import METHOD
from tests.scenario.mini_urdf import mini_entry, write_mini

TIAGO = "package://tiago_description/robots/tiago.urdf"


def run(*args: str) -> Result:
    return CliRunner().invoke(main, list(args))


def test_robots_lists_real_robots_as_not_installed_without_their_files(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(robot_data, "_candidates", lambda: [])  # example-robot-data "missing"
    monkeypatch.setattr(library, "_CACHE", {})
    monkeypatch.setenv("COLUMNS", "300")  # one line per robot
    result = run("robots")
    assert result.exit_code == 0, result.output
    rows = [line.split("│") for line in result.stdout.splitlines() if line.startswith("│")]
    described = {cells[1].strip(): cells[5].strip() for cells in rows if len(cells) == 7}
    for name in ("tiago", "ur5-omni"):
        assert described[name] == "not installed (below)"
    # the command whole after the tables, however narrow the output (new-user trial: cut)
    assert f"not installed (tiago, ur5-omni): {install_command('robots')}" in result.stdout
    assert described["youbot-3r"].startswith("KUKA youBot")


def test_scenarios_say_which_robots_are_not_installed(monkeypatch: pytest.MonkeyPatch) -> None:
    """A TIAGo scenario is not "installed" without example-robot-data (found by a new-user
    trial: the method was installed, the robot was not); names whole in a pipe."""
    monkeypatch.setattr(robot_data, "_candidates", lambda: [])  # example-robot-data "missing"
    monkeypatch.delenv("MMPLAN_PACKAGE_PATH", raising=False)
    result = run("scenarios")
    assert result.exit_code == 0, result.output
    rows = [[c.strip() for c in line.split("│")[1:-1]] for line in result.stdout.splitlines()
            if line.startswith("│")]  # fmt: skip
    installed = {cells[0]: (cells[1], cells[3]) for cells in rows}
    assert installed["tiago-table"] == ("tiago", "no")
    assert installed["diffdrive3-track"] == ("diffdrive-3dof", "yes")  # not cut in a pipe
    assert installed["youbot3r-obstacles-torque"][1] == "yes"
    # a scenario's own URDF robot from example-robot-data too (new-user trial: "yes")
    assert installed["tiago-wall-line"] == ("tiago-pen", "no")
    assert installed["tiago-wall-segment"] == ("tiago-pen", "no")
    reason = [line for line in result.stdout.splitlines() if line.startswith("not installed")]
    assert len(reason) == 2 and "tiago-table" in reason[0] and "ur5-omni-table" in reason[0]
    assert reason[0].endswith(install_command("robots"))
    assert "tiago-wall-line" in reason[1] and install_command("robots") in reason[1]


def tiago_scenario(urdf: str = TIAGO) -> dict[str, Any]:
    return {
        "name": "tiago-drive",
        "robot": {"urdf": urdf,
                  "platform": {"kind": "differential-drive",
                               "wheels": ["wheel_left_joint", "wheel_right_joint"],
                               "wheel_radius": 0.0985, "half_track": 0.2022},
                  "end_effector": "arm_7_link",
                  "locked": {"head_1_joint": 0.0, "head_2_joint": 0.0},
                  "collision": {"tolerance": 0.05}},
        "start": {"x": 0.0, "y": 0.0, "theta": 0.0, "torso_lift_joint": 0.15,
                  "arm_1_joint": 0.2},
        # arm_7_link at the start is at (0.2565, -0.7166, 0.8565); drive 0.2 m forward
        "goal": {"position": [0.4565, -0.7166, 0.8565], "tolerance": 0.01},
        "obstacles": [{"shape": "cylinder", "base_center": [2.0, 1.0, 0.0], "radius": 0.3,
                       "height": 1.0}],
        "limits": {"torque": "unlimited"},  # the test planner writes no effort columns
        "planner": {"method": METHOD, "eta": [3.0, 3.0] + [0.0] * 8, "t_max": 2.0, "dt": 0.02},
    }


def test_plan_check_report_of_the_unmodified_tiago_urdf(tmp_path: Path) -> None:
    from tests.robot.urdf_oracle import robot_data_dir

    robot_data_dir()  # skips (with the reason) without example-robot-data
    pytest.importorskip("matplotlib", reason="mmplan report needs the report extra")
    scenario = tmp_path / "tiago.yaml"
    scenario.write_text(yaml.safe_dump(tiago_scenario()))
    out = tmp_path / "run"
    result = run("plan", str(scenario), "--out", str(out))
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["robot"] == "tiago" and summary["status"] == "reached"
    assert summary["check_passed"] and summary["min_self_clearance_m"] > 0
    recorded = yaml.safe_load((out / "scenario.yaml").read_text())["robot"]
    assert recorded["urdf"] == TIAGO and recorded["end_effector"] == "arm_7_link"
    header = (out / "trajectory.csv").read_text().splitlines()[0].split(",")
    assert "q.arm_1_joint" in header and "dq.wheel_left_joint" in header

    result = run("check", str(out))
    assert result.exit_code == 0 and "check passed" in result.stdout, result.output
    result = run("report", str(out))
    assert result.exit_code == 0, result.output
    assert (out / "report.html").stat().st_size > 0


def test_plan_and_check_of_a_urdf_next_to_the_scenario(tmp_path: Path) -> None:
    pytest.importorskip("pinocchio", reason="URDF robots need Pinocchio")
    write_mini(tmp_path / "robots")
    data = {"name": "mini-drive", "robot": mini_entry("robots/mini.urdf"),
            "start": {"joint2": 0.3},
            "goal": {"position": [0.6253, 0.0477, 0.4522], "tolerance": 0.01},  # ee + 0.15 m x
            "planner": {"method": METHOD, "eta": [2.0, 2.0, 0.0, 0.0], "t_max": 2.0,
                        "dt": 0.02}}
    (tmp_path / "scenarios").mkdir()
    scenario = tmp_path / "scenarios" / "mini.yaml"
    data["robot"]["urdf"] = "../robots/mini.urdf"
    scenario.write_text(yaml.safe_dump(data))
    out = tmp_path / "run"
    result = run("plan", str(scenario), "--out", str(out))
    assert result.exit_code == 0, result.output
    assert json.loads((out / "summary.json").read_text())["robot"] == "mini"
    result = run("check", str(out))
    assert result.exit_code == 0 and "check passed" in result.stdout, result.output

    data["robot"]["end_effector"] = "gripper"
    scenario.write_text(yaml.safe_dump(data))
    result = run("plan", str(scenario), "--out", str(tmp_path / "bad"))
    assert result.exit_code == 2
    assert result.stderr.startswith(f"error: {scenario}: robot.end_effector: unknown frame "
                                    "'gripper'")
    assert len(result.stderr.strip().splitlines()) == 1
