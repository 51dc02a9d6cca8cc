"""Tampered plan folders: ``mmplan check`` exits 3 with a line naming the reason (issue 16).

Real plans of three built-in scenarios are written with ``mmplan plan`` (the
extended-Jacobian planner with torque and rate limits, a path tracker, the endogenous
planner), copied, edited on disk and re-checked. Some edits touch one thing (a column, a
summary key); the ``*_reforged`` ones are forgeries that recompute everything derived
(``ee`` by forward kinematics, ``tau`` from the model, summary.json from mmplan's own
checker, ``check_passed: true``) so that only the physics or the scenario can catch them.
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import mmplan
from mmplan.cli.main import main

#: The plans tampered with, by short key.
SCENARIOS = {
    "ej": "youbot3r-obstacles-torque",  # extended Jacobian: torque + rate limits, obstacles
    "tracker": "diffdrive3-track",  # pseudoinverse path tracking, obstacles
    "endogenous": "car-rtr-free",  # endogenous configuration space, point goal
}
ALL = tuple(SCENARIOS)
#: An arm coordinate of each robot, with its upper limit [rad].
ARM = {"ej": "q2", "tracker": "theta2", "endogenous": "x3"}
OTHER_ARM = {"ej": "q3", "tracker": "theta3", "endogenous": "x1"}


class Plan:
    """A plan folder opened for editing: trajectory.csv as header + array, summary.json."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.header = (folder / "trajectory.csv").read_text().splitlines()[0].split(",")
        self.data = np.loadtxt(folder / "trajectory.csv", delimiter=",", skiprows=1, ndmin=2)
        self.summary: dict[str, Any] = json.loads((folder / "summary.json").read_text())
        _, self.scenario = mmplan.read_plan(folder)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.data[:, self.header.index(name)]

    def __setitem__(self, name: str, value: Any) -> None:
        self.data[:, self.header.index(name)] = value

    def names(self, prefix: str) -> list[str]:
        return [h for h in self.header if h.startswith(prefix)]

    def scale(self, prefix: str, factor: float) -> None:
        for name in self.names(prefix):
            self[name] = self[name] * factor

    def drop(self, *names: str) -> None:
        keep = [i for i, h in enumerate(self.header) if h not in names]
        self.header = [self.header[i] for i in keep]
        self.data = self.data[:, keep]

    def swap(self, a: str, b: str) -> None:
        self[a], self[b] = self[b].copy(), self[a].copy()

    def save(self) -> None:
        np.savetxt(self.folder / "trajectory.csv", self.data, fmt="%.17g", delimiter=",",
                   header=",".join(self.header), comments="")
        (self.folder / "summary.json").write_text(json.dumps(self.summary, indent=2) + "\n")

    def reforge(self) -> None:
        """What a careful forger does after editing q, dq, ddq, t: ee by forward kinematics,
        tau from the model, summary.json recomputed by mmplan's own checker and passed."""
        robot = self.scenario.build().robot
        q = self.data[:, [self.header.index(f"q.{c}") for c in robot.coordinates]]
        dq = self.data[:, [self.header.index(f"dq.{c}") for c in robot.coordinates]]
        ddq = self.data[:, [self.header.index(f"ddq.{c}") for c in robot.coordinates]]
        for row, x in enumerate(q):
            for axis, value in zip("xyz", robot.ee_position(x), strict=True):
                self.data[row, self.header.index(f"ee.{axis}")] = value
        if self.names("tau."):
            tau = np.array([robot.actuator_efforts(*x) for x in zip(q, dq, ddq, strict=True)])
            for j, name in enumerate(robot.actuators):
                self[f"tau.{name}"] = tau[:, j]
        self.save()
        tr, sc = mmplan.read_plan(self.folder)
        report = mmplan.check(tr, sc.build(), status=self.summary["status"])
        forged = report.summary(status=self.summary["status"], planner=self.summary["planner"],
                                compute_time_s=self.summary["compute_time_s"])
        forged.update(check_passed=True, check_failures=[], message=self.summary["message"],
                      scenario=self.summary["scenario"],
                      planner_info=self.summary["planner_info"])
        self.summary = _json_safe(forged)
        self.save()


def _json_safe(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


# --- the edits ------------------------------------------------------------------------------


def replay_faster(p: Plan, factor: float = 2.0) -> None:
    """The same path in 1/factor of the time: t / f, dq * f, ddq * f^2 (consistent)."""
    p["t"] = p["t"] / factor
    p.scale("dq.", factor)
    p.scale("ddq.", factor**2)


def bend_beyond_limit(p: Plan, key: str) -> None:
    """A smooth raised-cosine bump on an arm joint over the middle third of the plan, high
    enough to pass its upper limit by 0.2 rad (q, dq, ddq consistent)."""
    name = ARM[key]
    robot = p.scenario.build().robot
    upper = robot.limits.joint_max[list(robot.arm_coordinates).index(name)]
    t = p["t"]
    t1, t2 = t[0] + (t[-1] - t[0]) / 3, t[0] + 2 * (t[-1] - t[0]) / 3
    A, w = upper - np.min(p[f"q.{name}"]) + 0.2, 2 * np.pi / (t2 - t1)
    inside = (t >= t1) & (t <= t2)
    s = np.where(inside, t - t1, 0.0)
    p[f"q.{name}"] = p[f"q.{name}"] + np.where(inside, A / 2 * (1 - np.cos(w * s)), 0.0)
    p[f"dq.{name}"] = p[f"dq.{name}"] + np.where(inside, A / 2 * w * np.sin(w * s), 0.0)
    p[f"ddq.{name}"] = p[f"ddq.{name}"] + np.where(inside, A / 2 * w**2 * np.cos(w * s), 0.0)


def start_elsewhere(p: Plan, key: str) -> None:
    """Begin 0.05 rad away on an arm joint and blend into the plan by its end:
    q += 0.05 (1 + cos(pi t / T)) / 2 with dq, ddq consistent (same end, same goal)."""
    name, t = ARM[key], p["t"]
    T, d = t[-1], 0.05
    p[f"q.{name}"] = p[f"q.{name}"] + d / 2 * (1 + np.cos(np.pi * t / T))
    p[f"dq.{name}"] = p[f"dq.{name}"] - d / 2 * np.pi / T * np.sin(np.pi * t / T)
    p[f"ddq.{name}"] = p[f"ddq.{name}"] - d / 2 * (np.pi / T) ** 2 * np.cos(np.pi * t / T)


#: Arm joints and the values they reach mid-plan to take an arm sphere through the floor z = 0
#: (youbot-3r q2 = 1: link3 0.22 m below; diffdrive-3dof elbow down: 0.07 m; car-rtr's
#: vertical slider x2 = -0.5: the forearm 0.5 m below).
FLOOR_DIP = {"ej": {"q2": 1.0}, "tracker": {"theta2": 1.2, "theta3": 0.3},
             "endogenous": {"x2": -0.5}}


def lower_through_floor(p: Plan, key: str) -> None:
    """Raised-cosine bumps over the middle third of the plan that bring the joints of
    FLOOR_DIP[key] to their values at its centre (q, dq, ddq consistent, joint limits kept)."""
    t = p["t"]
    t1, t2 = t[0] + (t[-1] - t[0]) / 3, t[0] + 2 * (t[-1] - t[0]) / 3
    w, inside = 2 * np.pi / (t2 - t1), (t >= t1) & (t <= t2)
    s = np.where(inside, t - t1, 0.0)
    mid = int(np.argmin(np.abs(t - (t1 + t2) / 2)))
    for name, target in FLOOR_DIP[key].items():
        A = (target - p[f"q.{name}"][mid]) / (0.5 * (1 - np.cos(w * (t[mid] - t1))))
        p[f"q.{name}"] = p[f"q.{name}"] + np.where(inside, A / 2 * (1 - np.cos(w * s)), 0.0)
        p[f"dq.{name}"] = p[f"dq.{name}"] + np.where(inside, A / 2 * w * np.sin(w * s), 0.0)
        p[f"ddq.{name}"] = p[f"ddq.{name}"] + np.where(inside, A / 2 * w**2 * np.cos(w * s),
                                                       0.0)


def set_ground(p: Plan, ground: float | None) -> None:
    """The plan's scenario.yaml with the floor at ``ground`` (None: no floor)."""
    path = p.folder / "scenario.yaml"
    data = yaml.safe_load(path.read_text())
    data["ground"] = ground
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    _, p.scenario = mmplan.read_plan(p.folder)


def slip(p: Plan) -> None:
    """The platform drifts along y at 5 cm/s (q.y, dq.y consistent; wheels unchanged)."""
    p["q.y"] = p["q.y"] + 0.05 * p["t"]
    p["dq.y"] = p["dq.y"] + 0.05


def shift_joint_midway(p: Plan, key: str) -> None:
    """One arm joint 0.05 rad higher from the middle sample on (dq, ddq unchanged)."""
    name = ARM[key]
    column = p[f"q.{name}"].copy()
    column[len(column) // 2:] += 0.05
    p[f"q.{name}"] = column


def fake_ee(p: Plan) -> None:
    """The ee columns claim the final position all along."""
    for axis in "xyz":
        p[f"ee.{axis}"] = p[f"ee.{axis}"][-1]


def delete_middle_row(p: Plan) -> None:
    p.data = np.delete(p.data, len(p.data) // 2, axis=0)


def rename(p: Plan, old: str, new: str) -> None:
    p.header[p.header.index(old)] = new


def set_nan(p: Plan) -> None:
    column = p["q.x"].copy()
    column[10] = np.nan
    p["q.x"] = column


def edit_summary(key: str, change: Callable[[Any], Any]) -> Callable[[Plan, str], None]:
    def edit(p: Plan, _: str) -> None:
        p.summary[key] = change(p.summary[key])
    return edit


def halve_first_peak(p: Plan, _: str) -> None:
    name = next(iter(p.summary["peak_velocity"]))
    p.summary["peak_velocity"][name] *= 0.5


def reforged(edit: Callable[[Plan, str], None]) -> Callable[[Plan, str], None]:
    def both(p: Plan, key: str) -> None:
        edit(p, key)
        p.reforge()
    return both


@dataclass(frozen=True)
class Tamper:
    """One tamper class: the edit, the plans it applies to and, per plan, the FAIL lines
    expected (each one must start a FAIL line: the check that names the reason)."""

    name: str
    edit: Callable[[Plan, str], None]
    reasons: dict[str, tuple[str, ...]]


def same(reasons: tuple[str, ...], keys: tuple[str, ...] = ALL) -> dict[str, tuple[str, ...]]:
    return dict.fromkeys(keys, reasons)


TAMPERS = [
    # the reliability pass of issue 16
    Tamper("ddq_x5_tau_kept", lambda p, _: p.scale("ddq.", 5.0),
           {"ej": ("tau vs model", "torque limits: exceeded"),
            "tracker": ("ddq consistency",), "endogenous": ("ddq consistency",)}),
    Tamper("replay_2x_tau_kept", lambda p, _: replay_faster(p),
           {"ej": ("tau vs model", "torque limits: exceeded"),
            "tracker": ("status: planner says 'reached' but the task is not completed",),
            "endogenous": ("summary duration_s",)}),
    Tamper("start_elsewhere_reforged", reforged(start_elsewhere),
           same(("start: q at the first sample differs",))),
    Tamper("tau_dropped", lambda p, _: p.drop(*p.names("tau.")),
           {"ej": ("columns: effort columns missing (the robot has torque limits)",)}),
    Tamper("u_dropped", lambda p, _: p.drop("u"), {"ej": ("columns: column u missing",)}),
    Tamper("status_bogus", edit_summary("status", lambda _: "bogus"),
           same(("status: 'bogus' is not one of", "summary status: 'bogus'"))),
    # time axis
    Tamper("time_stretched_x2", lambda p, _: p.__setitem__("t", 2.0 * p["t"]),
           same(("dq consistency",))),
    Tamper("time_compressed_x0.5", lambda p, _: p.__setitem__("t", 0.5 * p["t"]),
           same(("dq consistency",))),
    Tamper("time_shifted_1s", lambda p, _: p.__setitem__("t", p["t"] + 1.0),
           same(("start: the trajectory begins at t = 1",))),
    Tamper("sample_deleted", lambda p, _: delete_middle_row(p), same(("summary samples",))),
    Tamper("replay_2x_reforged", reforged(lambda p, _: replay_faster(p)),
           {"ej": ("torque limits: exceeded", "rate limits:"),
            "tracker": ("status: planner says 'reached' but the task is not completed",)}),
    # ddq scaled with its efforts recomputed: the ddq check alone catches it on every plan
    # (before, its allowance 0.5 x peak |ddq| let x1.5 through; only the torque limits did)
    Tamper("ddq_x1.5_reforged", reforged(lambda p, _: p.scale("ddq.", 1.5)),
           {"ej": ("ddq consistency", "torque limits: exceeded"),
            "tracker": ("ddq consistency",), "endogenous": ("ddq consistency",)}),
    Tamper("ddq_x0.5_reforged", reforged(lambda p, _: p.scale("ddq.", 0.5)),
           same(("ddq consistency",))),
    # columns
    Tamper("tau_columns_swapped", lambda p, _: p.swap("tau.wheel1", "tau.wheel2"),
           {"ej": ("tau vs model",)}),
    Tamper("tau_halved", lambda p, _: p.scale("tau.", 0.5), {"ej": ("tau vs model",)}),
    Tamper("tau_one_dropped", lambda p, _: p.drop("tau.q3"),
           {"ej": ("columns: effort columns tau.wheel1, tau.wheel2, tau.q1, tau.q2 do not "
                   "name the robot's actuators",)}),
    Tamper("tau_renamed", lambda p, _: rename(p, "tau.wheel1", "tau.left"),
           {"ej": ("columns: effort columns tau.left",)}),
    Tamper("q_columns_swapped", lambda p, k: p.swap(f"q.{ARM[k]}", f"q.{OTHER_ARM[k]}"),
           same(("end effector: ee columns differ", "start: q at the first sample differs"))),
    Tamper("joint_shifted_midway_reforged", reforged(shift_joint_midway),
           same(("dq consistency",))),
    Tamper("dq_scaled_x0.9", lambda p, _: p.scale("dq.", 0.9), same(("dq consistency",))),
    Tamper("ddq_zeroed", lambda p, _: p.scale("ddq.", 0.0),
           {"ej": ("tau vs model", "ddq consistency"), "tracker": ("ddq consistency",),
            "endogenous": ("ddq consistency",)}),
    Tamper("ee_faked", lambda p, _: fake_ee(p), same(("end effector: ee columns differ",))),
    Tamper("nan_injected", lambda p, _: set_nan(p), same(("finite:",))),
    # physics broken consistently
    Tamper("platform_slips_reforged", reforged(lambda p, _: slip(p)), same(("pfaffian:",))),
    Tamper("arm_through_floor_reforged", reforged(lower_through_floor),
           same(("floor: clearance",))),
    Tamper("floor_raised", lambda p, _: set_ground(p, 0.6),  # above the youBot's arm at rest
           {"ej": ("floor: clearance",)}),
    Tamper("arm_bent_beyond_limit_reforged", reforged(bend_beyond_limit),
           {"ej": ("joint limits: exceeded",), "tracker": ("joint limits: exceeded",)}),
    # summary.json claims
    Tamper("summary_duration", edit_summary("duration_s", lambda v: v - 1.0),
           same(("summary duration_s",))),
    Tamper("summary_clearance", edit_summary("min_clearance_m", lambda v: (v or 0.0) + 0.05),
           same(("summary min_clearance_m",))),
    Tamper("summary_peak_velocity", halve_first_peak, same(("summary peak_velocity.",))),
    Tamper("summary_status_stalled", edit_summary("status", lambda _: "stalled"),
           same(("status: planner says 'stalled' but the task is completed",))),
]
CASES = [(tamper, key) for tamper in TAMPERS for key in tamper.reasons]


@pytest.fixture(scope="module")
def honest(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], Path]:
    """The plan of SCENARIOS[key], written once by ``mmplan plan`` (on first use)."""
    root = tmp_path_factory.mktemp("honest")
    cache: dict[str, Path] = {}

    def get(key: str) -> Path:
        if key not in cache:
            folder = root / SCENARIOS[key]
            planned = CliRunner().invoke(main, ["plan", SCENARIOS[key], "--out", str(folder),
                                                "-q"])
            assert planned.exit_code == 0, planned.output
            cache[key] = folder
        return cache[key]

    return get


def _fail_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("FAIL ")]


@pytest.mark.parametrize("key", ALL)
def test_untampered_plans_pass(honest: Callable[[str], Path], key: str) -> None:
    checked = CliRunner().invoke(main, ["check", str(honest(key))])
    assert checked.exit_code == 0, checked.output


@pytest.mark.parametrize(("tamper", "key"), CASES,
                         ids=[f"{tamper.name}-{key}" for tamper, key in CASES])
def test_tampered_plan_fails_naming_the_reason(honest: Callable[[str], Path], tamper: Tamper,
                                               key: str, tmp_path: Path) -> None:
    folder = tmp_path / "plan"
    shutil.copytree(honest(key), folder)
    plan = Plan(folder)
    tamper.edit(plan, key)
    plan.save()
    checked = CliRunner().invoke(main, ["check", str(folder)])
    fails = _fail_lines(checked.stderr)
    assert checked.exit_code == 3, checked.output
    for reason in tamper.reasons[key]:
        assert any(line.startswith(f"FAIL {reason}") for line in fails), (
            f"no FAIL line starts with {reason!r}:\n" + "\n".join(fails))


def test_accelerations_x5_through_the_installed_command(honest: Callable[[str], Path],
                                                         tmp_path: Path) -> None:
    """The issue's first finding end to end (a new process): ddq x5 with tau kept exits 3,
    naming the tau-vs-model gap and the model's efforts over their limits."""
    folder = tmp_path / "plan"
    shutil.copytree(honest("ej"), folder)
    plan = Plan(folder)
    plan.scale("ddq.", 5.0)
    plan.save()
    checked = subprocess.run([sys.executable, "-m", "mmplan.cli", "check", str(folder)],
                             capture_output=True, text=True, timeout=300, check=False)
    assert checked.returncode == 3, checked.stdout + checked.stderr
    fails = _fail_lines(checked.stderr)
    assert any(line.startswith("FAIL tau vs model") for line in fails), fails
    assert any(line.startswith("FAIL torque limits: exceeded") and "model efforts" in line
               for line in fails), fails


class TestFloor:
    """The floor z = 0 (docs/conventions.md, "Floor"): an arm lowered through it fails the check
    (the tamper above); the same plan with the floor removed (``ground: null``) or lowered
    below the dip passes, so the floor is the only reason."""

    @pytest.mark.parametrize(("ground", "passes"), [(None, True), (-0.6, True), (0.0, False)])
    def test_lowered_arm_passes_only_without_the_floor(
            self, honest: Callable[[str], Path], tmp_path: Path, ground: float | None,
            passes: bool) -> None:
        folder = tmp_path / "plan"
        shutil.copytree(honest("endogenous"), folder)
        plan = Plan(folder)
        lower_through_floor(plan, "endogenous")
        set_ground(plan, ground)
        plan.reforge()
        checked = CliRunner().invoke(main, ["check", str(folder)])
        assert checked.exit_code == (0 if passes else 3), checked.output
        row = next(r for r in checked.stdout.splitlines() if r.startswith("min floor"))
        assert ("no floor (ground: null)" in row) == (ground is None), row
        tr, sc = mmplan.read_plan(folder)  # independent: the forearm's lowest sphere
        points = np.array([sc.robot.collision_points(x)[:, 2] for x in tr.q])
        forearm = [i for i, c in enumerate(sc.robot.collision) if c.body == "forearm"]
        assert -0.55 < points[:, forearm].min() < -0.45
