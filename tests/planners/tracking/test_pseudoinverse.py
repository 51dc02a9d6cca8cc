"""Weighted-pseudoinverse path tracking ([AbdessemedDjebrani] s.2; docs/tracking.md)."""

from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np
import pytest
from pydantic import ValidationError

from mmplan.planners.tracking.planner import PseudoinversePlanner
from mmplan.planners.tracking.potentials import barrier_term
from mmplan.planners.tracking.pseudoinverse import WeightedPseudoinverse, coordinate_weights
from mmplan.planners.tracking.settings import PseudoinverseSettings
from mmplan.problem import Problem
from mmplan.robot.library import get_robot
from mmplan.scene import Scene, obstacle_from_dict
from mmplan.task import LinePath
from mmplan.trajectory import PlanResult, Status

START = np.array([0.0, 0.0, 0.0, 0.0, -np.pi / 4, np.pi / 2])
PATH = LinePath((0.5, 0.0, 0.7), (0.1, 0.0, 0.0), 30.0, 1e-3)
CYLINDER = {"shape": "cylinder", "base_center": [2.0, 0.05, 0.0], "radius": 0.15, "height": 0.5}


def _robot():  # type: ignore[no-untyped-def]
    return get_robot("diffdrive-3dof")


def _scene() -> Scene:
    return Scene((obstacle_from_dict(CYLINDER),))


def _random_q(rng: np.random.Generator, count: int) -> np.ndarray:
    """Configurations with the platform near the obstacle so that V2 is active."""
    q = np.empty((count, 6))
    q[:, 0] = rng.uniform(1.4, 2.6, count)
    q[:, 1] = rng.uniform(-0.6, 0.6, count)
    q[:, 2] = rng.uniform(-np.pi, np.pi, count)
    q[:, 3] = rng.uniform(-2.5, 2.5, count)
    q[:, 4] = rng.uniform(-1.2, 1.2, count)
    q[:, 5] = rng.uniform(0.3, 2.2, count)
    return q


def _eq2(q: np.ndarray) -> np.ndarray:
    """[AbdessemedDjebrani] eq. (2) with l1, l2, l3 = 0.6, 0.4, 0.3."""
    x, y, phi, t1, t2, t3 = q
    reach = 0.4 * np.cos(t2) + 0.3 * np.cos(t2 + t3)
    return np.array(
        [
            x + np.cos(t1 + phi) * reach,
            y + np.sin(t1 + phi) * reach,
            0.6 - 0.4 * np.sin(t2) - 0.3 * np.sin(t2 + t3),
        ]
    )


def test_fk_matches_eq2(rng: np.random.Generator) -> None:
    robot = _robot()
    for q in rng.uniform(-3, 3, (200, 6)):
        np.testing.assert_allclose(robot.ee_position(q), _eq2(q), atol=1e-12)


def test_task_jacobian_is_pfaffian_over_fd_of_eq2(rng: np.random.Generator) -> None:
    model = WeightedPseudoinverse(_robot(), (), PseudoinverseSettings())
    for q in rng.uniform(-3, 3, (20, 6)):
        J = np.asarray(model.task_jacobian(q))
        h = 1e-6
        fd = np.column_stack([(_eq2(q + h * e) - _eq2(q - h * e)) / (2 * h) for e in np.eye(6)])
        np.testing.assert_allclose(J[1:], fd, atol=1e-8)
        # no lateral slip: sin(phi) dx - cos(phi) dy = 0 (eq. (6))
        np.testing.assert_allclose(J[0], [np.sin(q[2]), -np.cos(q[2]), 0, 0, 0, 0], atol=1e-15)


def test_weights_are_ranges_over_max_range() -> None:
    w = coordinate_weights(_robot(), None)
    b = np.array([10.0, 10.0, 2 * np.pi, 2 * np.pi, np.pi, 5.0])
    np.testing.assert_allclose(w, b / 10.0)


def test_null_projector_annihilated_by_jacobian(rng: np.random.Generator) -> None:
    model = WeightedPseudoinverse(_robot(), _scene().obstacles, PseudoinverseSettings())
    for q in _random_q(rng, 20):
        J = np.asarray(model.task_jacobian(q))
        H = np.asarray(model.null_projector(q))
        assert np.abs(J @ H).max() < 1e-12
        # H = W0^-1 (I - A^+ A) with A = J W0^-1 (eq. (27))
        w0i = np.diag(1 / np.sqrt(model.w))
        A = J @ w0i
        np.testing.assert_allclose(H, w0i @ (np.eye(6) - np.linalg.pinv(A) @ A), atol=1e-12)


def test_closed_form_step_equals_svd_eq27(rng: np.random.Generator) -> None:
    model = WeightedPseudoinverse(_robot(), _scene().obstacles, PseudoinverseSettings())
    for q in _random_q(rng, 20):
        xd, dxd = rng.normal(size=3), rng.normal(size=3)
        fast = np.asarray(model.velocity(q, xd, dxd)).ravel()
        np.testing.assert_allclose(fast, model.svd_velocity(q, xd, dxd), rtol=1e-9, atol=1e-10)
        # the task rows hold: A dq = 0 and J_m dq = dX_d + K (X_d - X)
        J = np.asarray(model.task_jacobian(q))
        rhs = dxd + 2.0 * (xd - model.robot.ee_position(q))
        np.testing.assert_allclose(J @ fast, np.concatenate([[0.0], rhs]), atol=1e-10)


def test_null_vector_is_negative_weighted_gradient_fd(rng: np.random.Generator) -> None:
    settings = PseudoinverseSettings()
    model = WeightedPseudoinverse(_robot(), _scene().obstacles, settings)
    active = 0
    for q in _random_q(rng, 30):
        V1, V2, d_min = (float(v) for v in model.potentials(q))
        if not settings.d_floor + 0.01 < d_min < settings.d0 - 0.01:
            continue
        active += 1
        h = 1e-6
        grad = np.zeros((2, 6))
        for i, e in enumerate(np.eye(6)):
            hi = np.asarray([float(v) for v in model.potentials(q + h * e)[:2]])
            lo = np.asarray([float(v) for v in model.potentials(q - h * e)[:2]])
            grad[:, i] = (hi - lo) / (2 * h)
        z = np.asarray(model.null_vector(q)).ravel()
        np.testing.assert_allclose(z, -0.5 * grad[0] - 1.0 * grad[1], rtol=1e-5, atol=1e-7)
        assert V1 >= 0 and V2 > 0
    assert active >= 5


def test_barrier_term_eq32() -> None:
    d = ca.SX.sym("d")
    term = barrier_term(d, 0.002, 0.6, 0.02)
    f = ca.Function("f", [d], [term, ca.gradient(term, d)])
    for x in (0.05, 0.3, 0.59):
        assert float(f(x)[0]) == pytest.approx(0.5 * 0.002 * (1 / x - 1 / 0.6) ** 2, rel=1e-12)
    assert float(f(0.61)[0]) == 0.0 and float(f(0.61)[1]) == 0.0
    # below the floor (and inside the obstacle) the term continues with the floor's slope
    slope = -0.002 * (1 / 0.02 - 1 / 0.6) / 0.02**2
    for x in (0.0, -0.1, 0.01):
        assert float(f(x)[1]) == pytest.approx(slope, rel=1e-12)
        assert np.isfinite(float(f(x)[0]))
    assert float(f(0.02 - 1e-9)[0]) == pytest.approx(float(f(0.02 + 1e-9)[0]), rel=1e-6)


@pytest.mark.parametrize(
    "data",
    [
        CYLINDER,
        {"shape": "sphere", "center": [0.3, -0.2, 0.5], "radius": 0.25},
        {"shape": "box", "center": [0.1, 0.2, 0.3], "size": [0.4, 0.3, 0.2], "yaw": 0.7},
    ],
)
def test_symbolic_distance_equals_exact_distance(rng: np.random.Generator, data: dict) -> None:
    obstacle = obstacle_from_dict(data)
    p = ca.SX.sym("p", 3)
    f = ca.Function("d", [p], [obstacle.signed_distance_sym(p)])
    center = np.asarray(data.get("center", data.get("base_center")), dtype=float)
    points = center + rng.uniform(-0.8, 0.8, (300, 3))
    ours = np.array([float(f(x)) for x in points])
    np.testing.assert_allclose(ours, obstacle.distance(points), atol=1e-8)


def _plan(
    settings: PseudoinverseSettings,
    scene: Scene | None = None,
    task: LinePath = PATH,
    start: np.ndarray = START,
) -> PlanResult:
    problem = Problem(_robot(), scene if scene is not None else _scene(), task, start, settings)
    return PseudoinversePlanner().plan(problem)


def _horizontal_gap(result: PlanResult) -> float:
    """2D disc clearance of the platform (discs r 0.2 at A and 0.3 ahead) to the cylinder."""
    q = result.trajectory.q
    gaps = []
    for ahead in (0.0, 0.3):
        cx, cy = q[:, 0] + ahead * np.cos(q[:, 2]), q[:, 1] + ahead * np.sin(q[:, 2])
        gaps.append(np.hypot(cx - 2.0, cy - 0.05) - 0.15 - 0.2)
    return float(np.min(gaps))


def test_diffdrive3_track_example() -> None:
    result = _plan(PseudoinverseSettings())
    assert result.status is Status.REACHED, result.message
    tr = result.trajectory
    assert tr.duration == pytest.approx(30.0)
    err = PATH.errors(tr.t, tr.ee)
    assert err[tr.t >= 2.0].max() < 1e-3
    assert result.info["max_error_after_settle_m"] == pytest.approx(err[tr.t >= 2.0].max())
    assert result.info["min_clearance_m"] > 0.03
    assert _horizontal_gap(result) > 0.03
    # the platform went around: it left the straight line y = 0 by more than the disc radius
    assert np.abs(tr.q[:, 1]).max() > 0.2
    # nonholonomic rows hold exactly for the sampled velocities
    residual = np.sin(tr.q[:, 2]) * tr.dq[:, 0] - np.cos(tr.q[:, 2]) * tr.dq[:, 1]
    assert np.abs(residual).max() < 1e-12
    # q is the trapezoid integral of dq to second order (the checker's consistency test)
    incr = np.diff(tr.q, axis=0) / np.diff(tr.t)[:, None] - 0.5 * (tr.dq[1:] + tr.dq[:-1])
    assert np.abs(incr).max() < 1e-2 * np.abs(tr.dq).max()


def test_without_obstacle_term_the_platform_collides() -> None:
    result = _plan(PseudoinverseSettings(beta2=0.0, stop_on_collision=False))
    assert result.info["min_clearance_m"] < -0.1
    assert "collides" in result.message
    assert _horizontal_gap(result) == pytest.approx(-0.30, abs=1e-3)
    # the end effector still tracks: only the platform collides
    tr = result.trajectory
    assert PATH.errors(tr.t, tr.ee)[tr.t >= 2.0].max() < 1e-3


def test_out_of_reach_stops_with_time_and_reason() -> None:
    task = LinePath((0.5, 0.0, 0.7), (0.0, 0.0, 0.2), 6.0, 1e-3)  # rises above the arm's reach
    result = _plan(PseudoinverseSettings(), scene=Scene(), task=task)
    assert result.status in (Status.STALLED, Status.DIVERGED)
    assert "t = " in result.message
    tr = result.trajectory
    assert tr.is_finite() and tr.t[-1] < 6.0
    assert np.abs(tr.dq).max() < 20.0  # stopped before the solution became wild


def test_settings_validation() -> None:
    with pytest.raises(ValidationError):
        PseudoinverseSettings(d_floor=0.7, d0=0.6)
    with pytest.raises(ValidationError):
        PseudoinverseSettings(dt=0.0)
    with pytest.raises(ValidationError):
        PseudoinverseSettings(unknown=1.0)  # type: ignore[call-arg]


def test_random_straight_lines_are_tracked_or_stop_honestly(rng: np.random.Generator) -> None:
    """20 seeded random lines: reachable heights track, unreachable ones stop with a status."""
    robot = _robot()
    settings = PseudoinverseSettings(t_max=8.0)
    outcomes = []
    for _ in range(20):
        q0 = np.array(
            [
                0,
                0,
                rng.uniform(-np.pi, np.pi),
                rng.uniform(-1.5, 1.5),
                rng.uniform(-1.0, 0.3),
                rng.uniform(0.5, 1.8),
            ]
        )
        start = robot.ee_position(q0) + rng.uniform(-0.03, 0.03, 3)
        velocity = rng.normal(size=3) * np.array([0.08, 0.08, 0.05])
        task = LinePath(tuple(start), tuple(velocity), 8.0, 1e-3)
        result = _plan(settings, scene=Scene(), task=task, start=q0)
        tr = result.trajectory
        z = start[2] + velocity[2] * np.array([0.0, 8.0])
        reachable = bool(np.all(np.abs(z - 0.6) < 0.5))
        unreachable = bool(np.any(np.abs(z - 0.6) > 0.72))
        assert tr.is_finite()
        err = task.errors(tr.t, tr.ee)
        if result.status is Status.REACHED:  # honest: covers the path, ends within tolerance
            assert tr.t[-1] == pytest.approx(8.0) and err[-1] < 1e-3
        else:
            assert "t = " in result.message
        if reachable:
            assert result.status is Status.REACHED, result.message
        if unreachable:
            assert result.status in (Status.STALLED, Status.DIVERGED)
        outcomes.append((reachable, unreachable, result.status))
    assert sum(r for r, _, _ in outcomes) >= 5 and sum(u for _, u, _ in outcomes) >= 2


def test_platform_range_length_is_checked() -> None:
    from mmplan.errors import InputError

    with pytest.raises(InputError, match="platform_range"):
        _plan(PseudoinverseSettings(platform_range=(10.0, 10.0)))


def test_unbounded_arm_limits_are_rejected() -> None:
    from mmplan.errors import InputError

    robot = _robot()
    lim = replace(robot.limits, joint_max=np.array([np.inf, 1.0, 1.0]))
    with pytest.raises(InputError, match=r"limits\.joints"):
        coordinate_weights(robot.with_limits(lim), None)


def test_builtin_scenario_plans_and_passes_the_checker() -> None:
    from mmplan.scenario.loader import load_scenario
    from mmplan.verify.check import check

    problem = load_scenario("diffdrive3-track").build()
    assert isinstance(problem.settings, PseudoinverseSettings)
    result = PseudoinversePlanner().plan(problem)
    assert result.status is Status.REACHED, result.message
    report = check(result.trajectory, problem, result.status.value)
    assert report.failures() == []
    assert report.min_clearance_m is not None and report.min_clearance_m > 0.03
    tr = result.trajectory
    assert PATH.errors(tr.t, tr.ee)[tr.t >= 2.0].max() < 1e-3
    # without the obstacle term the checker finds the collision
    update = {"beta2": 0.0, "stop_on_collision": False}
    bare = replace(problem, settings=problem.settings.model_copy(update=update))
    collided = PseudoinversePlanner().plan(bare)
    report = check(collided.trajectory, bare, collided.status.value)
    assert report.min_clearance_m is not None and report.min_clearance_m < -0.1
    assert any(line.startswith("clearance") for line in report.failures())


@pytest.mark.parametrize("name", ["youbot-3r", "youbot-4r", "base-6dof", "omni-3dof"])
def test_other_builtin_robots_track_a_line(name: str) -> None:
    """Any robot fits: J stacks its Pfaffian rows (h = 0..3) over the end-effector rows."""
    from mmplan.verify.check import check

    robot = get_robot(name)
    q0 = np.zeros(robot.n)
    lo, hi = robot.limits.joint_min, robot.limits.joint_max
    q0[list(robot.arm_indices)] = np.clip(0.3, lo + 0.1, hi - 0.1)
    task = LinePath(tuple(robot.ee_position(q0) + 0.01), (0.1, 0.05, 0.0), 3.0, 1e-3)
    # no floor: with the arm at 0.3 rad the youBots' end effector is at the floor (z +-0.01 m)
    problem = Problem(robot, Scene(ground=None), task, q0, PseudoinverseSettings())
    result = PseudoinversePlanner().plan(problem)
    assert result.status is Status.REACHED, result.message
    assert check(result.trajectory, problem, result.status.value).failures() == []


def test_singular_start_stops_at_once_with_the_start_sample() -> None:
    start = np.array([0.0, 0.0, 0.0, 0.0, -np.pi / 2, 0.0])  # arm stretched straight up
    task = LinePath((0.0, 0.0, 1.3), (0.1, 0.0, 0.0), 5.0, 1e-3)
    result = _plan(PseudoinverseSettings(), scene=Scene(), task=task, start=start)
    assert result.status is Status.STALLED
    assert "t = 0.000 s" in result.message and "singular" in result.message
    tr = result.trajectory
    assert tr.samples == 1 and tr.is_finite()
    np.testing.assert_array_equal(tr.q[0], start)
    np.testing.assert_array_equal(tr.dq[0], np.zeros(6))


def test_collision_stops_the_run_by_default() -> None:
    """Without the obstacle term, and face-on into a box (a local minimum of V2)."""
    stopped = _plan(PseudoinverseSettings(beta2=0.0))
    assert stopped.status is Status.STALLED and "collision at t = " in stopped.message
    assert stopped.info["min_clearance_m"] >= 0.0  # the samples kept are collision-free
    box = {"shape": "box", "center": [2.0, 0.05, 0.25], "size": [0.3, 0.3, 0.5]}
    result = _plan(PseudoinverseSettings(), scene=Scene((obstacle_from_dict(box),)))
    assert result.status is Status.STALLED and "local minimum" in result.message
    assert result.info["min_clearance_m"] >= 0.0
    assert result.trajectory.is_finite() and np.abs(result.trajectory.dq).max() < 5.0
