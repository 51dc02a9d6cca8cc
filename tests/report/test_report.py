"""Report (mmplan.report): files written, self-contained page, figure data checked against
independent computations (closed forms, the robot model, the written files)."""

from __future__ import annotations

import base64
import json
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from mmplan.errors import InputError
from mmplan.robot import get_robot

# [PajakPajak]'s three obstacles (docs/conventions.md), with their influence neighbourhoods.
PAPER_OBSTACLES: list[dict[str, Any]] = [
    {
        "shape": "superellipsoid",
        "center": [0.15, 0.75, 0.10],
        "semi_axes": [0.25, 0.25, 0.10],
        "exponents": [0.1, 1.0],
        "influence": 0.35,
    },
    {"shape": "sphere", "center": [1.25, 0.70, 0.45], "radius": 0.15, "influence": 0.15},
    {
        "shape": "cylinder",
        "base_center": [1.25, 2.5, 0.0],
        "radius": 0.40,
        "height": 0.10,
        "influence": 0.35,
    },
]


def _smooth(tau: np.ndarray) -> np.ndarray:
    return tau**3 * (10 - 15 * tau + 6 * tau**2)


def make_plan_dir(
    folder: Path, obstacles: list[dict[str, Any]] | None = None, samples: int = 401
) -> Path:
    """A small hand-made youbot-3r plan: the platform drives a smooth S-curve past obstacle 1
    (heading along the path, wheel angles integrated from the rolling constraints), the arm
    moves; efforts from the robot's dynamics; history.csv and artifacts.npz with synthetic
    method data."""
    robot = get_robot("youbot-3r")
    obstacles = PAPER_OBSTACLES if obstacles is None else obstacles
    T = 8.0
    t = np.linspace(0.0, T, samples)
    s = _smooth(t / T)
    x = -0.45 * (1 - np.cos(2 * np.pi * s)) / 2
    y = -0.5 + 3.0 * s
    dx_ds, dy_ds = -0.45 * np.pi * np.sin(2 * np.pi * s), np.full_like(s, 3.0)
    theta = np.arctan2(dy_ds, dx_ds)  # heading along the path
    v = np.hypot(dx_ds, dy_ds) * np.gradient(s, t)
    w = np.gradient(theta, t)
    r, d = 0.05, 0.16
    dphi1, dphi2 = (v - d * w) / r, (v + d * w) / r

    def integrate(rate: np.ndarray) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t))])

    q = np.column_stack(
        [
            x,
            y,
            theta,
            integrate(dphi1),
            integrate(dphi2),
            0.3 * np.sin(np.pi * s),
            -0.17 + 0.3 * s,
            0.35 - 0.2 * s,
        ]
    )
    dq = np.gradient(q, t, axis=0)
    ddq = np.gradient(dq, t, axis=0)
    tau = np.array([robot.actuator_efforts(q[i], dq[i], ddq[i]) for i in range(samples)])
    u = 1.0 - np.exp(-t)
    ee = np.array([robot.ee_position(qi) for qi in q])
    names = ["t"] + [f"{p}.{c}" for p in ("q", "dq", "ddq") for c in robot.coordinates]
    names += [f"tau.{a}" for a in robot.actuators] + ["u", "ee.x", "ee.y", "ee.z"]
    data = np.column_stack([t, q, dq, ddq, tau, u, ee])
    folder.mkdir(parents=True, exist_ok=True)
    np.savetxt(
        folder / "trajectory.csv",
        data,
        fmt="%.17g",
        delimiter=",",
        header=",".join(names),
        comments="",
    )
    goal = [float(v) for v in ee[-1]]
    mu = [robot.manipulability(qi) for qi in q]
    summary = {
        "status": "reached",
        "planner": "extended-jacobian",
        "robot": "youbot-3r",
        "duration_s": 7.5,
        "duration_1cm_s": 7.0,
        "duration_1mm_s": 7.5,
        "final_error_m": 0.0,
        "min_clearance_m": 0.12,
        "max_joint_limit_violation": 0.0,
        "max_torque_violation": 0.25,
        "max_pfaffian_residual": 1.5e-3,
        "manipulability_start": mu[0],
        "manipulability_end": mu[-1],
        "manipulability_min": min(mu),
        "compute_time_s": 1.25,
        "samples": samples,
        "message": "hand-made test plan",
        "planner_info": {"max_cond_E": 4e3},
    }
    (folder / "summary.json").write_text(json.dumps(summary, indent=2))
    scenario = {
        "name": "report-test",
        "robot": "youbot-3r",
        "start": [float(v) for v in q[0]],
        "goal": {"position": goal, "tolerance": 0.001},
        "obstacles": obstacles,
        "limits": {
            "joints": {"min": [-2.9496, -1.1345, -2.6354], "max": [2.9496, 1.5708, 2.5307]},
            "torque": {"min": [-1.5, -1.5, -1.0, -10.0, -5.0], "max": [1.5, 1.5, 1.0, 0.0, 0.0]},
        },
        "planner": {"method": "extended-jacobian", "t_max": 120.0, "margin": 0.05},
    }
    (folder / "scenario.yaml").write_text(yaml.safe_dump(scenario, sort_keys=False))
    iterations = np.arange(12.0)
    history = np.column_stack([iterations, 2.0 * 0.5**iterations])
    np.savetxt(
        folder / "history.csv",
        history,
        delimiter=",",
        header="iteration,error_norm",
        comments="",
        fmt="%.17g",
    )
    gx, gy = np.linspace(0.0, 1.0, 21), np.linspace(-0.5, 0.5, 11)
    X, Y = np.meshgrid(gx, gy, indexing="ij")  # (nx, ny), as the LMA planner stores grids
    grid = np.exp(-((X - 0.5) ** 2 + Y**2) * 8.0)
    freq = np.linspace(0.0, 50.0, 101)
    np.savez(
        folder / "artifacts.npz",
        grid_x=gx,
        grid_y=gy,
        manipulability_first=grid,
        ma_masks=np.stack([grid > 0.5, grid > 0.4, grid > 0.3]).astype(float),
        path_xy=np.column_stack([np.linspace(0.4, 0.6, 5), np.linspace(-0.2, 0.2, 5)]),
        freq_hz=freq,
        tip_acceleration=1.0 / (1.0 + (freq - 15.0) ** 2),
    )
    return folder


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
    assert 'id="mmplan-viewer"' in html and "<canvas" in html


def test_report_is_self_contained(report_dir: Path) -> None:
    html = (report_dir / "report.html").read_text()
    assert not re.search(r"https?://|//cdn|<link\b|\bsrc=\"(?!data:)", html)
    assert re.findall(r"<img [^>]*src=\"data:image/png;base64,", html)
    assert "@import" not in html and "url(" not in html


def test_summary_table_shows_summary_values(report_dir: Path) -> None:
    html = (report_dir / "report.html").read_text()
    summary = json.loads((report_dir / "summary.json").read_text())
    for key in (
        "status",
        "duration_1cm_s",
        "duration_1mm_s",
        "max_pfaffian_residual",
        "manipulability_end",
        "compute_time_s",
        "message",
    ):
        row = re.search(rf'<tr data-key="{key}"><th>[^<]*</th><td>([^<]*)</td>', html)
        assert row is not None, key
        value = summary[key]
        shown = f"{value:.4g}" if isinstance(value, float) else str(value)
        assert row.group(1).startswith(shown), (key, row.group(1))
    assert 'data-key="planner_info.max_cond_E"' in html


def test_animation_frames_decode_to_robot_body_positions(report_dir: Path) -> None:
    html = (report_dir / "report.html").read_text()
    match = re.search(r'<script id="mmplan-scene" type="application/json">(.*?)</script>', html)
    assert match is not None
    scene = json.loads(match.group(1))
    assert scene["dtype"] == "int16" and len(scene["t"]) == 300
    frames = (
        np.frombuffer(base64.b64decode(scene["frames"]), dtype="<i2").reshape(
            len(scene["t"]), scene["nPoints"], 3
        )
        * scene["scale"]
    )
    robot = get_robot("youbot-3r")
    data = np.loadtxt(report_dir / "trajectory.csv", delimiter=",", skiprows=1)
    k = 137
    i = int(np.flatnonzero(np.isclose(data[:, 0], scene["t"][k]))[0])
    q = data[i, 1 : 1 + robot.n]
    bodies = robot.body_positions(q)
    for j, name in enumerate(scene["bodies"]):
        np.testing.assert_allclose(frames[k, j], bodies[name], atol=6e-4)
    np.testing.assert_allclose(frames[k, scene["eeIndex"]], robot.ee_position(q), atol=6e-4)
    np.testing.assert_allclose(
        frames[k, scene["nBodies"] + 1 :], robot.collision_points(q), atol=6e-4
    )
    assert len(scene["obstacles"]) == 3 and scene["goal"] is not None
    assert len(scene["links"]) >= 6  # platform -> wheels, arm base, three links, tool


def test_mean_normalization_maps_limits_to_half() -> None:
    from mmplan.report.figure_kit import mean_normalized

    values = np.array([[-1.0, 0.0, 5.0], [3.0, 2.0, 7.0]])
    norm, by_limits = mean_normalized(
        values, np.array([-1.0, -2.0, -np.inf]), np.array([3.0, 2.0, np.inf])
    )
    np.testing.assert_allclose(norm[:, 0], [-0.5, 0.5])  # exactly its limits
    np.testing.assert_allclose(norm[:, 1], [0.0, 0.5])
    np.testing.assert_allclose(norm[:, 2], [-0.5, 0.5])  # no limits: own range
    assert by_limits.tolist() == [True, True, False]


def test_decimation_keeps_ends_and_bound() -> None:
    from mmplan.report.context import decimation

    idx = decimation(10_001, 2000)
    assert idx[0] == 0 and idx[-1] == 10_000 and len(idx) <= 2000
    assert np.all(np.diff(idx) > 0)
    assert decimation(5, 2000).tolist() == [0, 1, 2, 3, 4]


class _Ellipsoid:
    """Axis-aligned ellipsoid F = sum (p_i / a_i)^2: a closed-form reference."""

    def __init__(self, center: list[float], axes: list[float]) -> None:
        self.center = np.asarray(center)
        self.axes = np.asarray(axes)

    def implicit(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(np.sum(((points - self.center) / self.axes) ** 2, axis=1))


def test_surface_along_rays_matches_closed_form_ellipsoid() -> None:
    from mmplan.report.shapes import surface_along_rays, top_outline, wireframe

    model = _Ellipsoid([1.0, -2.0, 0.5], [0.3, 0.2, 0.1])
    rng = np.random.default_rng(7)
    directions = rng.normal(size=(50, 3))
    points = surface_along_rays(model, directions)
    np.testing.assert_allclose(model.implicit(points), 1.0, atol=1e-9)
    rel = points - model.center  # on the rays
    cos = np.sum(rel * directions, axis=1) / (
        np.linalg.norm(rel, axis=1) * np.linalg.norm(directions, axis=1)
    )
    np.testing.assert_allclose(cos, 1.0, atol=1e-12)
    outline = top_outline(model, 64)
    np.testing.assert_allclose(
        ((outline - model.center[:2]) / model.axes[:2]) ** 2 @ [1, 1], 1.0, atol=1e-9
    )
    assert len(wireframe(model, meridians=4, parallels=3, steps=8)) == 7


def test_report_without_optional_files_and_obstacles(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from mmplan.report import render_report_cli

    folder = make_plan_dir(tmp_path / "plain", obstacles=[], samples=41)
    (folder / "history.csv").unlink()
    (folder / "artifacts.npz").unlink()
    (folder / "figures").mkdir()
    (folder / "figures" / "clearance.png").write_bytes(b"stale")  # from an earlier report
    out = render_report_cli(folder)
    assert out == folder / "report.html"
    assert capsys.readouterr().out.startswith(f"wrote {out} (")
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
        "bad = [m for m in sys.modules if m.startswith(('matplotlib', 'mmplan.report'))];"
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
