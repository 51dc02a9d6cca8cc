"""Console output of ``mmplan plan`` and ``mmplan check`` (mmplan.cli.output): one set of
numbers, the reach time named apart from the trajectory's end, every checked quantity with
its threshold."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mmplan
from mmplan.cli import output
from mmplan.verify.check import CheckReport
from mmplan.verify.consistency import Consistency


def _report(**changes: Any) -> CheckReport:
    values: dict[str, Any] = {
        "robot": "youbot-3r", "samples": 624, "finite": True, "ee_deviation_m": 0.0,
        "min_clearance_m": 0.1215, "clearance_where": "", "max_joint_limit_violation": 0.0,
        "joint_where": "", "max_torque_violation": 0.0, "torque_where": "",
        "torque_source": "trajectory", "tau_model_deviation": 1e-15,
        "max_pfaffian_residual": 5e-16, "pfaffian_where": "", "dq_residual": 0.2,
        "dq_scale": 16.0, "ddq_scale": 37.0, "duration_s": 13.78,
        "duration_1cm_s": 11.38, "duration_1mm_s": 13.78, "final_error_m": 4.9e-4,
        "tolerance": 1e-3, "task_completed": True, "manipulability_start": 0.0097,
        "manipulability_end": 0.0198, "manipulability_min": 0.0097, "status": "reached",
        "consistency": Consistency(required=("tau.*", "u"), tau_model_deviation=1e-15,
                                   ddq_excess=5.22, ddq_allowed=9.99),
    }
    names = {f.name for f in dataclasses.fields(CheckReport)}
    values = {k: v for k, v in values.items() if k in names}
    return dataclasses.replace(CheckReport(**values), **changes)


def _lines(capsys: pytest.CaptureFixture[str]) -> dict[str, str]:
    rows = {}
    for line in capsys.readouterr().out.splitlines():
        label, _, rest = line.partition(":")
        rows[label.strip()] = rest.strip()
    return rows


def test_check_prints_each_quantity_with_its_threshold(
        capsys: pytest.CaptureFixture[str]) -> None:
    output.print_check(_report(), trajectory_end_s=14.5)
    rows = _lines(capsys)
    assert rows["reach time T(tol)"].startswith("13.78 s") and "<= 0.001 m" in rows[
        "reach time T(tol)"]
    assert rows["trajectory end"].startswith("14.5 s")
    assert re.search(r"must be <= 1e-06 m/s", rows["pfaffian residual"])
    assert "must be <= 0.16 /s (0.01 x max |dq| 16)" in rows["dq residual"]
    assert rows["ddq vs interpolant"].startswith("5.22") and "must be <= 9.99" in rows[
        "ddq vs interpolant"]
    assert rows["tau vs model"].startswith("1e-15") and "must be <= 1e-06" in rows[
        "tau vs model"]
    assert rows["start vs scenario"].startswith("0, t0 = 0 s") and "must be <= 1e-09" in rows[
        "start vs scenario"]
    assert rows["effort columns"].startswith("complete") and "tau.*, u" in rows[
        "effort columns"]
    assert "must be >= 0 m" in rows["min clearance"]
    assert "must be <= 1e-09" in rows["joint limit violation"]
    assert "must be <= 1e-06" in rows["torque violation"]
    assert "must be <= 1e-06 m" in rows["ee vs FK"]
    assert "must agree" in rows["status (claimed)"]
    for label in ("T(1 cm)", "T(1 mm)", "final error", "manipulability"):
        assert "info" in rows[label], label  # reported, not a pass criterion


def test_check_prints_the_self_clearance(capsys: pytest.CaptureFixture[str]) -> None:
    """A robot with self-collision pairs: the smallest distance, where, and its threshold;
    without pairs the row says so."""
    output.print_check(_report(min_self_clearance_m=0.0123,
                               self_clearance_where="arm_7_link vs platform at t = 2.5 s"))
    row = _lines(capsys)["min self-clearance"]
    assert row.startswith("0.0123 m (arm_7_link vs platform at t = 2.5 s)"), row
    assert "must be >= 0 m" in row
    output.print_check(_report())
    assert "no self-collision pairs" in _lines(capsys)["min self-clearance"]


def test_plan_names_reach_time_and_trajectory_end(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    t = np.linspace(0.0, 14.5, 30)
    trajectory = mmplan.Trajectory(
        coordinates=("x",), t=t, q=np.zeros((30, 1)), dq=np.zeros((30, 1)),
        ddq=np.zeros((30, 1)), ee=np.zeros((30, 3)))
    result = mmplan.PlanResult(mmplan.Status.REACHED, trajectory, "extended-jacobian",
                               message="goal reached at t = 14.500 s (generator path 12.460 s)")
    summary = {"duration_s": 13.78, "duration_1cm_s": 11.38, "duration_1mm_s": 13.78,
               "final_error_m": 4.9e-4, "min_clearance_m": 0.1215, "compute_time_s": 0.55}
    output.print_plan(result, summary, tmp_path)
    text = capsys.readouterr().out
    assert text.startswith("status: reached\n")  # no second, differing time in the status
    assert "14.500" not in text.splitlines()[0]
    rows = {line.split(":")[0].strip(): line for line in text.splitlines()}
    assert "13.78 s" in rows["reach time"] and "within the goal tolerance" in rows["reach time"]
    assert "14.5 s" in rows["trajectory end"] and "final error 0.00049 m" in rows[
        "trajectory end"]
    timeout = dataclasses.replace(result, status=mmplan.Status.TIMEOUT, message="t_max 60 s")
    output.print_plan(timeout, {**summary, "duration_s": None}, tmp_path)
    text = capsys.readouterr().out
    assert text.startswith("status: timeout (t_max 60 s)") and "task not completed" in text
