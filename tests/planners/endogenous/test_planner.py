"""Endogenous configuration space planner ([JaniakTchon]): the paper's three examples, a seeded
set of random targets and bounds, bad input, and the built-in scenario files."""

from __future__ import annotations

import numpy as np
import pytest

from mmplan.errors import InputError
from mmplan.planners import get_planner
from mmplan.planners.endogenous.planner import EndogenousPlanner
from mmplan.planners.endogenous.settings import BoundSetting, EndogenousSettings
from mmplan.problem import Problem
from mmplan.robot.library import get_robot
from mmplan.robot.robot import Robot
from mmplan.scene.scene import Scene
from mmplan.task import ReachPoint
from mmplan.trajectory import PlanResult, Status

START = np.array([20.0, 0.0, np.pi / 2, 0.0, 0.0, 1.0, np.pi / 2])  # (q0, x0), [JaniakTchon] s.III
LAMBDA0 = (-1.0, 0.5, -0.5, -0.2, 0.1, 0.1, 0.01, 0.01)
GOAL = (0.0, 0.0, 2.0)
PSI = 3


@pytest.fixture(scope="module")
def robot() -> Robot:
    return get_robot("car-rtr")


def psi_bound(b: float) -> tuple[BoundSetting, ...]:
    return (BoundSetting(coordinate="psi", min=-b, max=b),)


def plan(
    robot: Robot,
    start: np.ndarray = START,
    goal: tuple[float, float, float] = GOAL,
    tolerance: float = 1e-4,
    **settings: object,
) -> PlanResult:
    settings.setdefault("lambda0", LAMBDA0)
    problem = Problem(
        robot, Scene([]), ReachPoint(goal, tolerance), start, EndogenousSettings(**settings)
    )  # type: ignore[arg-type]
    return EndogenousPlanner().plan(problem)


def check_result(
    result: PlanResult,
    robot: Robot,
    start: np.ndarray,
    goal: tuple[float, float, float],
    tolerance: float,
) -> None:
    """Independent checks of any result: finite, starts at start, consistent end point."""
    traj = result.trajectory
    assert traj.is_finite()
    assert result.message
    np.testing.assert_allclose(traj.q[0], start, atol=1e-12)
    np.testing.assert_allclose(traj.dq[0, robot.n_platform :], 0.0, atol=1e-12)
    ee_end = robot.ee_position(traj.q[-1])  # FK of the last sample, not the planner's value
    error = float(np.linalg.norm(ee_end - np.asarray(goal)))
    assert error == pytest.approx(result.info["final_error_m"], abs=1e-9)
    if result.status is Status.REACHED:
        assert error < tolerance
    history = result.history
    assert len(history["iteration"]) == len(history["error_norm"]) == result.info["iterations"] + 1


def test_registered() -> None:
    assert get_planner("endogenous") is EndogenousPlanner


def test_unbounded_plan_turns_the_wheels_beyond_pi_over_2(robot: Robot) -> None:
    result = plan(robot)
    check_result(result, robot, START, GOAL, 1e-4)
    assert result.status is Status.REACHED
    psi_max = result.info["max_abs.psi"]
    assert psi_max > np.pi / 2  # the paper's figure 2: cusp turn
    assert psi_max == pytest.approx(6.57, abs=0.02)  # [RefRuns]
    errors = result.history["error_norm"]
    assert errors[0] > 10 and errors[-1] < 1e-4


@pytest.mark.parametrize("bound", [np.pi / 3, np.pi / 6])
def test_bounded_plans_respect_the_steering_bound(robot: Robot, bound: float) -> None:
    result = plan(robot, bounds=psi_bound(bound))
    check_result(result, robot, START, GOAL, 1e-4)
    assert result.status is Status.REACHED
    psi = result.trajectory.q[:, PSI]
    assert np.abs(psi).max() <= 1.05 * bound
    assert result.info["bound_overshoot.psi"] == pytest.approx(np.abs(psi).max() / bound - 1)
    assert result.info["bound_residual"] < 1e-4
    assert len(result.trajectory.extra) == 2  # u1, u2


def random_case(
    rng: np.random.Generator,
) -> tuple[np.ndarray, tuple[float, float, float], dict[str, object]]:
    start = np.array(
        [
            *rng.uniform(-5, 5, 2),
            rng.uniform(-np.pi, np.pi),
            rng.uniform(-0.2, 0.2),
            rng.uniform(-np.pi, np.pi),
            rng.uniform(0, 2),
            rng.uniform(0.2, 1.3),
        ]
    )
    goal = (float(rng.uniform(-15, 15)), float(rng.uniform(-15, 15)), float(rng.uniform(0.2, 3)))
    terms = [(3, 5), (5, 5), (1, 3)][int(rng.integers(3))]
    bounds: list[BoundSetting] = []
    kind = int(rng.integers(4))
    if kind >= 1:
        bounds += psi_bound(float(rng.uniform(0.3, 1.5)))
    if kind == 3:
        bounds.append(BoundSetting(coordinate="x2", min=0.0, max=3.0))
    settings = {
        "horizon": float(rng.choice([0.5, 1.0, 2.0])),
        "basis_terms": terms,
        "lambda0": tuple(rng.normal(0, 0.3, sum(terms))),
        "bounds": tuple(bounds),
        "steps": 80,
        "max_iterations": 1500,
    }
    return start, goal, settings


def test_random_targets_and_bounds_end_converged_or_with_an_honest_status(
    robot: Robot, rng: np.random.Generator
) -> None:
    statuses = []
    for _ in range(20):
        start, goal, settings = random_case(rng)
        result = plan(robot, start, goal, **settings)
        check_result(result, robot, start, goal, 1e-4)
        assert result.status in (Status.REACHED, Status.STALLED, Status.INFEASIBLE)
        if result.status is Status.REACHED:
            for b in settings["bounds"]:  # type: ignore[attr-defined]
                k = robot.index(b.coordinate)
                assert result.trajectory.q[:, k].max() <= b.max + 0.05 * (b.max - b.min)
                assert result.trajectory.q[:, k].min() >= b.min - 0.05 * (b.max - b.min)
        statuses.append(result.status)
    assert statuses.count(Status.REACHED) >= 18  # measured: 20 of 20


def test_iteration_limit_gives_stalled_with_the_partial_plan(robot: Robot) -> None:
    result = plan(robot, max_iterations=5)
    assert result.status is Status.STALLED
    assert "within 5 iterations" in result.message
    check_result(result, robot, START, GOAL, 1e-4)


@pytest.mark.parametrize(
    ("settings", "field"),
    [
        ({"lambda0": (0.0,) * 8, "bounds": psi_bound(0.5)}, "planner.lambda0"),  # singular J J^T
        ({"bounds": (BoundSetting(coordinate="psi", min=0.1, max=0.5),)}, "planner.bounds[0]"),
        ({"bounds": (BoundSetting(coordinate="psi", min=0.5, max=0.1),)}, "planner.bounds[0]"),
        (
            {"bounds": (BoundSetting(coordinate="zeta", min=-1, max=1),)},
            "planner.bounds[0].coordinate",
        ),
        ({"basis_terms": (3, 5, 1)}, "planner.basis_terms"),
        ({"lambda0": (1.0, 2.0)}, "planner.lambda0"),
    ],
)
def test_bad_settings_are_input_errors(
    robot: Robot, settings: dict[str, object], field: str
) -> None:
    with pytest.raises(InputError) as info:
        plan(robot, **settings)
    assert info.value.field == field


def test_unreachable_height_and_bad_start_are_input_errors(robot: Robot) -> None:
    with pytest.raises(InputError) as info:
        plan(robot, goal=(0.0, 0.0, 12.0))  # x2 <= 5 m and l3 = 0.5 m: top of the reach 5.5 m
    assert info.value.field == "goal.position"
    assert "5.5" in str(info.value)
    with pytest.raises(InputError) as info:
        plan(robot, start=START[:4])
    assert info.value.field == "start"


def test_obstacles_are_refused(robot: Robot) -> None:
    from mmplan.scene import Sphere

    problem = Problem(
        robot,
        Scene([Sphere((10.0, 0.0, 0.5), 0.5)]),
        ReachPoint(GOAL, 1e-4),
        START,
        EndogenousSettings(lambda0=LAMBDA0),
    )
    with pytest.raises(InputError) as info:
        EndogenousPlanner().plan(problem)
    assert info.value.field == "obstacles"


@pytest.mark.parametrize(
    ("name", "bound"),
    [("car-rtr-free", None), ("car-rtr-steer60", np.pi / 3), ("car-rtr-steer30", np.pi / 6)],
)
def test_builtin_scenario_files_load_and_reach_the_goal(name: str, bound: float | None) -> None:
    from mmplan.scenario.loader import load_scenario

    scenario = load_scenario(name)
    problem = scenario.build()
    settings = problem.settings
    assert isinstance(settings, EndogenousSettings)
    assert settings.lambda0 == LAMBDA0
    np.testing.assert_allclose(problem.start, START)
    result = get_planner(scenario.method)().plan(problem)
    assert result.status is Status.REACHED
    psi_max = result.info["max_abs.psi"]
    if bound is None:
        assert settings.bounds == ()
        assert psi_max > np.pi / 2
    else:
        assert [(b.coordinate, b.min, b.max) for b in settings.bounds] == [
            ("psi", pytest.approx(-bound), pytest.approx(bound))
        ]
        assert psi_max <= 1.05 * bound


def test_singular_jacobian_during_the_run_stalls_with_the_singular_value(robot: Robot) -> None:
    sigma = plan(robot).history["min_singular_value"]
    assert sigma.min() < sigma[0]  # the free run passes a near-singular configuration
    threshold = 0.5 * (sigma[0] + sigma.min())
    result = plan(robot, singular_threshold=threshold)
    assert result.status is Status.STALLED
    assert "singular Jacobian" in result.message
    assert result.info["min_singular_value"] < threshold
    check_result(result, robot, START, GOAL, 1e-4)


def test_non_finite_error_ends_as_diverged_with_the_last_finite_plan(
    robot: Robot, monkeypatch: pytest.MonkeyPatch
) -> None:
    from mmplan.planners.endogenous import cache as endogenous_cache
    from mmplan.planners.endogenous import model as endogenous_model
    from mmplan.planners.endogenous import planner as endogenous

    real = endogenous_cache.get_model

    def poisoned(*args: object, **kwargs: object) -> endogenous_model.EndogenousModel:
        model = real(*args, **kwargs)  # type: ignore[arg-type]
        calls = {"n": 0}
        evaluate = model.evaluate

        class Poisoned:
            def __getattr__(self, name: str) -> object:
                return getattr(model, name)

            def evaluate(self, *a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
                calls["n"] += 1
                e, J = evaluate(*a)
                return (e * np.nan, J) if calls["n"] > 6 else (e, J)

        return Poisoned()  # type: ignore[return-value]

    monkeypatch.setattr(endogenous, "get_model", poisoned)
    result = plan(robot)
    assert result.status is Status.DIVERGED
    check_result(result, robot, START, GOAL, 1e-4)


def test_arm_joint_outside_its_limits_is_infeasible_and_a_bound_fixes_it(robot: Robot) -> None:
    from mmplan.robot.limits import Limits

    tight = robot.with_limits(
        Limits(
            np.array([-6.0, 0.0, -6.0]),
            np.array([6.0, 1.2, 6.0]),
            robot.limits.torque_min,
            robot.limits.torque_max,
        )
    )
    goal = (0.0, 0.0, 1.65)  # reachable with x2 <= 1.2 (x2 + 0.5 sin x3), not by the free plan
    free = plan(tight, goal=goal)
    assert free.status is Status.INFEASIBLE
    assert "x2" in free.message and "add a planner bound" in free.message
    bounded = plan(tight, goal=goal, bounds=(BoundSetting(coordinate="x2", min=0.0, max=1.2),))
    assert bounded.status is Status.REACHED
    assert bounded.trajectory.q[:, 5].min() > 0.0
    assert bounded.trajectory.q[:, 5].max() < 1.2
    check_result(bounded, tight, START, goal, 1e-4)
