"""Report (mmplan.report): files written, a self-contained page that opens with a plain
summary, the margins it states checked against the trajectory, the planner's internals folded
away, context data against closed forms."""

from __future__ import annotations

import base64
import html as html_module
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from mmplan.errors import InputError
from mmplan.robot import get_robot
from tests.report.plans import make_plan_dir


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from mmplan.report import write_report

    folder = make_plan_dir(tmp_path_factory.mktemp("plan") / "plan")
    write_report(folder, max_frames=300)
    return folder


EXPECTED_FIGURES = {
    "top_view",
    "clearance",
    "joints",
    "manipulability",
    "torques_wheels",
    "torques_arm",
    "virtual_control",
    "task_error",
    "history",
    "artifact_manipulability_first",
    "artifact_ma_masks",
    "artifact_freq_hz",
    "platform",
}


def test_report_writes_html_and_every_figure(report_dir: Path) -> None:
    html = (report_dir / "report.html").read_text()
    pngs = {p.stem for p in (report_dir / "figures").glob("*.png")}
    assert pngs == EXPECTED_FIGURES
    for name in EXPECTED_FIGURES:
        raw = (report_dir / "figures" / f"{name}.png").read_bytes()
        assert raw[:8] == b"\x89PNG\r\n\x1a\n"
        assert base64.b64encode(raw).decode() in html  # the same image is inlined
    assert 'id="mmplan-viewer"' in html and "MeshCat.Viewer" in html  # meshcat's bundle


def test_report_is_self_contained(report_dir: Path) -> None:
    html = (report_dir / "report.html").read_text()
    assert not re.search(r"<link\b|<script[^>]*\bsrc=|<img[^>]*\bsrc=\"(?!data:)", html)
    assert re.findall(r"<img [^>]*src=\"data:image/png;base64,", html)
    styles = "".join(re.findall(r"<style>(.*?)</style>", html, re.S))
    assert "@import" not in styles and "url(" not in styles
    assert not re.findall(r"url\((?!data:)", html)  # meshcat's own CSS: data: URLs only


def test_page_opens_with_a_plain_summary_then_figures_then_internals(report_dir: Path) -> None:
    html = (report_dir / "report.html").read_text()
    order = [html.index(marker) for marker in (
        'id="summary"', 'class="headline"', 'id="view3d"', "<h2>Figures</h2>",
        '<details id="internals">')]
    assert order == sorted(order)
    headline = re.search(r'<p class="headline">([^<]*)</p>', html)
    assert headline is not None
    text = headline.group(1)
    assert "reached the goal" in text and "within the 1 mm tolerance from t = 7.5 s" in text
    assert "reach time" in text and "ends at t = 8 s" in text
    summary_part = html[: html.index('<details id="internals">')]
    assert "max_cond_E" not in summary_part  # planner internals only in the folded part
    assert "[PajakPajak]" in html.split("References", 1)[1]


def test_internals_show_every_summary_value(report_dir: Path) -> None:
    html = (report_dir / "report.html").read_text()
    internals = html[html.index('<details id="internals">'):]
    summary = json.loads((report_dir / "summary.json").read_text())
    for key in ("status", "duration_1cm_s", "duration_1mm_s", "max_pfaffian_residual",
                "manipulability_end", "compute_time_s", "message"):
        row = re.search(rf'<tr data-key="{key}"><th>[^<]*</th><td>([^<]*)</td>', internals)
        assert row is not None, key
        value = summary[key]
        shown = f"{value:.4g}" if isinstance(value, float) else str(value)
        assert row.group(1).startswith(shown), (key, row.group(1))
    assert 'data-key="planner_info.max_cond_E"' in internals


def _cell(html: str, key: str, column: int) -> str:
    row = re.search(rf'<tr data-key="{re.escape(key)}">(.*?)</tr>', html)
    assert row is not None, key
    cells = re.findall(r"<t[hd]>(.*?)</t[hd]>", row.group(1))
    return html_module.unescape(str(cells[column]))


def test_limits_table_states_margins_computed_from_the_trajectory(report_dir: Path) -> None:
    html = (report_dir / "report.html").read_text()
    data = np.loadtxt(report_dir / "trajectory.csv", delimiter=",", skiprows=1)
    scenario = yaml.safe_load((report_dir / "scenario.yaml").read_text())
    robot = get_robot("youbot-3r")
    q_arm = data[:, 1 + robot.n_platform : 1 + robot.n]
    lo, hi = (np.array(scenario["limits"]["joints"][k]) for k in ("min", "max"))
    for j, name in enumerate(robot.arm_coordinates):
        gap = np.minimum(q_arm[:, j] - lo[j], hi[j] - q_arm[:, j]).min()
        margin = _cell(html, f"limit.joint.{name}", 3)
        assert margin.startswith(f"{gap:.3g} rad"), (name, margin)
        assert "✓" in margin
    tau = data[:, 1 + 3 * robot.n : 1 + 3 * robot.n + len(robot.actuators)]
    tlo, thi = (np.array(scenario["limits"]["torque"][k]) for k in ("min", "max"))
    for j, name in enumerate(robot.actuators):
        gap = np.minimum(tau[:, j] - tlo[j], thi[j] - tau[:, j]).min()
        assert _cell(html, f"limit.effort.{name}", 3).startswith(f"{gap:.3g} N m"), name
    clearance = _cell(html, "limit.clearance", 1)
    assert clearance.startswith("0.12 m (obstacle ")  # summary.json's min_clearance_m
    assert "0.07 m outside the planner" in _cell(html, "limit.clearance", 3)  # 0.12 - 0.05
    pfaffian = _cell(html, "limit.pfaffian", 3)  # the hand-made summary claims 1.5e-3 m/s
    assert "broken" in pfaffian and _cell(html, "limit.pfaffian", 2).startswith("<= 1e-06")


def test_rate_limit_margins_of_the_summary_are_listed(tmp_path: Path) -> None:
    from mmplan.report.context import build_context
    from mmplan.report.overview import overview
    from mmplan.report.plan_data import read_plan_dir

    folder = make_plan_dir(tmp_path / "rates", obstacles=[], samples=41)
    summary = json.loads((folder / "summary.json").read_text())
    summary.update({"peak_velocity": {"q1": 1.2}, "peak_platform_speed_mps": 0.7,
                    "limit_margins": {"velocity.q1": 0.37, "platform_speed": -0.1}})
    (folder / "summary.json").write_text(json.dumps(summary))
    rows = {r.key: r for r in overview(build_context(read_plan_dir(folder))).limits}
    q1 = rows["limit.rate.velocity.q1"]
    assert (q1.worst, q1.limit, q1.margin, q1.ok) == ("peak 1.2 rad/s", "<= 1.57 rad/s",
                                                      "0.37 rad/s", True)
    speed = rows["limit.rate.platform_speed"]
    assert (speed.limit, speed.ok) == ("<= 0.6 m/s", False)


def test_segment_plans_speak_of_the_path_parameter(tmp_path: Path) -> None:
    from mmplan.report.context import build_context
    from mmplan.report.overview import overview
    from mmplan.report.plan_data import read_plan_dir

    folder = make_plan_dir(tmp_path / "segment", obstacles=[], samples=41)
    scenario = yaml.safe_load((folder / "scenario.yaml").read_text())
    scenario["goal"] = {"segment": {"start": [0, 0, 0.3], "end": [0, 0.6, 0.6],
                                    "normal": [1, 0, 0]}, "tolerance": 0.001}
    (folder / "scenario.yaml").write_text(yaml.safe_dump(scenario))
    ctx = build_context(read_plan_dir(folder))
    view = overview(ctx)
    assert not ctx.timed and ctx.t_label == "segment parameter s [-]"
    assert "s = 8" in view.headline and "parameter s runs from 0 to 1" in view.headline
    assert dict((k, v) for _, v, k in view.facts)["fact.t_end"] == "s = 8"


def test_report_without_optional_files_and_obstacles(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from mmplan.cli.main import main

    folder = make_plan_dir(tmp_path / "plain", obstacles=[], samples=41)
    (folder / "history.csv").unlink()
    (folder / "artifacts.npz").unlink()
    (folder / "figures").mkdir()
    (folder / "figures" / "clearance.png").write_bytes(b"stale")  # from an earlier report
    result = CliRunner().invoke(main, ["report", str(folder)])
    out = folder / "report.html"
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith(f"wrote {out} (")
    pngs = {p.stem for p in (folder / "figures").glob("*.png")}
    assert pngs == {
        "top_view",
        "joints",
        "manipulability",
        "torques_wheels",
        "torques_arm",
        "virtual_control",
        "task_error",
        "platform",
    }


def test_core_and_cli_do_not_import_plotting() -> None:
    code = (
        "import sys, mmplan, mmplan.cli.main, mmplan.io.plan_folder, mmplan.robot;"
        "bad = [m for m in sys.modules if m.startswith(('matplotlib', 'mmplan.report', "
        "'meshcat'))];"
        "print(bad); sys.exit(1 if bad else 0)"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stdout + run.stderr


def test_report_rejects_a_directory_that_is_no_plan(tmp_path: Path) -> None:
    from mmplan.report import write_report

    with pytest.raises(InputError, match=r"trajectory\.csv"):
        write_report(tmp_path)
    folder = make_plan_dir(tmp_path / "bad", obstacles=[], samples=11)
    text = (folder / "trajectory.csv").read_text().splitlines()
    text[3] = text[3].replace(",", ",x", 1)
    (folder / "trajectory.csv").write_text("\n".join(text))
    with pytest.raises(InputError, match=r"trajectory\.csv:4"):
        write_report(folder)


def test_context_tracking_error_and_sphere_clearance_match_closed_forms(tmp_path: Path) -> None:
    from mmplan.report.context import build_context
    from mmplan.report.plan_data import read_plan_dir

    center, radius = np.array([1.25, 0.70, 0.45]), 0.15
    sphere = {"shape": "sphere", "center": center.tolist(), "radius": radius}
    folder = make_plan_dir(tmp_path / "path", obstacles=[sphere], samples=81)
    scenario = yaml.safe_load((folder / "scenario.yaml").read_text())
    start, velocity = [0.1, 0.2, 0.3], [0.0, 0.4, 0.0]
    path = {"kind": "line", "start": start, "velocity": velocity, "duration": 8.0}
    scenario["goal"] = {"path": path, "tolerance": 0.01}
    (folder / "scenario.yaml").write_text(yaml.safe_dump(scenario))
    ctx = build_context(read_plan_dir(folder), max_samples=30)
    data = np.loadtxt(folder / "trajectory.csv", delimiter=",", skiprows=1)
    t, ee = data[:, 0], data[:, -3:]
    expected = np.linalg.norm(ee - (np.array(start) + t[:, None] * np.array(velocity)), axis=1)
    assert ctx.task_kind == "path" and ctx.tolerance == 0.01
    assert ctx.task_error is not None
    np.testing.assert_allclose(ctx.task_error, expected, rtol=1e-12, atol=1e-12)
    robot = get_robot("youbot-3r")
    assert len(ctx.index) == 30 and ctx.clearance.shape == (30, 1)
    for k, i in enumerate(ctx.index):
        points = robot.collision_points(data[i, 1 : 1 + robot.n])
        exact = np.min(np.linalg.norm(points - center, axis=1)) - radius
        assert abs(ctx.clearance[k, 0] - exact) < 1e-6


def test_obstacle_influence_falls_back_to_the_planner_setting() -> None:
    from mmplan.report.context import build_obstacles

    dicts = [
        {"shape": "sphere", "center": [0.0, 0.0, 0.5], "radius": 0.1, "influence": 0.2},
        {"shape": "sphere", "center": [1.0, 0.0, 0.5], "radius": 0.1},
    ]
    views = build_obstacles(dicts, default_influence=0.35)
    assert [v.influence for v in views] == [0.2, 0.35]
    assert [v.label for v in views] == ["1 sphere", "2 sphere"]
    assert [v.influence for v in build_obstacles(dicts)] == [0.2, None]
    with pytest.raises(InputError, match=r"obstacles\[1\]"):
        build_obstacles([dicts[0], {"shape": "sphere", "center": [0, 0, 0], "radius": -1.0}])
