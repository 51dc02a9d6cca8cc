"""``mmplan export``: exit codes, one-line errors, nothing written on bad input, output."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner, Result

import mmplan
from mmplan.cli.main import main
from mmplan.extras import install_command
from tests.cli.test_cli import BASE
from tests.eta_planner import METHOD


def run(*args: str) -> Result:
    return CliRunner().invoke(main, list(args))


@pytest.fixture(scope="module")
def plan_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An honest 'timeout' plan of the test planner (1 s, steps of 0.01 s; check passes)."""
    folder = tmp_path_factory.mktemp("plan")
    (folder / "s.yaml").write_text(yaml.safe_dump(BASE))
    assert run("plan", str(folder / "s.yaml"), "--out", str(folder / "p"), "-q").exit_code == 3
    return folder / "p"


def test_export_writes_a_plan_folder_that_checks(plan_dir: Path, tmp_path: Path) -> None:
    result = run("export", str(plan_dir), "--rate", "30", "--out", str(tmp_path / "E"))
    assert result.exit_code == 0, result.output
    assert "resampled 101 -> 31 samples at 30 Hz" in result.stdout
    assert "check passed" in result.stdout
    assert run("check", str(tmp_path / "E")).exit_code == 0
    tr, _ = mmplan.read_plan(tmp_path / "E")
    np.testing.assert_allclose(np.diff(tr.t), 1 / 30, atol=1e-12)


def test_export_writes_a_bag(plan_dir: Path, tmp_path: Path) -> None:
    pytest.importorskip("rosbags", reason="rosbags not installed (pip install 'mmplan[ros]')")
    result = run("export", str(plan_dir), "--ros2", str(tmp_path / "bag"), "-q")
    assert result.exit_code == 0 and result.output == ""
    assert (tmp_path / "bag" / "metadata.yaml").is_file()
    result = run("export", str(plan_dir), "--ros2", str(tmp_path / "bag2"))
    assert "/joint_trajectory 1, /base_path 1, /cmd_vel 101" in result.stdout  # 100 Hz, 1 s


@pytest.mark.parametrize(("args", "expected"), [
    (["--rate", "0"], "--rate: 0.0 Hz is outside [1, 10000] Hz"),
    (["--rate", "-3"], "--rate: -3.0 Hz is outside"),
    (["--rate", "nan"], "--rate: nan Hz is outside"),
    (["--rate", "1e6"], "--rate: 1000000.0 Hz is outside"),
    ([], "nothing to write: give --out DIR and/or --ros2 BAG"),
])
def test_bad_arguments_exit_2_with_one_line(plan_dir: Path, tmp_path: Path, args: list[str],
                                            expected: str) -> None:
    out = [] if args == [] else ["--out", str(tmp_path / "E")]
    result = run("export", str(plan_dir), *args, *out)
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and expected in lines[0], lines
    assert not (tmp_path / "E").exists()


def test_bad_outputs_exit_2_and_write_nothing(plan_dir: Path, tmp_path: Path) -> None:
    (tmp_path / "file").write_text("x")
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "mine.txt").write_text("keep")
    usage = run("export", str(plan_dir), "--out", str(tmp_path / "file"))  # click's own check
    assert usage.exit_code == 2 and "is a file" in usage.stderr
    cases = [
        (["--out", str(tmp_path / "full")], "--out: ", "is not a plan directory"),
        (["--out", str(plan_dir / "inside")], "--out: ", "plan folder being exported"),
        (["--out", str(plan_dir)], "--out: ", "plan folder being exported"),
        (["--ros2", "/proc/mmplan-bag"], "--ros2: ", "cannot create /proc/mmplan-bag"),
        (["--ros2", str(tmp_path / "full")], "--ros2: ", "is not a rosbag2 folder"),
        (["--out", str(tmp_path / "E"), "--ros2", str(tmp_path / "E" / "bag")], "--ros2: ",
         "overlap"),
    ]
    if "rosbags" not in sys.modules:
        pytest.importorskip("rosbags", reason="rosbags not installed (pip install 'mmplan[ros]')")
    before = sorted(p.name for p in tmp_path.iterdir())
    for args, field, problem in cases:
        result = run("export", str(plan_dir), *args)
        lines = result.stderr.strip().splitlines()
        assert result.exit_code == 2 and len(lines) == 1, (args, result.output)
        assert lines[0].startswith(f"error: {field}") and problem in lines[0], (args, lines)
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert (tmp_path / "full" / "mine.txt").read_text() == "keep"
    assert sorted(p.name for p in plan_dir.iterdir()) == sorted(
        ["trajectory.csv", "summary.json", "scenario.yaml", "history.csv"])


def test_missing_plan_folder_exits_2(tmp_path: Path) -> None:
    result = run("export", str(tmp_path / "nope"), "--out", str(tmp_path / "E"))
    assert result.exit_code == 2
    assert result.stderr.strip() == f"error: {tmp_path / 'nope'}: no such directory"
    assert not (tmp_path / "E").exists()


def test_without_rosbags_names_the_extra(plan_dir: Path, tmp_path: Path,
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "rosbags", None)  # import rosbags raises ImportError
    result = run("export", str(plan_dir), "--out", str(tmp_path / "E"),
                 "--ros2", str(tmp_path / "bag"))
    assert result.exit_code == 2
    assert result.stderr.strip() == ("error: --ros2: writing a ROS 2 bag needs the rosbags "
                                     "package: " + install_command("ros"))
    assert list(tmp_path.iterdir()) == []  # checked before anything is written


def _fast_plan(tmp_path: Path) -> Path:
    """A plan at 1 kHz whose first arm joint oscillates at 8 Hz: 100 Hz cannot resolve it."""
    sc = mmplan.Scenario.from_dict({**BASE, "planner": {"method": METHOD, "eta": [0] * 5}})
    problem = sc.build()
    robot = problem.robot
    t = np.arange(0, 0.5, 1e-3)
    w, j = 2 * math.pi * 8, robot.coordinates.index("q1")
    q = np.tile(np.asarray(problem.start, dtype=float), (len(t), 1))
    dq, ddq = np.zeros_like(q), np.zeros_like(q)
    q[:, j] += 1e-3 * np.sin(w * t)
    dq[:, j] = 1e-3 * w * np.cos(w * t)
    ddq[:, j] = -1e-3 * w * w * np.sin(w * t)
    ee = np.array([robot.ee_position(x) for x in q])
    tau = np.array([robot.actuator_efforts(*row) for row in zip(q, dq, ddq, strict=True)])
    tr = mmplan.Trajectory(robot.coordinates, t, q, dq, ddq, ee, actuators=robot.actuators,
                           tau=tau)  # the robot has torque limits: the checker wants efforts
    result = mmplan.PlanResult(mmplan.Status.STALLED, tr, METHOD)
    return mmplan.write_plan(tmp_path / "fast", result, problem, sc)


def test_failed_check_exits_3_with_fail_lines_and_a_hint(tmp_path: Path) -> None:
    fast = _fast_plan(tmp_path)
    assert run("check", str(fast)).exit_code == 0
    result = run("export", str(fast), "--out", str(tmp_path / "E"))
    assert result.exit_code == 3, result.output
    lines = result.stderr.strip().splitlines()
    assert lines[0].startswith("FAIL dq consistency")
    assert lines[-1] == ("hint: the plan's own steps are down to 0.001 s; a higher --rate "
                         "(up to 1000 Hz) resolves its motion")
    assert "1 checks failed" in result.stdout and (tmp_path / "E" / "summary.json").is_file()
    assert run("export", str(fast), "--rate", "1000", "--out", str(tmp_path / "E")).exit_code == 0


def test_help_names_exit_codes_and_topics() -> None:
    result = run("export", "--help")
    assert result.exit_code == 0 and "Exit code 0" in result.stdout
    for word in ("/joint_trajectory", "/cmd_vel", "/base_path", "mmplan export runs/youbot"):
        assert word in result.stdout
