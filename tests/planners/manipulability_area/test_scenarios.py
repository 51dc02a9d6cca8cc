"""The built-in scenarios of the manipulability-area planner load and plan."""

from __future__ import annotations

import numpy as np
import pytest

from mmplan.planners import get_planner
from mmplan.planners.manipulability_area.settings import ManipulabilityAreaSettings
from mmplan.scenario.loader import load_scenario
from mmplan.task import DrawSegment
from mmplan.trajectory import Status
from mmplan.verify.check import check


def test_wall_segment_scenario() -> None:
    scenario = load_scenario("wall-segment")
    assert scenario.robot.name == "base-6dof" and scenario.method == "manipulability-area"
    assert isinstance(scenario.settings, ManipulabilityAreaSettings)
    assert scenario.settings == ManipulabilityAreaSettings(substeps=10)  # defaults + substeps
    task = scenario.task
    assert isinstance(task, DrawSegment)
    assert task.start == (0.0, 0.0, 0.32) and task.end == (0.0, 0.6, 0.62)
    assert task.normal == (1.0, 0.0, 0.0)
    result = get_planner(scenario.method)().plan(scenario.build())
    assert result.status is Status.REACHED, result.message
    assert result.info["path_length_m"] == pytest.approx(0.122, abs=5e-4)
    assert result.info["manipulability_min"] >= result.info["manipulability_threshold"]
    assert scenario.resolved_dict()["planner"]["method"] == "manipulability-area"
    assert result.trajectory.samples == 301 and result.info["rows_per_layer"] == 10
    report = check(result.trajectory, scenario.build(), result.status.value)
    assert report.failures() == []


def test_wall_segment_limits_scenario_needs_subgoals() -> None:
    scenario = load_scenario("wall-segment-limits")
    assert isinstance(scenario.settings, ManipulabilityAreaSettings)
    assert scenario.settings.respect_joint_limits
    result = get_planner(scenario.method)().plan(scenario.build())
    assert result.status is Status.REACHED, result.message
    assert result.info["path_kind"] == "subgoals"
    q_arm = result.trajectory.q[:, 3:]
    lim = scenario.robot.limits
    assert np.all(q_arm >= lim.joint_min - 1e-12) and np.all(q_arm <= lim.joint_max + 1e-12)
    report = check(result.trajectory, scenario.build(), result.status.value)
    assert report.failures() == []  # incl. dq consistency through the blended corners


def test_wall_segment_summary_reports_threshold_and_independent_minimum(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """summary.json holds the threshold, and the checker's own minimum of [Nagatani]'s w (6x6 tool
    Jacobian of the robot model, not the planner's closed form) stays above it."""
    import json

    from mmplan.io.plan_folder import write_plan

    scenario = load_scenario("wall-segment")
    problem = scenario.build()
    result = get_planner(scenario.method)().plan(problem)
    write_plan(tmp_path / "plan", result, problem, scenario)
    summary = json.loads((tmp_path / "plan" / "summary.json").read_text())
    assert summary["manipulability_threshold"] == pytest.approx(0.00397, abs=1e-5)
    assert summary["manipulability_min"] >= summary["manipulability_threshold"]
    assert summary["manipulability_min"] == pytest.approx(
        result.info["manipulability_min"], rel=1e-6
    )
