"""The floor in the checker (``mmplan.verify.floor``): clearance over the samples and the motion
between them, its threshold, ``ground: null``; and the paper-000 plans against the floor."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import mmplan
from mmplan import Scenario, Trajectory, builtin_scenarios
from mmplan.cli.main import main
from mmplan.robot.ground import ground_sphere_indices
from mmplan.verify.check import check
from mmplan.verify.floor import FLOOR_TOL
from tests.eta_planner import METHOD

BASE: dict[str, Any] = {
    "name": "unit",
    "robot": "youbot-3r",
    "start": [0, 0, 0, 0, 0, 0, -0.17, 0.35],
    "goal": {"position": [1.5, 0.5, 0.3], "tolerance": 0.001},
    "limits": {"torque": "unlimited", "velocity": None, "acceleration": None},
    "planner": {"method": METHOD, "eta": [0.0] * 5},  # a test planner: no effort columns
}
Q2 = 6  # index of youbot-3r's q2 (positive: the arm goes down)


def problem(ground: float | None) -> mmplan.Problem:
    return Scenario.from_dict({**BASE, "ground": ground}, check_start=False).build()


def arm_heights(robot: mmplan.Robot, q: np.ndarray, ground: float) -> np.ndarray:
    """Independent: height above the floor of every non-platform sphere, (N, P_arm)."""
    arm = [i for i, c in enumerate(robot.collision) if c.body != "platform"]
    return np.array([robot.collision_points(x)[arm, 2] for x in q]) - robot.collision_radii[
        arm] - ground


def lowering(T: float = 2.0, N: int = 201, to: float = 0.5) -> Trajectory:
    """youbot-3r at rest on the platform, q2 from -0.17 to ``to`` by a quintic blend."""
    robot = problem(0.0).robot
    t = np.linspace(0.0, T, N)
    tau = t / T
    s, ds, dds = (tau**3 * (10 - 15 * tau + 6 * tau**2), 30 * tau**2 * (1 - tau) ** 2 / T,
                  60 * tau * (1 - 3 * tau + 2 * tau**2) / T**2)
    q = np.tile(np.asarray(BASE["start"], float), (N, 1))
    dq, ddq = np.zeros_like(q), np.zeros_like(q)
    d = to - q[0, Q2]
    q[:, Q2] += d * s
    dq[:, Q2], ddq[:, Q2] = d * ds, d * dds
    ee = np.array([robot.ee_position(x) for x in q])
    return Trajectory(robot.coordinates, t, q, dq, ddq, ee)


def floor_failures(report: mmplan.CheckReport) -> list[str]:
    return [f for f in report.failures() if f.startswith("floor:")]


def test_floor_clearance_is_the_lowest_arm_sphere_and_fails_below_zero() -> None:
    tr = lowering()
    report = check(tr, problem(0.0))
    expected = float(arm_heights(problem(0.0).robot, tr.q, 0.0).min())
    assert expected < -0.05  # the arm goes 8 cm through the floor
    # the blend is monotone: the motion between samples is no lower than the samples
    assert report.min_floor_clearance_m == pytest.approx(expected, abs=1e-9)
    (line,) = floor_failures(report)
    assert line.startswith(f"floor: clearance {expected:.4g} m < {FLOOR_TOL:g} m, robot point")
    assert "on link3" in line and "floor z = 0 m" in line
    lowered = check(tr, problem(-0.1))  # the floor 10 cm lower: clear
    assert lowered.min_floor_clearance_m == pytest.approx(expected + 0.1, abs=1e-9)
    assert not floor_failures(lowered) and lowered.ok, lowered.failures()
    removed = check(tr, problem(None))
    assert removed.min_floor_clearance_m is None and removed.ok, removed.failures()
    assert report.summary(status="x", planner="y", compute_time_s=0)[
        "min_floor_clearance_m"] == report.min_floor_clearance_m


def test_a_dip_between_samples_is_caught_on_the_interpolated_motion() -> None:
    """Two samples at the start pose (clear), but the velocities make the cubic Hermite
    interpolant between them swing q2 down to 0.58 rad: the arm goes through the floor
    between the samples only."""
    robot = problem(0.0).robot
    q = np.tile(np.asarray(BASE["start"], float), (2, 1))
    dq = np.zeros_like(q)
    dq[0, Q2], dq[1, Q2] = 3.0, -3.0  # q2(s) = q0 + 3 s (1 - s): +0.75 at s = 1/2
    ee = np.array([robot.ee_position(x) for x in q])
    tr = Trajectory(robot.coordinates, np.array([0.0, 1.0]), q, dq, np.zeros_like(q), ee)
    assert arm_heights(robot, q, 0.0).min() > 0.2
    mid = q[0].copy()
    mid[Q2] += 0.75
    report = check(tr, problem(0.0))
    assert report.min_floor_clearance_m == pytest.approx(
        float(arm_heights(robot, mid[None], 0.0).min()), abs=1e-9)  # at s = 1/2, sampled
    (line,) = floor_failures(report)
    assert "between samples 0 and 1, on the interpolated motion" in line


def test_check_prints_the_floor_clearance_with_its_threshold(tmp_path: Path) -> None:
    folder = tmp_path / "plan"
    mmplan.write_plan(folder, _result(lowering()), problem(0.0))
    checked = CliRunner().invoke(main, ["check", str(folder)])
    assert checked.exit_code == 3, checked.output
    (row,) = [r for r in checked.stdout.splitlines() if r.startswith("min floor clearance:")]
    assert "must be >= 0 m (floor z = 0 m; arm spheres)" in row
    assert any(r.startswith("FAIL floor: clearance") for r in checked.stderr.splitlines())


def _result(tr: Trajectory) -> mmplan.PlanResult:
    return mmplan.PlanResult(status=mmplan.Status.STALLED, trajectory=tr,
                             planner=METHOD, message="test", compute_time_s=0.0)


# --- the paper-000 plans (issue 16: the end effector 9 cm below the ground, passed) ----------

PAPER = ("youbot3r-obstacles", "youbot3r-obstacles-torque")


def plan(name: str, folder: Path, ground: Any = 0.0) -> Path:
    """``mmplan plan`` of a built-in scenario with its floor set to ``ground``."""
    data = yaml.safe_load(builtin_scenarios()[name].read_text())
    data["ground"] = ground
    path = folder.with_suffix(".yaml")
    path.write_text(yaml.safe_dump(data))
    planned = CliRunner().invoke(main, ["plan", str(path), "--out", str(folder), "-q"])
    assert planned.exit_code in (0, 3), planned.output
    return folder


def lowest(folder: Path) -> tuple[float, float]:
    """(min ee z, min arm-sphere height above z = 0) from the written trajectory."""
    tr, sc = mmplan.read_plan(folder)
    return float(tr.ee[:, 2].min()), float(arm_heights(sc.robot, tr.q, 0.0).min())


@pytest.mark.parametrize("name", PAPER)
def test_a_plan_below_the_floor_fails_the_check(name: str, tmp_path: Path) -> None:
    """The plan made without a floor (the papers' setting) dips 9 cm below the ground; checked
    against the default floor it fails (exit 3) naming the floor; before the floor existed
    `mmplan check` passed it."""
    folder = plan(name, tmp_path / name, ground=None)
    ee_z, sphere = lowest(folder)
    assert ee_z == pytest.approx(-0.09, abs=0.005) and sphere < -0.085
    scenario = yaml.safe_load((folder / "scenario.yaml").read_text())
    del scenario["ground"]  # the default floor z = 0
    (folder / "scenario.yaml").write_text(yaml.safe_dump(scenario))
    checked = CliRunner().invoke(main, ["check", str(folder)])
    assert checked.exit_code == 3, checked.output
    fails = [r for r in checked.stderr.splitlines() if r.startswith("FAIL floor: clearance")]
    assert fails, checked.stderr
    value = float(fails[0].split()[3])  # samples and the motion between them
    assert sphere - 1e-3 < value <= sphere + 1e-9, (value, sphere)


@pytest.mark.parametrize("name", PAPER)
def test_paper_plans_keep_clear_of_the_floor(name: str, tmp_path: Path) -> None:
    folder = plan(name, tmp_path / name)
    ee_z, sphere = lowest(folder)
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["status"] == "reached"
    assert ee_z >= 0 and sphere >= 0, (ee_z, sphere)
    assert summary["min_floor_clearance_m"] == pytest.approx(sphere, abs=1e-3)
    checked = CliRunner().invoke(main, ["check", str(folder)])
    assert not [r for r in checked.stderr.splitlines() if r.startswith("FAIL floor")]
    assert len(ground_sphere_indices(mmplan.get_robot("youbot-3r"))) == 5
