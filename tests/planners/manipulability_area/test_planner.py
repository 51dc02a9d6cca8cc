"""Manipulability-area planner ([Nagatani]; docs/manipulability_area.md) through Problem objects."""

from __future__ import annotations

import itertools

import casadi as ca
import numpy as np
import pytest
from pydantic import ValidationError

from mmplan.errors import InputError
from mmplan.planners import get_planner
from mmplan.planners.manipulability_area import grid as lma_grid
from mmplan.planners.manipulability_area import path as lma_path
from mmplan.planners.manipulability_area.planner import (
    ManipulabilityArea,
    ManipulabilityAreaSettings,
)
from mmplan.problem import Problem
from mmplan.robot.library import base_6dof_ik as puma_ik
from mmplan.robot.library import get_robot
from mmplan.robot.library.base_6dof_ik import PumaGeometry
from mmplan.scenario import load_scenario
from mmplan.scene import Scene
from mmplan.task import DrawSegment, ReachPoint
from mmplan.trajectory import PlanResult, Status

#: The papers' setting ([Nagatani] ignores joint limits): base-6dof with every arm joint in
#: [-pi, pi] (q6 wider), as the built-in wall-segment scenario states it.
ROBOT = load_scenario("wall-segment").build().robot
GEOM = PumaGeometry.base_6dof()
WALL = DrawSegment((0.0, 0.0, 0.32), (0.0, 0.60, 0.62), (1.0, 0.0, 0.0), 1e-3)
COARSE = {"resolution": 0.04, "layers": 7}


def plan(task: object, robot: object = ROBOT, **settings: object) -> PlanResult:
    problem = Problem(robot, Scene(), task, np.zeros(9),  # type: ignore[arg-type]
                      ManipulabilityAreaSettings(**settings))  # type: ignore[arg-type]
    return ManipulabilityArea().plan(problem)


@pytest.fixture(scope="module")
def wall() -> PlanResult:
    return plan(WALL)


@pytest.fixture(scope="module")
def fk() -> ca.Function:
    s = ROBOT.symbols
    return ca.Function("fk", [s.q], [s.ee_position, s.ee_rotation])


def test_registered_and_defaults() -> None:
    assert get_planner("manipulability-area") is ManipulabilityArea
    s = ManipulabilityAreaSettings()
    grid = lma_grid.Grid.from_bounds(s.x_range, s.y_range, s.resolution)
    assert grid.shape == (100, 221) and grid.cells().shape == (22100, 2)
    assert grid.xs[-1] == pytest.approx(1.0) and grid.ys[-1] == pytest.approx(1.4)
    assert s.layers == 31 and s.threshold_ratio == 0.5


def test_wall_segment_matches_the_reference_runs(wall: PlanResult) -> None:
    info = wall.info
    assert wall.status is Status.REACHED, wall.message
    assert info["path_kind"] == "straight"
    # [RefRuns]: horizontal length 0.122 m (grid displacement (+-2, 12) cells), threshold 0.00397
    assert info["path_length_m"] == pytest.approx(0.01 * np.hypot(2, 12), abs=1e-9)
    assert info["manipulability_threshold"] == pytest.approx(0.00397, abs=5e-6)
    assert info["manipulability_min"] >= info["manipulability_threshold"]
    assert info["manipulability_threshold"] == pytest.approx(
        0.5 * wall.artifacts["manipulability_max_per_layer"].max(), rel=1e-12)
    # the [RefRuns] segment has the same length and clears the threshold (exact IK)
    poses = lma_grid.tool_poses(WALL, 31)
    s = np.linspace(0, 1, 31)[:, None]
    ref = np.array([0.27, 0.26]) + s * np.array([0.02, 0.12])
    w_ref = lma_grid.path_manipulability(GEOM, poses, range(31), ref[None], lma_grid.Branch())
    assert w_ref.min() == pytest.approx(0.00398, abs=5e-6)
    assert w_ref.min() >= info["manipulability_threshold"]
    # it is one of the two shortest grid segments; the planner keeps the one with larger w min
    first = next(iter(lma_path.straight_candidates(wall.artifacts["ma_masks"] > 0.5)))
    xs, ys = wall.artifacts["grid_x"], wall.artifacts["grid_y"]
    pairs = {(round(xs[a[0]], 2), round(ys[a[1]], 2), round(xs[b[0]], 2), round(ys[b[1]], 2))
             for a, b in zip(first.starts, first.ends, strict=True)}
    assert pairs == {(0.27, 0.26, 0.29, 0.38), (0.29, 0.25, 0.27, 0.37)}
    assert info["manipulability_min"] > w_ref.min()


def test_wall_trajectory(wall: PlanResult, fk: ca.Function) -> None:
    traj = wall.trajectory
    assert traj.samples == 31
    np.testing.assert_allclose(traj.t, np.linspace(0, 1, 31))
    q = traj.q
    assert np.all(q[:, 0] > 0)  # base off the wall
    np.testing.assert_allclose(q[:, 2], np.pi)
    # straight base path between start_xy and end_xy, linear in the layer parameter
    a, b = np.array(wall.info["start_xy"]), np.array(wall.info["end_xy"])
    np.testing.assert_allclose(q[:, :2], a + traj.t[:, None] * (b - a), atol=1e-12)
    # tool tip on the segment (robot model FK, independent of base_6dof_ik), tool axis along -x
    p_dm, R_dm = fk.map(31)(q.T)
    p, R = np.asarray(p_dm).T, np.asarray(R_dm).reshape(3, 31, 3).transpose(1, 0, 2)
    target = np.array(WALL.start) + traj.t[:, None] * (np.array(WALL.end) - np.array(WALL.start))
    assert np.abs(p - target).max() < 1e-9
    np.testing.assert_allclose(traj.ee, p, atol=1e-12)
    np.testing.assert_allclose(R[:, :, 2], np.tile([-1.0, 0.0, 0.0], (31, 1)), atol=1e-9)
    # manipulability along the exact path (batched det of the 6x6 Jacobian) >= threshold
    w = np.abs(np.linalg.det(puma_ik.jacobian(GEOM, q[:, 3:])))
    assert w.min() >= wall.info["manipulability_threshold"]
    assert w.min() == pytest.approx(wall.info["manipulability_min"], rel=1e-9)


def test_no_shorter_straight_segment_by_brute_force(wall: PlanResult) -> None:
    """Round robin over all (start, end) cell pairs shorter than the found segment."""
    masks = wall.artifacts["ma_masks"] > 0.5
    L = masks.shape[0]
    found = wall.info["path_length_m"] / 0.01
    starts, ends = np.argwhere(masks[0]), np.argwhere(masks[-1])
    short: list[tuple[np.ndarray, np.ndarray]] = []
    for a in starts:
        near = ends[np.hypot(*(ends - a).T) < found - 1e-9]
        short.extend((a, e) for e in near)
    pairs = np.array(short)  # (P, 2, 2)
    assert len(pairs) > 1000  # there are many shorter candidates ...
    k = np.arange(L)[:, None, None] / (L - 1)
    cells = np.floor(pairs[None, :, 0] + k * (pairs[None, :, 1] - pairs[None, :, 0]) + 0.5)
    cells = cells.astype(int)
    ok = masks[np.arange(L)[:, None], cells[..., 0], cells[..., 1]].all(axis=0)
    assert not ok.any()  # ... and none of them stays inside the LMA


def test_grid_distribution_matches_model(wall: PlanResult, fk: ca.Function,
                                         rng: np.random.Generator) -> None:
    """Grid w at random MA cells = sqrt(det(J J^T)) of a finite-difference model Jacobian."""
    masks = wall.artifacts["ma_masks"][0] > 0.5
    cells = np.argwhere(masks)[rng.choice(int(masks.sum()), 5, replace=False)]
    xs, ys = wall.artifacts["grid_x"], wall.artifacts["grid_y"]
    poses = lma_grid.tool_poses(WALL, 31)
    for i, j in cells:
        q_arm, ok = lma_grid.configurations(GEOM, poses, 0, np.array([[xs[i], ys[j]]]),
                                            lma_grid.Branch())
        q = np.concatenate([[xs[i], ys[j], np.pi], q_arm[0]])
        p0, R0 = (np.asarray(v) for v in fk(q))
        np.testing.assert_allclose(p0.ravel(), WALL.start, atol=1e-9)
        J = np.zeros((6, 6))
        for c in range(6):
            e = np.zeros(9)
            e[3 + c] = 1e-6
            pp, Rp = (np.asarray(v) for v in fk(q + e))
            pm, Rm = (np.asarray(v) for v in fk(q - e))
            J[:3, c] = ((pp - pm) / 2e-6).ravel()
            W = (Rp - Rm) / 2e-6 @ R0.T
            J[3:, c] = [W[2, 1], W[0, 2], W[1, 0]]
        w = np.sqrt(np.linalg.det(J @ J.T))
        assert ok[0] and abs(w - wall.artifacts["manipulability_first"][i, j]) < 1e-8


def test_artifacts_for_the_report(wall: PlanResult) -> None:
    art = wall.artifacts
    assert art["ma_masks"].shape == (31, 100, 221)
    assert art["manipulability_first"].shape == (100, 221)
    assert art["path_xy"].shape == (31, 2) and art["path_manipulability"].shape == (31,)
    for key in ("manipulability_threshold", "manipulability_min", "path_length_m", "start_xy",
                "end_xy"):
        assert key in wall.info
    # the MA of the first layer is the thresholded distribution
    th = wall.info["manipulability_threshold"]
    np.testing.assert_array_equal(art["ma_masks"][0] > 0.5, art["manipulability_first"] >= th)


def test_heading_changes_q1_only() -> None:
    """The first joint is vertical through the platform centre: w and the base path do not
    depend on the heading, q1 absorbs it ([Nagatani]: heading fixed by the task)."""
    a = plan(WALL, **COARSE)
    b = plan(WALL, heading=np.pi / 2, **COARSE)
    assert a.status is Status.REACHED and b.status is Status.REACHED
    np.testing.assert_allclose(a.trajectory.q[:, :2], b.trajectory.q[:, :2], atol=1e-12)
    np.testing.assert_allclose(a.artifacts["path_manipulability"],
                               b.artifacts["path_manipulability"], rtol=1e-9)
    dq1 = (b.trajectory.q[:, 3] - a.trajectory.q[:, 3] + np.pi) % (2 * np.pi) - np.pi
    np.testing.assert_allclose(dq1, np.pi / 2, atol=1e-9)  # theta + q1 is invariant
    np.testing.assert_allclose(b.trajectory.ee, a.trajectory.ee, atol=1e-9)


def test_base_never_behind_the_wall() -> None:
    res = plan(WALL, x_range=(-0.6, 1.0), resolution=0.02, layers=11)
    xs = res.artifacts["grid_x"]
    assert xs.min() < 0 and res.status is Status.REACHED, res.message
    assert not res.artifacts["ma_masks"][:, xs <= 0, :].any()
    assert np.all(res.trajectory.q[:, 0] > 0)


def test_subgoals_when_no_straight_segment_exists() -> None:
    task = DrawSegment((0.0, 0.0, 0.35), (0.0, -0.6, 0.27), (1.0, 0.0, 0.0), 1e-3)
    res = plan(task, get_robot("base-6dof"))  # the PUMA's own limits (Corke): a thin LMA
    info = res.info
    assert res.status is Status.REACHED, res.message
    assert info["path_kind"] == "subgoals" and info["straight_lengths_checked"] == 0
    keep = info["subgoal_layers"]
    assert keep[0] == 0 and keep[-1] == 30 and len(keep) >= 3
    xy = res.trajectory.q[:, :2]
    way = np.array(info["subgoal_xy"])
    np.testing.assert_allclose(xy[[0, -1]], way[[0, -1]], atol=1e-12)
    h = info["corner_blend_half_width"]
    assert h == pytest.approx(0.5 / 30)  # corners rounded over half a layer interval
    for n, (i, j) in enumerate(itertools.pairwise(keep)):  # straight pieces between sub-goals
        s = np.linspace(0, 1, j - i + 1)[:, None]
        line = way[n] + s * (way[n + 1] - way[n])
        np.testing.assert_allclose(xy[i + 1: j], line[1:-1], atol=1e-12)
    for n, k in enumerate(keep[1:-1], start=1):  # the blend cuts each corner by |dv| h / 4
        dv = (way[n + 1] - way[n]) / (keep[n + 1] - k) - (way[n] - way[n - 1]) / (k - keep[n - 1])
        gap = np.linalg.norm(xy[k] - way[n])
        assert gap == pytest.approx(np.linalg.norm(dv * 30) * h / 4, rel=1e-9)
    w = np.abs(np.linalg.det(puma_ik.jacobian(GEOM, res.trajectory.q[:, 3:])))
    assert w.min() >= info["manipulability_threshold"]
    assert info["max_joint_limit_violation_rad"] == 0.0
    assert info["max_task_error_m"] < 1e-9 and np.all(xy[:, 0] > 0)
    off = plan(task, get_robot("base-6dof"), subgoals=False)
    assert off.status is Status.INFEASIBLE and "no straight base segment" in off.message


def test_unreachable_pose_names_the_layer() -> None:
    # the wrist centre is at the tool height (tool horizontal) and at most a2 + sqrt(a3^2 +
    # d4^2) = 0.3456 m from the shoulder (0.45 m high): heights below 0.1044 m are out of reach
    reach = GEOM.a[1] + np.hypot(GEOM.a[2], GEOM.d[3])
    z = np.linspace(0.30, 0.05, 7)
    first = int(np.argmax(z < GEOM.shoulder_height - reach))
    assert first == 5
    res = plan(DrawSegment((0.0, 0.0, 0.30), (0.0, 0.3, 0.05), (1.0, 0.0, 0.0)), **COARSE)
    assert res.status is Status.INFEASIBLE
    assert f"layer {first} " in res.message and "unreachable" in res.message
    assert res.trajectory.is_finite()


def test_empty_area_names_the_layer() -> None:
    res = plan(WALL, threshold=1.0, **COARSE)
    assert res.status is Status.INFEASIBLE
    assert "layer 0" in res.message and "empty" in res.message
    res = plan(DrawSegment((0, 0, 0.45), (0, 0.05, 0.70), (1, 0, 0)), threshold_ratio=0.6,
               **COARSE)
    assert res.status is Status.INFEASIBLE and "layer 6" in res.message


def test_bad_input_raises_input_error() -> None:
    with pytest.raises(InputError, match="goal"):
        plan(ReachPoint((0.0, 0.0, 0.3)), **COARSE)
    with pytest.raises(InputError, match="robot"):
        problem = Problem(get_robot("youbot-3r"), Scene(), WALL, np.zeros(8),
                          ManipulabilityAreaSettings(**COARSE))  # type: ignore[arg-type]
        ManipulabilityArea().plan(problem)
    with pytest.raises(InputError, match="normal"):
        plan(DrawSegment((0, 0, 0.3), (0, 0.1, 0.3), (0, 0, 1)), **COARSE)
    with pytest.raises(ValidationError):
        ManipulabilityAreaSettings(x_range=(1.0, 0.5))
    with pytest.raises(ValidationError):
        ManipulabilityAreaSettings(layers=1)
    with pytest.raises(ValidationError):
        ManipulabilityAreaSettings(grid=0.1)  # type: ignore[call-arg]


def test_a_path_that_breaks_joint_limits_is_never_reached() -> None:
    """Ignoring the limits (the paper's way) may give a path outside them: that plan is
    infeasible, not reached (it was reported reached before), and the checker agrees."""
    from mmplan.verify.check import check

    robot = get_robot("base-6dof")
    res = plan(WALL, robot, respect_joint_limits=False, **COARSE)
    assert res.info["max_joint_limit_violation_rad"] > 0.1
    assert res.status is Status.INFEASIBLE and "joint limits" in res.message
    problem = Problem(robot, Scene(), WALL, np.zeros(9), ManipulabilityAreaSettings(**COARSE))
    report = check(res.trajectory, problem, status=res.status.value)
    assert any(f.startswith("joint limits") for f in report.failures())
    assert not any(f.startswith("status") for f in report.failures())
    respected = plan(WALL, robot, **COARSE)  # the default respects them
    assert respected.info["max_joint_limit_violation_rad"] == 0.0
