"""Far obstacles cost nothing: culled before the model is built, verified after (issue 16).

Measured (bench, not asserted here): youbot3r-obstacles with 2000 spheres 100 m away plans
like the scene without them; before culling 300 such spheres took 42 s and 0.6 GB.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mmplan
from mmplan.errors import InputError
from mmplan.planners import culling
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.problem import Problem
from mmplan.scene import Obstacle, Scene, Sphere
from mmplan.scene.cull import near_path, near_points, path_samples
from mmplan.verify.check import check


@pytest.fixture(scope="module")
def problem() -> Problem:
    return mmplan.load_scenario("youbot3r-obstacles").build()


@pytest.fixture(scope="module")
def plain(problem: Problem) -> mmplan.PlanResult:
    return ExtendedJacobian().plan(problem)


def _point(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _far(count: int) -> tuple[Sphere, ...]:
    return tuple(Sphere((100.0 + i % 10, 100.0 + i // 10, 0.5), 0.2) for i in range(count))


def _with(problem: Problem, obstacles: tuple[Obstacle, ...]) -> Problem:
    return replace(problem, scene=replace(problem.scene, obstacles=obstacles))


def test_far_obstacles_are_culled_and_change_nothing(problem: Problem,
                                                     plain: mmplan.PlanResult) -> None:
    far = _far(60)
    # far spheres before and after the scenario's own: the culled scene keeps their order
    mixed = _with(problem, far[:30] + problem.scene.obstacles + far[30:])
    result = ExtendedJacobian().plan(mixed)
    assert result.info["obstacles_culled"] == 60
    assert result.info["obstacles_modelled"] == 3 and result.info["obstacle_replans"] == 0
    assert result.status is plain.status
    np.testing.assert_array_equal(result.trajectory.q, plain.trajectory.q)
    assert check(result.trajectory, mixed, result.status).ok


def test_culled_obstacle_the_plan_comes_near_is_put_back(
        problem: Problem, plain: mmplan.PlanResult, monkeypatch: pytest.MonkeyPatch) -> None:
    """A region too small culls obstacles the plan passes: they are found near the
    trajectory and the problem is planned again with them (the plan without culling)."""
    real = culling.region

    def tiny(p: Problem) -> tuple[np.ndarray, float] | None:
        found = real(p)
        assert found is not None
        return found[0], 0.01

    monkeypatch.setattr(culling, "region", tiny)
    kept = culling.kept_obstacles(problem)
    assert kept is not None and len(kept) < 3
    result = ExtendedJacobian().plan(problem)
    assert result.info["obstacle_replans"] >= 1
    assert result.info["obstacles_culled"] == 0
    np.testing.assert_array_equal(result.trajectory.q, plain.trajectory.q)


def test_too_many_near_obstacles_is_an_input_error(problem: Problem) -> None:
    """Tiny spheres 3 m above the route: near the region, far from the robot."""
    count = culling.MAX_NEAR_OBSTACLES + 1
    xs = np.linspace(0.0, 3.5, count)
    crowd = tuple(Sphere((float(x), float(x) * 4.0 / 3.5, 3.0), 0.001) for x in xs)
    with pytest.raises(InputError) as info:
        ExtendedJacobian().plan(_with(problem, problem.scene.obstacles + crowd))
    message = str(info.value)
    assert message.startswith("obstacles:") and str(culling.MAX_NEAR_OBSTACLES) in message
    assert "\n" not in message


def test_errors_name_obstacles_of_the_whole_scene(problem: Problem) -> None:
    """The planner sees the culled scene; its errors still number the scenario's obstacles."""
    start_ee = problem.robot.ee_position(problem.start)
    on_start = Sphere(_point(start_ee), 0.05)
    scene_obstacles = _far(5) + (on_start,)
    with pytest.raises(InputError, match="obstacle 5"):
        ExtendedJacobian().plan(_with(problem, scene_obstacles))


def test_near_path_keeps_exactly_what_dense_sampling_finds(rng: np.random.Generator) -> None:
    """Independent reference: distance to a densely sampled polyline (1 mm)."""
    path = np.array([[0.0, 0.0, 0.3], [2.0, 1.0, 0.3], [2.5, 3.0, 0.6]])
    obstacles = [Sphere(_point(rng.uniform(-3, 6, 3)),
                        float(rng.uniform(0.05, 0.5))) for _ in range(300)]
    radius = 1.2
    dense = path_samples(path, 1e-3)
    truth = [min(o.distance(dense)) for o in obstacles]
    kept = set(near_path(obstacles, path, radius))
    for i, d in enumerate(truth):
        if d <= radius:
            assert i in kept, (i, d)
        else:
            assert i not in kept or d <= radius + radius / 8 + 1e-3, (i, d)


def test_near_points_matches_brute_force(rng: np.random.Generator) -> None:
    points = rng.uniform(-1, 1, (200, 3))
    radii = rng.uniform(0.0, 0.1, 200)
    obstacles = [Sphere(_point(rng.uniform(-4, 4, 3)), 0.3) for _ in range(80)]
    reach = [float(r) for r in rng.uniform(0.0, 1.5, 80)]
    brute = tuple(i for i, o in enumerate(obstacles)
                  if np.min(o.distance(points) - radii) <= reach[i])
    assert near_points(obstacles, points, radii, reach) == brute
    assert 0 < len(brute) < 80


def test_scene_without_far_obstacles_is_not_touched(problem: Problem) -> None:
    assert culling.kept_obstacles(problem) is None
    assert culling.kept_obstacles(_with(problem, ())) is None
    assert isinstance(problem.scene, Scene)
