"""Review defects of the ``mmplan`` command (--out safety, plan runs the checks, check compares
summary.json, one-line errors), each through the CLI."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from tests.cli.test_cli import BASE, _reachable_goal, changed, run, write


def _reached(tmp_path: Path, **extra: Any) -> Path:
    """A scenario file the test planner reaches in 0.5 s (plus ``extra`` top-level keys)."""
    data = changed("goal", {"position": _reachable_goal(0.5), "tolerance": 0.005})
    data.update(extra)
    return write(tmp_path, data)


def _one_line(text: str) -> str:
    lines = text.strip().splitlines()
    assert len(lines) == 1, text
    return lines[0]


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def test_out_never_replaces_a_folder_with_other_content(tmp_path: Path) -> None:
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("precious")
    result = run("plan", str(_reached(tmp_path)), "--out", str(mine))
    assert result.exit_code == 2
    assert _one_line(result.stderr) == f"error: --out: {mine} exists and is not a plan directory"
    assert [p.name for p in mine.iterdir()] == ["thesis.tex"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine", "scenario.yaml"]


def test_out_replaces_a_plan_folder_with_normal_permissions(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert run("plan", str(_reached(tmp_path)), "--out", str(out), "-q").exit_code == 0
    assert run("report", str(out)).exit_code == 0  # report.html + figures/ are mmplan's
    assert run("plan", str(_reached(tmp_path)), "--out", str(out), "-q").exit_code == 0
    assert not (out / "report.html").exists()
    assert (out.stat().st_mode & 0o777) == 0o777 & ~_umask()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run", "scenario.yaml"]


@pytest.mark.parametrize(("out", "expected"), [
    ("/", "is the working directory, one of its parents or the root"),
    (".", "is the working directory, one of its parents or the root"),
    ("", "is the working directory, one of its parents or the root"),
    ("afile/x", "cannot create"),
    ("/proc/mmplan-x", "cannot create"),
])
def test_out_bad_paths_exit_2_with_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                            out: str, expected: str) -> None:
    scenario = _reached(tmp_path)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("x")
    result = run("plan", str(scenario), "--out", out)
    assert result.exit_code == 2
    line = _one_line(result.stderr)
    assert line.startswith("error: --out: ") and expected in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "scenario.yaml"]


def test_plan_exits_3_when_a_check_fails_although_the_planner_reached(tmp_path: Path) -> None:
    limits = {"joints": {"min": [-2.9, -1.1, -2.6], "max": [0.05, 1.5, 2.5]}}  # q1 <= 0.05
    out = tmp_path / "run"
    result = run("plan", str(_reached(tmp_path, limits=limits)), "--out", str(out))
    assert result.exit_code == 3
    assert "status: reached" in result.stdout
    assert "FAIL joint limits: exceeded by" in result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "reached" and summary["check_passed"] is False
    assert summary["check_failures"][0].startswith("joint limits: exceeded by")
    assert run("check", str(out)).exit_code == 3


def test_plan_records_a_passed_check(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert run("plan", str(_reached(tmp_path)), "--out", str(out), "-q").exit_code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["check_passed"] is True and summary["check_failures"] == []


@pytest.mark.parametrize(("key", "value", "expected"), [
    ("duration_s", 0.1, "summary duration_s: 0.1 but recomputed"),
    ("duration_1cm_s", None, "summary duration_1cm_s: null but recomputed"),
    ("final_error_m", 0.0, "summary final_error_m: 0 but recomputed"),
    ("min_clearance_m", 5.0, "summary min_clearance_m: 5 but recomputed"),
    ("max_torque_violation", "0", "summary max_torque_violation: not a number"),
    ("max_pfaffian_residual", True, "summary max_pfaffian_residual: not a number"),
    ("manipulability_min", 1.0, "summary manipulability_min: 1 but recomputed"),
    ("samples", 3, "summary samples: 3 but trajectory.csv has"),
    ("robot", "car-rtr", "summary robot: 'car-rtr' but the plan's scenario says 'youbot-3r'"),
    ("planner", "pseudoinverse", "summary planner: 'pseudoinverse' but the plan's scenario says"),
    ("status", "awesome", "summary status: 'awesome' is not one of reached"),
])
def test_check_fails_when_summary_disagrees(tmp_path: Path, key: str, value: Any,
                                            expected: str) -> None:
    out = tmp_path / "run"
    assert run("plan", str(_reached(tmp_path)), "--out", str(out), "-q").exit_code == 0
    path = out / "summary.json"
    summary = json.loads(path.read_text())
    summary[key] = value
    path.write_text(json.dumps(summary))
    result = run("check", str(out))
    assert result.exit_code == 3
    assert f"FAIL {expected}" in result.stderr


def test_check_fails_on_a_missing_summary_key(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert run("plan", str(_reached(tmp_path)), "--out", str(out), "-q").exit_code == 0
    summary = json.loads((out / "summary.json").read_text())
    del summary["max_joint_limit_violation"]
    (out / "summary.json").write_text(json.dumps(summary))
    result = run("check", str(out))
    assert result.exit_code == 3
    assert "FAIL summary max_joint_limit_violation: missing" in result.stderr


def test_check_of_a_start_in_collision_fails_clearance(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert run("plan", str(_reached(tmp_path)), "--out", str(out), "-q").exit_code == 0
    sc = yaml.safe_load((out / "scenario.yaml").read_text())
    start = sc["start"]
    sc["obstacles"].append({"shape": "sphere", "center": [start[0], start[1], 0.1],
                            "radius": 0.3})
    (out / "scenario.yaml").write_text(yaml.safe_dump(sc))
    result = run("check", str(out))
    assert result.exit_code == 3, result.output
    assert "FAIL clearance:" in result.stderr and "obstacles[4]" in result.stderr


@pytest.mark.parametrize("content", ["", "t,q.x\n"])
def test_check_of_an_empty_csv_is_one_line(tmp_path: Path, content: str) -> None:
    out = tmp_path / "run"
    assert run("plan", str(_reached(tmp_path)), "--out", str(out), "-q").exit_code == 0
    (out / "trajectory.csv").write_text(content)
    result = run("check", str(out))
    assert result.exit_code == 2
    assert _one_line(result.stderr).endswith("trajectory.csv: no samples")


def test_plan_of_a_directory_and_check_of_a_file_say_so(tmp_path: Path) -> None:
    result = run("plan", str(tmp_path), "--out", str(tmp_path / "o"))
    assert result.exit_code == 2
    assert "is a directory; give a scenario file or a built-in name" in _one_line(result.stderr)
    result = run("check", str(_reached(tmp_path)))
    assert result.exit_code == 2
    assert "is a file; give a plan directory" in _one_line(result.stderr)


def test_summary_has_no_non_finite_numbers_or_number_strings(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert run("plan", str(write(tmp_path, BASE)), "--out", str(out), "-q").exit_code == 3
    text = (out / "summary.json").read_text()
    assert "NaN" not in text and "Infinity" not in text

    def walk(node: Any) -> None:
        if isinstance(node, dict):
            for v in node.values():
                walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)
        else:
            assert not (isinstance(node, str) and node.lower() in {"nan", "inf", "-inf"})
            assert not (isinstance(node, float) and not np.isfinite(node))

    walk(json.loads(text))


def test_report_of_a_failing_plan_warns_and_shows_a_red_banner(tmp_path: Path) -> None:
    limits = {"joints": {"min": [-2.9, -1.1, -2.6], "max": [0.05, 1.5, 2.5]}}  # q1 <= 0.05
    out = tmp_path / "run"
    assert run("plan", str(_reached(tmp_path, limits=limits)), "--out", str(out),
               "-q").exit_code == 3
    result = run("report", str(out))
    assert result.exit_code == 0, result.output
    line = _one_line(result.stderr)
    assert line.startswith("warning: this plan FAILS its checks: joint limits: exceeded by")
    page = (out / "report.html").read_text()
    assert 'class="check-failed"' in page and "The independent check FAILED" in page
    good = tmp_path / "good"
    assert run("plan", str(_reached(tmp_path)), "--out", str(good), "-q").exit_code == 0
    result = run("report", str(good))
    assert result.exit_code == 0 and result.stderr == ""
    assert 'class="check-failed"' not in (good / "report.html").read_text()


def test_no_progress_bar_output_without_a_terminal(tmp_path: Path) -> None:
    """Review defect 14: a slow plan piped to a file printed a stray empty line."""
    data = changed("goal", {"position": _reachable_goal(0.5), "tolerance": 0.005})
    data["planner"] = {**data["planner"], "sleep_s": 3.0}  # 1.5 s to reach: > the bar delay
    code = "import sys, tests.eta_planner; from mmplan.cli.main import main; sys.exit(main())"
    root = Path(__file__).resolve().parents[2]
    proc = subprocess.run([sys.executable, "-c", code, "plan", str(write(tmp_path, data)),
                           "--out", str(tmp_path / "o")], cwd=root, capture_output=True,
                          text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == "" and proc.stdout.startswith("status: reached")


def test_reproduce_only_accepts_every_builtin_scenario() -> None:
    import mmplan
    from mmplan.reproduce.run import run_specs

    for name in mmplan.builtin_scenarios():
        assert name in [s.name for s in run_specs([name])]
    assert "wall-segment-limits" not in [s.name for s in run_specs()]  # no paper numbers
    result = run("reproduce", "--out", "unused", "--only", "nope")
    assert result.exit_code == 2 and "wall-segment-limits" in _one_line(result.stderr)
