"""Extended-Jacobian planner end to end ([PajakPajak], [Pajak]; docs/extended_jacobian.md).

The youbot-4r runs ([Pajak] example) are complete plans (about 1800 steps each); the youbot-3r
obstacle runs use short horizons here (the full runs are in bench/bench_extended_jacobian.py).
Obstacles come from a test-local ellipsoid so that these tests do not depend on the scene
package; test_scenarios.py runs the scenario files with the real scene.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import casadi as ca
import numpy as np
import pytest

from mmplan.errors import InputError
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.planners.extended_jacobian.settings import (
    ExtendedJacobianSettings,
    VirtualControlSettings,
)
from mmplan.problem import Problem
from mmplan.robot.library import get_robot
from mmplan.robot.limits import Limits, RateLimits
from mmplan.robot.robot import Robot
from mmplan.task import ReachPoint, completion_time
from mmplan.trajectory import PlanResult, Status

Q0_4R = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -np.pi / 8, np.pi / 8, 0.0])
Q0_3R = np.array([0.0, -0.5, np.pi / 2, 0.0, 0.0, 0.0, -0.17, 0.35])


class Ellipsoid:
    """Smooth model: radial distance to an axis-aligned ellipsoid (numeric and SX)."""

    def __init__(self, center: Sequence[float], axes: Sequence[float]) -> None:
        self.c, self.a = np.asarray(center, float), np.asarray(axes, float)
        # what the generator's parameter vector takes of a model (parameters.py)
        self.center, self.semi_axes, self.exponents, self.yaw = center, axes, (1.0, 1.0), 0.0

    def radial_distance_sym(self, p: ca.SX) -> ca.SX:
        return ca.norm_2(p - self.c) * (1 - ca.sumsqr((p - self.c) / self.a) ** (-0.5))

    def radial_distance(self, points: np.ndarray) -> np.ndarray:
        d = points - self.c
        return np.linalg.norm(d, axis=1) * (1 - np.sum((d / self.a) ** 2, axis=1) ** (-0.5))


class Blob:
    """Test obstacle following the scene contract (enlarged, superellipsoid, influence)."""

    def __init__(
        self, center: Sequence[float], axes: Sequence[float], influence: float | None
    ) -> None:
        self.center, self.axes, self.influence = center, axes, influence

    def enlarged(self, eps: float) -> Blob:
        return Blob(self.center, [x + eps for x in self.axes], self.influence)

    def superellipsoid(self) -> Ellipsoid:
        return Ellipsoid(self.center, self.axes)


class BlobScene:
    def __init__(self, obstacles: Sequence[Blob]) -> None:
        self.obstacles = list(obstacles)

    def distances(self, points: np.ndarray) -> np.ndarray:
        cols = [ob.superellipsoid().radial_distance(points) for ob in self.obstacles]
        return np.column_stack(cols) if cols else np.zeros((len(points), 0))


def _paper_robot(name: str) -> Robot:
    """A built-in robot without velocity and acceleration limits (the papers' robots)."""
    robot = get_robot(name)
    return robot.with_limits(dataclasses.replace(robot.limits, rates=RateLimits()))


def _plan(
    robot: Robot,
    start: np.ndarray,
    goal: Sequence[float],
    scene: BlobScene | None = None,
    **settings: object,
) -> PlanResult:
    st = ExtendedJacobianSettings.model_validate(settings)
    task = ReachPoint((float(goal[0]), float(goal[1]), float(goal[2])), 1e-3)
    return ExtendedJacobian().plan(Problem(robot, scene or BlobScene([]), task, start, st))  # type: ignore[arg-type]


def _wheel_limited(robot: Robot, limit: float) -> Robot:
    L, n_act = robot.limits, len(robot.actuators)
    lo, hi = np.full(n_act, -np.inf), np.full(n_act, np.inf)
    lo[:2], hi[:2] = -limit, limit
    return robot.with_limits(Limits(L.joint_min, L.joint_max, lo, hi))


@pytest.fixture(scope="module")
def youbot4r_plain() -> PlanResult:
    return _plan(_paper_robot("youbot-4r"), Q0_4R, (2.0, 1.0, 0.3), dt=0.005, t_max=30)


@pytest.fixture(scope="module")
def youbot4r_smooth() -> PlanResult:
    robot = _wheel_limited(_paper_robot("youbot-4r"), 0.2)
    vcs = VirtualControlSettings(growth="distance", eps_tau=0.1)
    return _plan(robot, Q0_4R, (2.0, 1.0, 0.3), dt=0.005, t_max=30, virtual_control=vcs)


def _pfaffian_residual(robot: Robot, result: PlanResult) -> float:
    tr = result.trajectory
    return max(
        float(np.abs(robot.pfaffian(q) @ dq).max()) for q, dq in zip(tr.q, tr.dq, strict=True)
    )


def test_youbot4r_plain_generator_reaches_goal_like_reference(youbot4r_plain: PlanResult) -> None:
    robot, tr = _paper_robot("youbot-4r"), youbot4r_plain.trajectory
    assert youbot4r_plain.status is Status.REACHED
    err = np.linalg.norm(tr.ee - np.array([2.0, 1.0, 0.3]), axis=1)
    assert err[-1] < 1e-3
    assert completion_time(tr.t, err, 1e-2) == pytest.approx(6.1, abs=0.1)  # [RefRuns]
    assert robot.manipulability(tr.q[0]) == pytest.approx(0.0100, abs=5e-5)
    assert tr.is_finite()
    assert tr.u is not None and np.all(tr.u == 1.0)
    assert tr.tau is not None and tr.tau[0, 1] == pytest.approx(2.35, abs=0.01)  # torque step
    assert _pfaffian_residual(robot, youbot4r_plain) < 1e-6
    assert youbot4r_plain.info["max_cond_E"] < 1e5
    # Written efforts are the robot's efforts for the written (q, dq, ddq).
    for k in (0, len(tr.t) // 2, len(tr.t) - 1):
        np.testing.assert_allclose(
            tr.tau[k], robot.actuator_efforts(tr.q[k], tr.dq[k], tr.ddq[k]), atol=1e-9
        )
    # ddq is the derivative of dq (RK4 consistency).
    fd = np.diff(tr.dq, axis=0) / np.diff(tr.t)[:, None]
    mid = 0.5 * (tr.ddq[1:] + tr.ddq[:-1])
    assert np.max(np.abs(fd - mid)) < 1e-2 * max(1.0, np.abs(tr.ddq).max())


def test_youbot4r_smooth_virtual_control(
    youbot4r_plain: PlanResult, youbot4r_smooth: PlanResult
) -> None:
    robot = _paper_robot("youbot-4r")
    tr, plain = youbot4r_smooth.trajectory, youbot4r_plain.trajectory
    assert youbot4r_smooth.status is Status.REACHED
    assert tr.tau is not None and tr.u is not None and plain.tau is not None
    assert np.abs(tr.tau[:, :2]).max() <= 0.2 + 1e-9
    assert tr.u[0] == 0.0 and tr.u.min() >= 0.0 and tr.u.max() <= 1.0
    assert abs(tr.tau[0, 1] - plain.tau[0, 1]) > 2.0  # no torque step at t = 0

    def peak_rate(t: np.ndarray, tau: np.ndarray) -> float:
        rate = np.abs(np.diff(tau[:, :2], axis=0)) / np.diff(t)[:, None]
        return float(rate[t[1:] <= 0.5].max())

    # The plain plan steps at t = 0 (2.35 N m in one sample); the smooth one ramps.
    step = np.abs(plain.tau[0, :2]).max() / plain.t[1]
    assert peak_rate(tr.t, tr.tau) * 10 < max(step, peak_rate(plain.t, plain.tau))
    assert _pfaffian_residual(robot, youbot4r_smooth) < 1e-6
    err = np.linalg.norm(tr.ee - np.array([2.0, 1.0, 0.3]), axis=1)
    t_smooth, t_plain = completion_time(tr.t, err, 1e-3), youbot4r_plain.trajectory.t[-1]
    assert t_smooth is not None and t_smooth < 1.3 * t_plain


def _paper000_scene() -> BlobScene:
    return BlobScene(
        [
            Blob((0.15, 0.75, 0.10), (0.25, 0.25, 0.10), 0.35),
            Blob((1.25, 0.70, 0.45), (0.15, 0.15, 0.15), 0.15),
            Blob((1.25, 2.5, 0.05), (0.40, 0.40, 0.05), 0.35),
        ]
    )


def test_youbot3r_obstacles_torque_start_keeps_limits() -> None:
    """The start lies inside obstacle 1's neighbourhood: the push must fit the torque budget."""
    robot = _paper_robot("youbot-3r")
    result = _plan(
        robot,
        Q0_3R,
        (3.5, 4.0, 0.16),
        _paper000_scene(),
        t_max=1.0,
        virtual_control=VirtualControlSettings(enabled=True, mode="feedback"),
    )
    tr = result.trajectory
    assert result.status is Status.TIMEOUT and tr.is_finite()
    assert tr.tau is not None and tr.u is not None
    lo, hi = robot.limits.torque_min, robot.limits.torque_max
    assert np.all(tr.tau >= lo - 1e-9) and np.all(tr.tau <= hi + 1e-9)
    assert result.history["perturbation_scale"].min() < 1.0  # the budget was needed
    # Without the budget (eq. (24) with the perturbation in b) the first second breaks them.
    raw = _plan(
        robot,
        Q0_3R,
        (3.5, 4.0, 0.16),
        _paper000_scene(),
        t_max=1.0,
        virtual_control=VirtualControlSettings(
            enabled=True, mode="feedback", budget_perturbation=False
        ),
    )
    assert raw.trajectory.tau is not None
    assert np.any(raw.trajectory.tau > hi + 1e-6) or np.any(raw.trajectory.tau < lo - 1e-6)
    points = np.vstack([robot.collision_points(q) for q in tr.q[::10]])
    assert _paper000_scene().distances(points).min() > 0.05


def test_stalled_status_and_partial_trajectory() -> None:
    robot = _paper_robot("youbot-4r")
    result = _plan(
        robot,
        Q0_4R,
        (2.0, 1.0, 0.3),
        dt=0.01,
        lambda_p=1e-4,
        lambda_v=0.02,
        stall_window=0.3,
        stall_progress=1e-3,
        t_max=5,
    )
    assert result.status is Status.STALLED
    assert result.trajectory.is_finite() and result.trajectory.t[-1] < 5


@pytest.mark.parametrize(
    ("start", "goal", "field"),
    [
        (np.r_[Q0_3R[:6], 0.0, 0.0], (3.5, 4.0, 0.16), "start"),  # stretched arm: mu = 0
        (np.r_[Q0_3R[:5], 3.0, -0.17, 0.35], (3.5, 4.0, 0.16), "start[5]"),  # beyond q1 limit
        (Q0_3R, (3.5, 4.0, 2.0), "goal.position[2]"),  # above the arm's reach
        (Q0_3R[:7], (3.5, 4.0, 0.16), "start"),  # wrong length
    ],
)
def test_bad_input_is_rejected_before_planning(
    start: np.ndarray, goal: tuple[float, float, float], field: str
) -> None:
    with pytest.raises(InputError) as info:
        _plan(_paper_robot("youbot-3r"), start, goal)
    assert info.value.field == field


def test_start_in_collision_and_infeasible_torques_are_rejected() -> None:
    robot = _paper_robot("youbot-3r")
    on_platform = BlobScene([Blob((0.0, -0.5, 0.1), (0.1, 0.1, 0.1), None)])
    with pytest.raises(InputError, match="collision"):
        _plan(robot, Q0_3R, (3.5, 4.0, 0.16), on_platform)
    near = BlobScene([Blob((0.0, -0.75, 0.1), (0.05, 0.05, 0.05), None)])
    with pytest.raises(InputError, match="safety margin"):
        _plan(robot, Q0_3R, (3.5, 4.0, 0.16), near, obstacle_margin=0.2)
    L = robot.limits
    weak = robot.with_limits(Limits(L.joint_min, L.joint_max, L.torque_min * 0.1, L.torque_max))
    with pytest.raises(InputError, match="infeasible torque limits"):
        _plan(weak, Q0_3R, (3.5, 4.0, 0.16))


def test_time_mode_keeps_limits_on_the_unconstrained_path() -> None:
    """Time mode (mmplan.time_scaling.topp): same path as without limits, efforts in the zone."""
    robot = _paper_robot("youbot-3r")
    free = _plan(
        robot.with_limits(
            Limits(
                robot.limits.joint_min,
                robot.limits.joint_max,
                np.full(5, -np.inf),
                np.full(5, np.inf),
            )
        ),
        Q0_3R,
        (3.5, 4.0, 0.16),
        _paper000_scene(),
        t_max=1.5,
    )
    timed = _plan(
        robot,
        Q0_3R,
        (3.5, 4.0, 0.16),
        _paper000_scene(),
        t_max=1.5,
        virtual_control=VirtualControlSettings(enabled=True, mode="time"),
    )
    tr, fr = timed.trajectory, free.trajectory
    assert timed.info["virtual_control"] == "time" and tr.is_finite()
    np.testing.assert_allclose(tr.q, fr.q)  # the geometric path is kept
    assert tr.tau is not None and tr.u is not None and fr.tau is not None
    lo, hi = robot.limits.torque_min, robot.limits.torque_max
    zone_hi = hi - 0.05 * (hi - lo)
    assert np.all(tr.tau <= zone_hi + 1e-9) and np.all(tr.tau >= lo + 0.05 * (hi - lo) - 1e-9)
    assert np.abs(fr.tau[:, :2]).max() > 1.5  # the unconstrained plan breaks the wheel limits
    assert tr.u[0] == 0.0 and np.all((tr.u >= 0.0) & (tr.u <= 1.0))
    np.testing.assert_allclose(tr.dq, tr.u[:, None] * fr.dq)
    assert tr.t[-1] > fr.t[-1]  # slower, never faster
    # Efforts are the robot's efforts of the written (q, dq, ddq).
    for k in (1, len(tr.t) // 3, len(tr.t) - 1):
        np.testing.assert_allclose(
            tr.tau[k], robot.actuator_efforts(tr.q[k], tr.dq[k], tr.ddq[k]), atol=1e-8
        )


def test_online_step_matches_the_planned_rollout() -> None:
    """ExtendedJacobian().online(problem).step(q, dq) gives the rollout's ddq, tau and u."""
    robot = _wheel_limited(_paper_robot("youbot-4r"), 0.2)
    settings = ExtendedJacobianSettings.model_validate(
        {"dt": 0.005, "t_max": 0.3, "virtual_control": {"growth": "distance"}}
    )
    problem = Problem(robot, BlobScene([]), ReachPoint((2.0, 1.0, 0.3), 1e-3), Q0_4R, settings)  # type: ignore[arg-type]
    planned = ExtendedJacobian().plan(problem).trajectory
    online = ExtendedJacobian().online(problem)
    assert planned.tau is not None and planned.u is not None
    for k in range(len(planned.t)):
        ddq, tau, u = online.step(planned.q[k], planned.dq[k])
        np.testing.assert_allclose(ddq, planned.ddq[k], atol=1e-12)
        np.testing.assert_allclose(tau, planned.tau[k], atol=1e-12)
        assert u == pytest.approx(planned.u[k], abs=1e-15)


def test_goal_near_an_obstacle_shrinks_its_neighbourhood_and_inside_is_rejected() -> None:
    from mmplan.planners.extended_jacobian.checks import fit_influence
    from mmplan.planners.extended_jacobian.generator import ObstacleTerm

    ball = Ellipsoid((1.0, 0.0, 0.2), (0.2, 0.2, 0.2))
    fitted = fit_influence([ObstacleTerm(ball, 0.35)], np.array([1.0, 0.4, 0.2]))
    assert fitted[0].influence == pytest.approx(0.7 * 0.2)  # goal 0.2 m from the surface
    far = fit_influence([ObstacleTerm(ball, 0.35)], np.array([3.0, 0.0, 0.2]))
    assert far[0].influence == 0.35
    with pytest.raises(InputError) as info:
        _plan(
            _paper_robot("youbot-3r"),
            Q0_3R,
            (3.5, 4.0, 0.16),
            BlobScene([Blob((3.5, 4.0, 0.1), (0.1, 0.1, 0.1), None)]),
        )
    assert info.value.field == "goal.position"


@pytest.mark.parametrize(
    ("name", "t_max"),
    [("youbot4r-reach", 2.0), ("youbot4r-reach-smooth", 2.0), ("youbot3r-obstacles", 1.2)],
)
def test_chunked_fast_path_reproduces_the_step_by_step_loop(name: str, t_max: float) -> None:
    """The chunked fast path (chunks.py, step.py; with the virtual-control choice inside the
    chunk for youbot4r-reach-smooth, torque/feedback.py) gives the loop's samples to ~1e-9."""
    import dataclasses

    from mmplan.planners.extended_jacobian.generator import wheel_metric_inverse
    from mmplan.planners.extended_jacobian.rollout import rollout
    from mmplan.scenario.loader import load_scenario

    problem = load_scenario(name).build()
    dt = min(problem.settings.dt, 0.002)  # several chunks within t_max
    settings = problem.settings.model_copy(update={"t_max": t_max, "dt": dt})
    problem = dataclasses.replace(problem, settings=settings)
    prep = ExtendedJacobian._prepare(problem)
    assert prep.fns.chunk is not None
    args = (prep.fns, problem.robot.pfaffian, wheel_metric_inverse(problem.robot), prep.q0)
    fast = rollout(*args, prep.params, prep.options, fast=True)
    ref = rollout(*args, prep.params, prep.options, fast=False)
    assert fast.status is ref.status and len(fast.t) == len(ref.t) > 200
    assert fast.info["chunked_samples"] > 0.9 * len(fast.t) and ref.info["chunked_samples"] == 0
    np.testing.assert_array_equal(fast.t, ref.t)
    for got, want in ((fast.q, ref.q), (fast.dq, ref.dq), (fast.tau, ref.tau)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * max(1.0, np.abs(want).max()))
    np.testing.assert_allclose(fast.ddq, ref.ddq, rtol=0, atol=1e-8 * np.abs(ref.ddq).max())
    np.testing.assert_allclose(fast.u, ref.u, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.s, ref.s, rtol=0, atol=1e-12)
    assert fast.info["max_cond_E"] == pytest.approx(ref.info["max_cond_E"], rel=1e-9)


def test_symbolic_virtual_control_choice_matches_numpy_cases() -> None:
    """decision_symbolic.choose_sym equals virtual_control.choose wherever eq. (30) holds."""
    from mmplan.planners.extended_jacobian.torque import virtual_control as vc
    from mmplan.planners.extended_jacobian.torque.decision_symbolic import choose_sym

    lo = np.array([-1.5, -1.5, -1.0, -np.inf, -5.0])
    hi = np.array([1.5, 1.5, np.inf, 0.0, 0.0])
    un, a_s, b_s = ca.SX.sym("u"), ca.SX.sym("a", 5), ca.SX.sym("b", 5)
    fn = ca.Function("c", [un, a_s, b_s], list(choose_sym(un, a_s, b_s, lo, hi)))
    rng = np.random.default_rng(11)
    seen = {"inside": 0, "clipped": 0, "infeasible": 0}
    for _ in range(400):
        a, b = rng.normal(0, 2, 5), rng.normal(0, 1.5, 5)
        a[rng.random(5) < 0.15] = 0.0  # controls that u does not move
        u_nom = float(rng.uniform(0, 1))
        ref = vc.choose(u_nom, a, b, lo, hi)
        u, ok = (float(v) for v in fn(u_nom, a, b))
        if ref.feasible:
            assert ok == 1.0 and u == pytest.approx(ref.u, abs=1e-14)
            seen["inside" if ref.u == u_nom else "clipped"] += 1
        else:
            assert ok == 0.0
            seen["infeasible"] += 1
    assert min(seen.values()) > 20


def test_online_step_is_one_call_that_matches_the_numpy_decision() -> None:
    """The online function (decision_symbolic) gives decide()'s ddq, tau, u along a rollout."""
    robot = _wheel_limited(_paper_robot("youbot-4r"), 0.2)
    settings = ExtendedJacobianSettings.model_validate({"dt": 0.005, "t_max": 0.2})
    problem = Problem(robot, BlobScene([]), ReachPoint((2.0, 1.0, 0.3), 1e-3), Q0_4R, settings)  # type: ignore[arg-type]
    from mmplan.planners.extended_jacobian.generator import wheel_metric_inverse
    from mmplan.planners.extended_jacobian.rollout import rollout

    prep = ExtendedJacobian._prepare(problem)
    winv = wheel_metric_inverse(robot)
    # The step-by-step loop decides every sample with NumPy (torque.decision.decide).
    planned = rollout(
        prep.fns, robot.pfaffian, winv, prep.q0, prep.params, prep.options, fast=False
    )
    online = ExtendedJacobian().online(problem)
    assert 0.0 < planned.u[-1] < 1.0  # the choice is exercised
    for k in range(len(planned.t)):
        ddq, tau, u = online.step(planned.q[k], planned.dq[k])
        np.testing.assert_allclose(ddq, planned.ddq[k], atol=1e-12)
        np.testing.assert_allclose(tau, planned.tau[k], atol=1e-12)
        assert u == pytest.approx(planned.u[k], abs=1e-15)
    assert online.fallbacks == 0  # every sample was decided inside the one call
