"""The ``mmplan`` command: every bad input gives exit 2 and one line naming the key path;
plan / check exit codes; help texts; no traceback ever."""

from __future__ import annotations

import copy
import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pytest
import yaml
from click.testing import CliRunner, Result

import mmplan
from mmplan.cli.main import main
from mmplan.extras import install_command
from mmplan.planners.base import Planner, register
from mmplan.problem import PlannerSettings, Problem, Progress
from mmplan.task import Task
from mmplan.trajectory import PlanResult, Solution
from tests.eta_planner import METHOD

BASE: dict[str, Any] = {
    "name": "cli",
    "robot": "youbot-3r",
    "start": [0, -0.5, 1.5708, 0, 0, 0, -0.17, 0.35],
    "goal": {"position": [3.5, 4.0, 0.16], "tolerance": 0.001},
    "obstacles": [
        {"shape": "superellipsoid", "center": [0.15, 0.75, 0.10], "semi_axes": [0.25, 0.25, 0.10],
         "exponents": [0.1, 1.0]},
        {"shape": "sphere", "center": [1.25, 0.70, 0.45], "radius": 0.15},
        {"shape": "cylinder", "base_center": [1.25, 2.5, 0.0], "radius": 0.40, "height": 0.10},
        {"shape": "box", "center": [2.0, 1.0, 0.2], "size": [0.4, 0.4, 0.4], "yaw": 0.0},
    ],
    "planner": {"method": METHOD, "eta": [4.0, 3.0, 0.2, 0.0, 0.0], "t_max": 1.0},
}


class CrashSettings(PlannerSettings):
    method: Literal["test-crash"] = "test-crash"


@register
class CrashPlanner(Planner[CrashSettings, Task]):
    """Raises an unexpected exception (a bug), to check that no traceback reaches the user."""

    def _solve(
        self, problem: Problem, settings: CrashSettings, task: Task, progress: Progress
    ) -> Solution:
        raise ZeroDivisionError("division by zero in step 3")


def run(*args: str) -> Result:
    return CliRunner().invoke(main, list(args))


def write(tmp_path: Path, data: dict[str, Any] | str, name: str = "scenario.yaml") -> Path:
    path = tmp_path / name
    path.write_text(data if isinstance(data, str) else yaml.safe_dump(data))
    return path


def changed(path: str, value: Any) -> dict[str, Any]:
    """BASE with the value at a dotted key path (``[i]`` for list items) replaced or deleted."""
    data = copy.deepcopy(BASE)
    parts = path.replace("[", ".").replace("]", "").split(".")
    keys = [int(k) if k.isdigit() else k for k in parts]
    node: Any = data
    for k in keys[:-1]:
        node = node[k]
    if value is DELETE:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return data


DELETE = object()
NAN = math.nan

BAD_INPUTS = [
    # (key path to change, new value, expected "key.path: problem" fragment)
    ("colour", "red", "colour: unknown key"),
    ("goal.speed", 1.0, "goal.speed: unknown key"),
    ("obstacles[1].colour", "red", "obstacles[1].colour: unknown key"),
    ("start", [0.0] * 7, "start: expected 8 values (x, y, theta, ...), got 7"),
    ("goal.position", [1.0, 2.0], "goal.position: expected 3 values (x, y, z), got 2"),
    ("start[2]", NAN, "start[2]: expected a finite number, got nan"),
    ("start[1]", "abc", "start[1]: input should be a valid number"),
    ("obstacles[1].radius", NAN, "obstacles[1].radius: expected a finite number"),
    ("obstacles[1].radius", -0.15, "obstacles[1].radius: expected a positive length in metres"),
    ("obstacles[3].size[1]", -0.4, "obstacles[3].size[1]: expected a positive length in metres"),
    ("obstacles[2].height", 0.0, "obstacles[2].height: expected a positive length in metres"),
    ("obstacles[0].exponents", [0.1], "obstacles[0].exponents: expected a list of 2 numbers"),
    ("obstacles[0].shape", "cone", "obstacles[0].shape: unknown shape 'cone'"),
    ("obstacles[0].exponents", [0.1, 3.0],  # checked by the shape itself
     "obstacles[0].exponents[1]: expected an exponent in (0, 2]"),
    ("obstacles[1].shape", DELETE, "obstacles[1].shape: required key missing"),
    ("obstacles[1].radius", DELETE, "obstacles[1].radius: missing for shape 'sphere'"),
    ("limits", {"torque": {"min": [-1.5, -1.5, -1.0, 1.0, -5.0]}},
     "limits.torque.min[3]: min 1 > max 0"),
    ("limits", {"joints": {"min": [-1, 2, -1], "max": [1, 1, 1]}},
     "limits.joints.min[1]: min 2 > max 1"),
    ("limits", {"joints": {"max": [1, 1]}},
     "limits.joints.max: expected 3 values (q1, q2, q3), got 2"),
    ("limits", {"torque": {"min": [-1, -1, -1, -1, NAN]}},
     "limits.torque.min[4]: expected a number"),
    ("limits", {"torque": "unlimted"}, "limits.torque: expected {min: [...], max: [...]} or"),
    ("robot", "r2d2", "robot: unknown robot 'r2d2'; choose one of"),
    ("planner.method", "magic", "planner.method: unknown method 'magic'; choose one of"),
    ("planner.method", DELETE, "planner.method: required"),
    ("planner.gain", 2.0, "planner.gain: unknown key"),
    ("planner.dt", -0.1, "planner.dt: input should be greater than 0"),
    ("planner.t_max", NAN, "planner.t_max: "),
    ("goal.tolerance", -1e-3, "goal.tolerance: input should be greater than 0"),
    ("goal", {"tolerance": 0.01},
     "goal: expected exactly one of position, path, segment; got none"),
    ("goal", {"position": [1, 1, 1], "segment": {"start": [0, 0, 0], "end": [1, 0, 0],
                                                 "normal": [0, 0, 1]}},
     "goal: expected exactly one of position, path, segment; got position, segment"),
    ("goal", {"path": {"kind": "spline"}}, "goal.path.kind: unknown kind 'spline'"),
    ("goal", {"path": {"kind": "waypoints", "points": [[0, 0, 0], [1, 0, 0], [2, 0, 0]],
                       "times": [0, 2, 1]}}, "goal.path.times[2]: 1 <= times[1] = 2"),
    ("goal", {"path": {"kind": "line", "start": [0, 0, 0], "velocity": [1, 0, 0],
                       "duration": -1}}, "goal.path.duration: input should be greater than 0"),
    ("goal", {"segment": {"start": [0, 0, 0], "end": [0, 0, 0], "normal": [0, 0, 1]}},
     "goal.segment.end: equals start"),
    ("start[6]", 2.0, "start[6]: q2 = 2 outside the joint limits [-1.13446, 1.5708]"),
    ("obstacles[1].center", [0.0, -0.5, 0.08], "start: in collision: robot point"),
    ("name", DELETE, "name: required key missing"),
]


@pytest.mark.parametrize(("key", "value", "expected"), BAD_INPUTS)
def test_bad_scenario_exits_2_with_one_line(tmp_path: Path, key: str, value: Any,
                                            expected: str) -> None:
    path = write(tmp_path, changed(key, value))
    result = run("plan", str(path), "--out", str(tmp_path / "out"))
    assert result.exit_code == 2, result.output
    assert result.stderr == f"error: {path}: " + result.stderr.removeprefix(f"error: {path}: ")
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"error: {path}: {expected}"), lines[0]
    assert "Traceback" not in result.output
    assert not (tmp_path / "out").exists()


def test_collision_message_names_obstacle_index(tmp_path: Path) -> None:
    path = write(tmp_path, changed("obstacles[1].center", [0.0, -0.5, 0.08]))
    result = run("plan", str(path), "--out", str(tmp_path / "out"))
    assert "inside obstacles[1]" in result.stderr and "(on platform" in result.stderr


@pytest.mark.parametrize(("text", "expected"), [
    ("name: [unclosed\n", "malformed YAML: line 2, column 1"),
    ("- just\n- a list\n", "expected a mapping of keys"),
    ("name: a\nname: b\n", "malformed YAML: line 2, column 1: duplicate key 'name'"),
])
def test_malformed_yaml_exits_2(tmp_path: Path, text: str, expected: str) -> None:
    path = write(tmp_path, text)
    result = run("plan", str(path), "--out", str(tmp_path / "out"))
    assert result.exit_code == 2
    assert result.stderr.strip().startswith(f"error: {path}: {expected}"), result.stderr


def test_missing_scenario_file_exits_2(tmp_path: Path) -> None:
    result = run("plan", str(tmp_path / "nope.yaml"), "--out", str(tmp_path / "out"))
    assert result.exit_code == 2
    assert "nope.yaml: no such file and no built-in scenario of that name" in result.stderr
    assert "did you mean" not in result.stderr  # nothing close


def test_a_misspelt_scenario_name_gets_the_close_one(tmp_path: Path) -> None:
    """New-user trial: ``youbot3r-obstacle`` listed all built-ins without the close match."""
    result = run("plan", "youbot3r-obstacle", "--out", str(tmp_path / "out"))
    assert result.exit_code == 2
    assert "did you mean youbot3r-obstacles? built-ins:" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def _reachable_goal(t_reach: float) -> list[float]:
    """Where dq = N(q) eta takes the end effector after t_reach (integrated finely here)."""
    robot = mmplan.get_robot("youbot-3r")
    q, eta, h = np.array(BASE["start"], float), np.array(BASE["planner"]["eta"]), 1e-3
    for _ in range(round(t_reach / h)):
        k1 = robot.null_basis(q) @ eta
        k2 = robot.null_basis(q + h / 2 * k1) @ eta
        k3 = robot.null_basis(q + h / 2 * k2) @ eta
        k4 = robot.null_basis(q + h * k3) @ eta
        q = q + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return [float(v) for v in robot.ee_position(q)]


def test_plan_reached_writes_files_and_check_passes(tmp_path: Path) -> None:
    data = changed("goal", {"position": _reachable_goal(0.5), "tolerance": 0.005})
    out = tmp_path / "run"
    result = run("plan", str(write(tmp_path, data)), "--out", str(out))
    assert result.exit_code == 0, result.output
    assert "status: reached" in result.stdout and "T(1 cm):" in result.stdout
    assert "min clearance:" in result.stdout and "compute time:" in result.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "reached" and summary["duration_s"] is not None
    assert summary["max_pfaffian_residual"] < 1e-12 and summary["min_clearance_m"] > 0
    checked = run("check", str(out))
    assert checked.exit_code == 0, checked.output
    assert "check passed" in checked.stdout and "pfaffian residual:" in checked.stdout


def test_plan_not_reached_exits_3_with_honest_summary(tmp_path: Path) -> None:
    out = tmp_path / "run"
    result = run("plan", str(write(tmp_path, BASE)), "--out", str(out), "--format", "npz")
    assert result.exit_code == 3, result.output
    assert "status: timeout" in result.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "timeout" and summary["duration_s"] is None
    assert (out / "trajectory.npz").exists() and (out / "history.csv").exists()
    assert run("check", str(out)).exit_code == 0  # an honest 'timeout' is a valid plan


def test_quiet_prints_nothing(tmp_path: Path) -> None:
    result = run("plan", str(write(tmp_path, BASE)), "--out", str(tmp_path / "o"), "--quiet")
    assert result.exit_code == 3 and result.output == ""


def test_internal_error_exits_1_without_traceback(tmp_path: Path) -> None:
    path = write(tmp_path, changed("planner", {"method": "test-crash"}))
    result = run("plan", str(path), "--out", str(tmp_path / "out"))
    assert result.exit_code == 1
    assert result.stderr.strip().splitlines() == [
        "error: internal error: ZeroDivisionError: division by zero in step 3 (this is a bug in "
        "mmplan; please report it with the command you ran)"]
    assert not (tmp_path / "out").exists()


def _plan_dir(tmp_path: Path, mutate: Any) -> Path:
    """A plan written by the test planner, then its trajectory.csv altered by ``mutate``."""
    data = changed("goal", {"position": _reachable_goal(0.3), "tolerance": 0.005})
    out = tmp_path / "run"
    assert run("plan", str(write(tmp_path, data)), "--out", str(out), "-q").exit_code == 0
    tr, _ = mmplan.read_plan(out)
    header = (out / "trajectory.csv").read_text().splitlines()[0].split(",")
    table = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    mutate(table, {name: i for i, name in enumerate(header)}, tr)
    np.savetxt(out / "trajectory.csv", table, fmt="%.17g", delimiter=",",
               header=",".join(header), comments="")
    return out


def test_check_names_a_pfaffian_violation(tmp_path: Path) -> None:
    def slide(table: np.ndarray, col: dict[str, int], tr: Any) -> None:
        table[:, col["dq.x"]] += 0.05  # heading is +y: sideways, no-slip violated by 0.05 m/s
        table[:, col["q.x"]] += 0.05 * table[:, col["t"]]

    result = run("check", str(_plan_dir(tmp_path, slide)))
    assert result.exit_code == 3
    assert "FAIL pfaffian: residual |A(q) dq| = 0.05" in result.stderr


def test_check_names_a_joint_limit_violation(tmp_path: Path) -> None:
    def bend(table: np.ndarray, col: dict[str, int], tr: Any) -> None:
        table[-1, col["q.q3"]] = 3.0  # max 145 deg
    result = run("check", str(_plan_dir(tmp_path, bend)))
    assert result.exit_code == 3
    assert "FAIL joint limits: exceeded by" in result.stderr and "q3 at t =" in result.stderr


def test_check_names_a_collision(tmp_path: Path) -> None:
    def crash(table: np.ndarray, col: dict[str, int], tr: Any) -> None:
        table[-1, col["q.x"]], table[-1, col["q.y"]] = 0.15, 0.75  # inside obstacle 0

    result = run("check", str(_plan_dir(tmp_path, crash)))
    assert result.exit_code == 3
    assert "FAIL clearance:" in result.stderr and "obstacles[0] vs robot point" in result.stderr


def test_check_unreadable_input_exits_2(tmp_path: Path) -> None:
    result = run("check", str(tmp_path / "nothing"))
    assert result.exit_code == 2 and "no such directory" in result.stderr
    (tmp_path / "empty").mkdir()
    result = run("check", str(tmp_path / "empty"))
    assert result.exit_code == 2 and "not a plan directory" in result.stderr


def test_robots_and_scenarios_listings() -> None:
    result = run("robots")
    assert result.exit_code == 0
    for name in mmplan.robot_names():
        assert name in result.stdout
    result = run("scenarios")
    assert result.exit_code == 0
    for name in mmplan.builtin_scenarios():
        assert name in result.stdout


@pytest.mark.parametrize("command", [[], ["plan"], ["check"], ["robots"], ["scenarios"],
                                     ["report"], ["reproduce"]])
def test_help_texts(command: list[str]) -> None:
    result = run(*command, "--help")
    assert result.exit_code == 0 and "Usage:" in result.stdout
    if command in ([], ["plan"], ["check"], ["report"], ["reproduce"]):
        assert "mmplan " in result.stdout and "Exit code" in result.stdout


def test_usage_error_exits_2() -> None:
    result = run("plan", "x.yaml")  # --out missing
    assert result.exit_code == 2 and "Missing option '--out'" in result.output


def test_installed_entry_point_runs() -> None:
    """The console script declared in pyproject works as a module too (no traceback)."""
    result = subprocess.run([sys.executable, "-m", "mmplan.cli", "robots"], capture_output=True,
                            text=True, timeout=120, check=False)
    assert result.returncode == 0 and "youbot-3r" in result.stdout


def test_help_example_scenario_is_valid() -> None:
    """The scenario printed by `mmplan plan --help` validates (with the test planner)."""
    text = run("plan", "--help").stdout
    block = text[text.index("name: my-reach"):text.index("Exit code")]
    data = yaml.safe_load("\n".join(line.removeprefix("    ") for line in block.splitlines()))
    assert data["planner"]["method"] == "extended-jacobian"
    data["planner"] = {"method": METHOD, "eta": [0.0] * 5}
    sc = mmplan.Scenario.from_dict(data)
    assert sc.robot.name == "youbot-3r" and len(sc.scene.obstacles) == 1


def test_check_works_without_the_planner_installed(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    from mmplan.planners import base

    out = tmp_path / "run"
    assert run("plan", str(write(tmp_path, BASE)), "--out", str(out), "-q").exit_code == 3
    monkeypatch.delitem(base._REGISTRY, METHOD)
    result = run("check", str(out))
    assert result.exit_code == 0, result.output
    _, sc = mmplan.read_plan(out)
    assert not sc.planner_validated and sc.resolved_dict()["planner"]["eta"] == [4, 3, 0.2, 0, 0]
    # planning it, however, needs the method
    result = run("plan", str(out / "scenario.yaml"), "--out", str(tmp_path / "again"))
    assert result.exit_code == 2 and "planner.method: unknown method 'test-eta'" in result.stderr


def test_public_api_names_resolve() -> None:
    """Every name in __all__ resolves; ``mmplan.check`` stays the function even when the
    submodule of that name is imported first (fresh interpreter)."""
    code = ("import mmplan.io.plan_folder, mmplan; "
            "assert callable(mmplan.check), mmplan.check; "
            "missing = [n for n in mmplan.__all__ if getattr(mmplan, n, None) is None]; "
            "assert not missing, missing; print('ok')")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=120, check=False)
    assert result.returncode == 0 and result.stdout.strip() == "ok", result.stderr
    assert sorted(mmplan.__all__) == sorted(set(mmplan.__all__))


def test_interrupt_exits_130_without_output(tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    from tests.eta_planner import EtaPlanner

    def interrupted(self: Any, problem: Problem, progress: Progress = None) -> PlanResult:
        raise KeyboardInterrupt

    monkeypatch.setattr(EtaPlanner, "plan", interrupted)
    result = run("plan", str(write(tmp_path, BASE)), "--out", str(tmp_path / "out"))
    assert result.exit_code == 130 and result.stderr.strip() == "error: interrupted"
    assert not (tmp_path / "out").exists()


def test_planner_input_errors_name_the_scenario_file(tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    from tests.eta_planner import EtaPlanner

    def reject(self: Any, problem: Problem, progress: Progress = None) -> PlanResult:
        raise mmplan.InputError("planner.eta", "too fast for this robot")

    monkeypatch.setattr(EtaPlanner, "plan", reject)
    path = write(tmp_path, BASE)
    result = run("plan", str(path), "--out", str(tmp_path / "out"))
    assert result.exit_code == 2
    assert result.stderr.strip() == f"error: {path}: planner.eta: too fast for this robot"


def test_plan_report_flag_and_report_command(tmp_path: Path) -> None:
    """`plan --report` writes report.html next to the plan; `report DIR` rewrites it."""
    out = tmp_path / "run"
    result = run("plan", str(write(tmp_path, BASE)), "--out", str(out), "--report")
    assert result.exit_code == 3, result.output  # not reached (timeout): report written anyway
    assert f"report: {out / 'report.html'}" in result.stdout
    page = out / "report.html"
    assert page.is_file() and "<html" in page.read_text()[:500].lower()
    assert list((out / "figures").glob("*.png"))
    page.unlink()
    result = run("report", str(out))
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith(f"wrote {page} (") and page.is_file()


def test_report_command_bad_input_exits_2(tmp_path: Path) -> None:
    result = run("report", str(tmp_path / "missing"))
    assert result.exit_code == 2 and result.stderr.startswith("error: ")
    assert len(result.stderr.strip().splitlines()) == 1 and "missing" in result.stderr
    (tmp_path / "empty").mkdir()
    result = run("report", str(tmp_path / "empty"))
    assert result.exit_code == 2 and "trajectory.csv" in result.stderr
    assert "Traceback" not in result.output


def test_report_without_the_extra_is_one_line(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """Without matplotlib, `mmplan report` says how to install it (exit 1, no traceback)."""
    for name in [m for m in sys.modules if m == "mmplan.report" or m.startswith("mmplan.report.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    (tmp_path / "p").mkdir()
    result = run("report", str(tmp_path / "p"))
    assert result.exit_code == 1
    assert result.stderr.strip() == ("error: mmplan report needs matplotlib: "
                                     + install_command("report"))


def test_report_extra_is_not_imported_by_the_cli() -> None:
    """The report (matplotlib) is an optional extra: loading the CLI and reproduce skips it."""
    code = ("import sys, mmplan.cli.main, mmplan.reproduce.run, mmplan.reproduce.table; "
            "bad = [m for m in sys.modules if m.startswith(('mmplan.report', 'matplotlib'))]; "
            "assert not bad, bad; print('ok')")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=120, check=False)
    assert result.returncode == 0 and result.stdout.strip() == "ok", result.stderr
