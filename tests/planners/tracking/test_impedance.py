"""Virtual impedance for the omnidirectional mobile manipulator ([AbdessemedDjebrani] s.3)."""

from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np
import pytest
from pydantic import ValidationError

from mmplan.errors import InputError
from mmplan.planners.tracking.impedance import VirtualImpedance, obstacle_force_magnitude
from mmplan.planners.tracking.planner import ImpedancePlanner
from mmplan.planners.tracking.settings import ImpedanceSettings
from mmplan.problem import Problem
from mmplan.robot.library import get_robot
from mmplan.robot.robot import Robot
from mmplan.scene import Scene, obstacle_from_dict
from mmplan.task import LinePath
from mmplan.trajectory import PlanResult, Status

A, B, A1, A2, A3 = 0.2, 0.0, 0.6, 0.4, 0.3
START = np.array([0.1, 0.1, np.pi / 6, np.pi / 4, -np.pi / 2, np.pi / 4])
PATH = LinePath((0.0, 0.0, 1.0), (0.1, 0.1, 0.1), 2.5, 5e-3)
POST = {"shape": "cylinder", "base_center": [0.35, 0.0, 0.0], "radius": 0.01, "height": 0.4}


def _robot() -> Robot:
    """omni-3dof with qa1 in +-2 pi (as the omni3-impedance scenario; the paper has no limits)."""
    robot = get_robot("omni-3dof")
    lim = replace(
        robot.limits,
        joint_min=np.array([-2 * np.pi, -np.pi, -2.5]),
        joint_max=np.array([2 * np.pi, np.pi / 2, 2.5]),
    )
    return robot.with_limits(lim)


def _eq33(q: np.ndarray) -> np.ndarray:
    x, y, th, q1, q2, q3 = q
    r = A3 * np.cos(q2 + q3) + A2 * np.cos(q2)
    return np.array(
        [
            x + (A + np.cos(q1) * r) * np.cos(th) - (B + np.sin(q1) * r) * np.sin(th),
            y + (A + np.cos(q1) * r) * np.sin(th) + (B + np.sin(q1) * r) * np.cos(th),
            A1 - A2 * np.sin(q2) - A3 * np.sin(q2 + q3),
        ]
    )


def _printed_jacobian(q: np.ndarray) -> np.ndarray:
    """J of eq. (34) from the printed D1..D10, columns reordered to (x, y, theta, qa1..qa3)."""
    _, _, th, q1, q2, q3 = q
    C1g, S1g = np.cos(th + q1), np.sin(th + q1)
    C2, S2, C23, S23 = np.cos(q2), np.sin(q2), np.cos(q2 + q3), np.sin(q2 + q3)
    D1 = -A3 * C1g * S23
    D2 = -A2 * C1g * S2 + D1
    D3 = -A2 * S1g * C2 - A3 * S1g * C23
    D4 = -A3 * S1g * S23
    D5 = -A2 * S1g * S2 + D4
    D6 = A2 * C1g * C2 + A3 * C1g * C23
    D7 = -A3 * C23
    D8 = -A2 * C2 + D7
    D9 = -A * np.sin(th) - B * np.cos(th) + D3
    D10 = A * np.cos(th) - B * np.sin(th) + D6
    return np.array([[1, 0, D9, D3, D2, D1], [0, 1, D10, D6, D5, D4], [0, 0, 0, 0, D8, D7]])


def test_fk_and_jacobian_match_eqs_33_34(rng: np.random.Generator) -> None:
    robot = _robot()
    for q in rng.uniform(-3, 3, (200, 6)):
        np.testing.assert_allclose(robot.ee_position(q), _eq33(q), atol=1e-12)
        np.testing.assert_allclose(robot.jacobian(q), _printed_jacobian(q), atol=1e-12)


def test_force_magnitude_law() -> None:
    d = ca.SX.sym("d")
    f = ca.Function("f", [d], [obstacle_force_magnitude(d, 0.15, 1.0, 0.25)])
    a_obs = 0.25 * 0.85**2
    assert float(f(0.0)) == pytest.approx(a_obs) and float(f(0.15)) == pytest.approx(a_obs)
    assert float(f(0.5)) == pytest.approx(a_obs - 0.25 * 0.35**2)
    assert float(f(1.0)) == 0.0 and float(f(2.0)) == 0.0
    assert float(f(1.0 - 1e-9)) == pytest.approx(0.0, abs=1e-9)  # continuous at d_max


def test_force_points_away_from_the_post(rng: np.random.Generator) -> None:
    model = VirtualImpedance(_robot(), (obstacle_from_dict(POST),), ImpedanceSettings())
    for _ in range(20):
        q = np.concatenate([rng.uniform(-0.5, 1.0, 2), rng.uniform(-1, 1, 4)])
        F, d = (np.asarray(v).ravel() for v in model.force(q))
        away = q[:2] - np.array([0.35, 0.0])
        dist = np.linalg.norm(away)
        assert d[0] == pytest.approx(dist - 0.01, abs=1e-9)
        gap = dist - 0.01
        mag = 0.0 if gap >= 1.0 else 0.25 * 0.85**2 - 0.25 * (max(gap, 0.15) - 0.15) ** 2
        np.testing.assert_allclose(F, mag * away / dist, atol=1e-9)


def test_step_solves_eq37_with_impedance_reference(rng: np.random.Generator) -> None:
    settings = ImpedanceSettings()
    robot = _robot()
    model = VirtualImpedance(robot, (obstacle_from_dict(POST),), settings)
    task = PATH
    for _ in range(10):
        q = START + rng.normal(scale=0.2, size=6)
        delta = rng.normal(scale=0.1, size=2)
        t = rng.uniform(0, 2)
        r0, r1 = model.reference(task, t), model.reference(task, t + settings.dt)
        out = np.asarray(model.step(np.concatenate([q, delta, r0, r1]))).ravel()
        u = out[8:14]
        F = np.asarray(model.force(q)[0]).ravel()
        ddelta = (F - delta) / 1.0
        xi_ref = np.concatenate([r0[:3], r0[6:9] + np.array([*delta, 0.0])])
        dxi_ref = np.concatenate([r0[3:6], r0[9:12] + np.array([*ddelta, 0.0])])
        J_t = np.vstack([robot.jacobian(q), np.eye(3, 6)])
        xi = np.concatenate([robot.ee_position(q), q[:3]])
        expected = np.linalg.solve(J_t, dxi_ref + 5.0 * (xi_ref - xi))
        np.testing.assert_allclose(u, expected, rtol=1e-9, atol=1e-10)
        # our reading of the platform task (docs/tracking.md): (X_d,x, X_d,y, pi/4)
        np.testing.assert_allclose(r0[6:9], [0.1 * t, 0.1 * t, np.pi / 4], atol=1e-15)


def _plan(settings: ImpedanceSettings, task: LinePath = PATH, post: bool = True) -> PlanResult:
    scene = Scene((obstacle_from_dict(POST),)) if post else Scene()
    return ImpedancePlanner().plan(Problem(_robot(), scene, task, START, settings))


def _centre_distance(result: PlanResult) -> np.ndarray:
    q = result.trajectory.q
    return np.asarray(np.hypot(q[:, 0] - 0.35, q[:, 1]))


def test_omni3_impedance_example() -> None:
    with_imp = _plan(ImpedanceSettings())
    assert with_imp.status is Status.REACHED, with_imp.message
    tr = with_imp.trajectory
    err = PATH.errors(tr.t, tr.ee)
    assert err[tr.t >= 1.0].max() < 5e-3
    dist = _centre_distance(with_imp)
    assert dist.min() >= 0.25
    assert dist[tr.t >= 1.0].min() > 0.33  # pushed away at the pass (reference 0.365 m)
    assert with_imp.info["min_clearance_m"] > 0
    # info: horizontal platform-centre distance to the post's surface (radius 0.01)
    assert with_imp.info["min_platform_obstacle_distance_m"] == pytest.approx(dist.min() - 0.01)

    without = _plan(ImpedanceSettings(b_obs=0.0, stop_on_collision=False))
    assert _centre_distance(without).min() == pytest.approx(0.2475, abs=2e-3)  # reference 0.247
    # at the pass (t = 1.75 s, where the reference platform path is closest to the post):
    # without impedance the distance is the reference's own, with it the platform is pushed out
    assert without.info["pass_time_s"] == pytest.approx(1.75, abs=0.01)
    assert without.info["platform_obstacle_distance_at_pass_m"] == pytest.approx(0.2375, abs=2e-3)
    at_pass = with_imp.info["platform_obstacle_distance_at_pass_m"]
    assert at_pass == pytest.approx(dist[np.argmin(abs(tr.t - 1.75))] - 0.01, abs=1e-6)
    assert at_pass > 0.33  # [RefRuns]: 0.365 m (centre) at the pass
    assert without.info["min_clearance_m"] < 0  # the platform (r 0.25) touches the post


def test_leaving_the_arm_reach_stalls_near_2_7_s() -> None:
    task = LinePath((0.0, 0.0, 1.0), (0.1, 0.1, 0.1), 3.5, 5e-3)
    result = _plan(ImpedanceSettings(), task=task, post=False)
    assert result.status is Status.STALLED
    assert "singular" in result.message and "t = " in result.message
    assert 2.5 < result.trajectory.t[-1] < 2.8
    assert result.trajectory.is_finite()


def test_needs_an_omnidirectional_platform() -> None:
    with pytest.raises(InputError, match="omnidirectional"):
        VirtualImpedance(get_robot("diffdrive-3dof"), (), ImpedanceSettings())


def test_settings_validation() -> None:
    with pytest.raises(ValidationError):
        ImpedanceSettings(d_min=1.0, d_max=0.5)
    with pytest.raises(ValidationError):
        ImpedanceSettings(damping=0.0)


def test_builtin_scenario_plans_and_passes_the_checker() -> None:
    from mmplan.scenario.loader import load_scenario
    from mmplan.verify.check import check

    problem = load_scenario("omni3-impedance").build()
    assert isinstance(problem.settings, ImpedanceSettings)
    result = ImpedancePlanner().plan(problem)
    assert result.status is Status.REACHED, result.message
    report = check(result.trajectory, problem, result.status.value)
    assert report.failures() == []
    tr = result.trajectory
    assert PATH.errors(tr.t, tr.ee)[tr.t >= 1.0].max() < 5e-3
    assert _centre_distance(result).min() >= 0.25


def test_unreachable_platform_task_stalls_or_diverges_honestly() -> None:
    """Platform pose task 1 m behind a fixed end-effector point: the arm cannot follow."""
    robot = get_robot("omni-3dof")
    q0 = np.array([0.0, 0.0, 0.0, 0.0, -0.3, 1.0])
    task = LinePath(tuple(robot.ee_position(q0)), (0.0, 0.0, 0.0), 5.0, 1e-3)
    base = ImpedanceSettings(platform_offset=(-1.0, 0.0), platform_heading=0.0)
    stalled = ImpedancePlanner().plan(Problem(robot, Scene(), task, q0, base))
    assert stalled.status is Status.STALLED and "singular" in stalled.message
    assert np.abs(stalled.trajectory.dq).max() < 50.0
    # without the singularity rule, the error-growth rule stops the run
    no_sigma = base.model_copy(update={"min_singular_value": 1e-12})
    diverged = ImpedancePlanner().plan(Problem(robot, Scene(), task, q0, no_sigma))
    assert diverged.status is Status.DIVERGED and "max_error" in diverged.message
    assert diverged.trajectory.is_finite()
    tr = diverged.trajectory
    assert task.errors(tr.t, tr.ee).max() <= 0.1 + 1e-12
