"""Compile once per robot model and shape types; re-plan from a moving state with no compile.

Compiles are counted at the C compiler call (``codegen.subprocess.run``) and symbolic
builds at ``generator.build_functions``.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mmplan
from mmplan.compile import codegen
from mmplan.planners.extended_jacobian import cache as ej_cache
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.planners.extended_jacobian.replan import Replanner
from mmplan.scene.scene import Scene
from mmplan.scene.sphere import Sphere
from mmplan.task import ReachPoint
from tests.planners.extended_jacobian.conftest import Counts

EXAMPLE = Path(__file__).parents[3] / "examples" / "replan_moving_obstacle.py"

def _compiled(problem: mmplan.Problem) -> mmplan.Problem:
    settings = problem.settings.model_copy(update={"codegen": True})
    return dataclasses.replace(problem, settings=settings)


@pytest.mark.skipif(codegen.compiler() is None, reason="no C compiler")
def test_new_scene_and_new_run_compile_nothing(counts: Counts) -> None:
    """A moved obstacle and a new goal: no compile, no build; a new process (the in-memory
    cache cleared) loads the library without building the symbolic model, same values."""
    problem = _compiled(mmplan.load_scenario("youbot3r-obstacles-torque").build())
    first = ExtendedJacobian._prepare(problem)
    assert first.fns.compiled
    counts.compiles = counts.builds = 0
    scene = problem.scene
    moved = Scene(
        (scene.obstacles[0], Sphere((1.6, 1.2, 0.4), 0.2, 0.2), scene.obstacles[2]), scene.ground
    )
    other = dataclasses.replace(problem, scene=moved, task=ReachPoint((3.0, 3.6, 0.3), 1e-3))
    sol = ExtendedJacobian().plan(other)
    assert sol.status.value == "reached" and sol.info["compiled"]
    assert (counts.compiles, counts.builds) == (0, 0)
    ej_cache.clear()  # as in a new process: only the disk cache is left
    again = ExtendedJacobian._prepare(problem)
    assert again.fns.compiled and again.fns is not first.fns
    assert (counts.compiles, counts.builds) == (0, 0)
    q, dq = first.q0, 0.1 * np.ones(problem.robot.n)
    a, b = (f.fns.evaluate(q, dq, first.params) for f in (first, again))
    np.testing.assert_array_equal(a.f0, b.f0)
    np.testing.assert_array_equal(a.fp, b.fp)


def _example() -> Any:
    spec = importlib.util.spec_from_file_location("replan_moving_obstacle", EXAMPLE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_replanning_loop_reaches_the_goal_without_collision(counts: Counts) -> None:
    """The example's loop (a ball crossing the path, a drifting sphere, 10 Hz): reached,
    every sample clear of the obstacles where they were and of the floor, no compile and no
    build inside the loop."""
    example = _example()
    ready = example.setup()
    counts.compiles = counts.builds = 0
    result = example.run(seconds=40.0, verbose=False, ready=ready)
    assert result.reached, result
    assert result.clearance > 0.0 and result.floor_gap > 0.0, result
    assert result.crossing < 0.3  # the ball does come near
    assert (counts.compiles, counts.builds) == (0, 0)
    assert len(result.replan_times) >= 50


@pytest.mark.parametrize("sight", ["blind", "frozen"])
def test_a_replanner_that_ignores_the_moving_ball_collides(sight: str) -> None:
    """The crossing ball is in the way: the same loop re-planning without the ball (blind) or
    with the obstacles where they were at t = 0 (frozen) collides with it, so the loop's
    clearance is a test of the re-planning, not of a ball that never comes near."""
    example = _example()
    problem, replanner = example.setup()
    replan = replanner.replan

    def unseeing(q: Any, dq: Any, scene: Scene, **kwargs: Any) -> Any:
        if sight == "blind":
            scene = Scene(scene.obstacles[:3], scene.ground)
        else:
            scene = example.obstacles_at(problem.scene, 0.0)
        return replan(q, dq, scene, **kwargs)

    replanner.replan = unseeing
    result = example.run(seconds=40.0, verbose=False, ready=(problem, replanner))
    assert result.crossing < -0.05, result


def test_online_step_with_culled_obstacle_terms_matches_the_numpy_decision() -> None:
    """The online step (its terms made of the culled obstacle calls, compiled when a compiler
    is present) against the NumPy decision on the generator's terms, at states of a plan
    near the obstacles and the floor."""
    from mmplan.planners.extended_jacobian.torque.decision import decide

    problem = mmplan.load_scenario("youbot3r-obstacles-torque").build()
    vc = problem.settings.virtual_control.model_copy(update={"mode": "feedback"})  # type: ignore[attr-defined]
    settings = problem.settings.model_copy(update={"virtual_control": vc})
    problem = dataclasses.replace(problem, settings=settings)
    prep = ExtendedJacobian._prepare(problem)
    online = ExtendedJacobian().online(problem)
    plan = ExtendedJacobian().plan(problem).trajectory
    zero, checked, near = np.zeros(problem.robot.n), 0, 0
    for k in range(0, len(plan.t), max(1, len(plan.t) // 40)):
        q, dq = plan.q[k], plan.dq[k]
        online.u, online._first = 0.6, False
        before = online.fallbacks
        ddq, tau, u = online.step(q, dq)
        if online.fallbacks > before:
            continue  # decided by NumPy itself
        terms = prep.fns.evaluate(q, dq, prep.params)
        d = decide(terms, dq, 0.6, False, zero, prep.options)
        np.testing.assert_allclose(ddq, d.ddq, rtol=1e-9, atol=1e-9 * (1 + np.abs(d.ddq).max()))
        np.testing.assert_allclose(tau, d.tau, rtol=1e-9, atol=1e-9 * (1 + np.abs(d.tau).max()))
        assert u == pytest.approx(d.u, abs=1e-9)
        checked, near = checked + 1, near + (terms.S > 0)
    assert checked >= 20 and near >= 5, (checked, near)


def _checked(problem: mmplan.Problem, res: Any) -> list[str]:
    """The independent check's failures of a re-plan from the problem's start."""
    from mmplan.trajectory import Trajectory
    from mmplan.verify.check import check

    robot = problem.robot
    ee = np.array([robot.ee_position(q) for q in res.q])
    trajectory = Trajectory(
        coordinates=robot.coordinates, t=res.t, q=res.q, dq=res.dq, ddq=res.ddq, ee=ee,
        actuators=robot.actuators, tau=res.tau, u=res.u,
    )  # fmt: skip
    return check(trajectory, problem, res.status).failures()


def test_a_replan_holds_the_robots_limits() -> None:
    """The paper scenario (the youBot's torque and rate limits) re-planned from its start to
    the goal: the time-scaled re-plan passes the independent check; the generator's own
    timing (limits=False) breaks the platform's speed limit and the wheels' torques."""
    problem = mmplan.load_scenario("youbot3r-obstacles-torque").build()
    replanner = Replanner(problem)
    start, rest = np.asarray(problem.start, dtype=float), np.zeros(problem.robot.n)
    scaled = replanner.replan(start, rest, problem.scene, horizon=60.0)
    assert scaled.status.value == "reached", scaled.message
    assert _checked(problem, scaled) == []
    free = replanner.replan(start, rest, problem.scene, horizon=60.0, limits=False)
    failures = _checked(problem, free)
    assert any("platform speed" in f for f in failures), failures
    assert any(f.startswith("torque limits") for f in failures), failures


def test_a_replan_from_a_moving_state_starts_at_its_velocity() -> None:
    """From a state of the plan (q, dq and its time rate w, the u column) the re-plan starts
    at dq exactly and keeps every rate and effort within the limits."""
    problem = mmplan.load_scenario("youbot3r-obstacles-torque").build()
    plan = ExtendedJacobian().plan(problem).trajectory
    assert plan.u is not None
    replanner = Replanner(problem)
    for t in (2.0, 5.0, 9.0):
        k = int(np.searchsorted(plan.t, t))
        q, dq, w = plan.q[k], plan.dq[k], float(plan.u[k])
        res = replanner.replan(q, dq, problem.scene, horizon=2.0, rate=w)
        np.testing.assert_allclose(res.dq[0], dq, rtol=1e-12, atol=1e-12)
        assert res.info["start_rate"] == pytest.approx(w, rel=1e-12)
        assert res.info["max_rate_ratio"] <= 1.0 + 1e-9
        assert res.info["max_torque_violation"] == 0.0
        assert res.status.value in ("timeout", "reached"), res.message


def test_a_goal_under_an_obstacle_holds_and_bad_states_are_input_errors() -> None:
    problem = mmplan.load_scenario("youbot3r-obstacles-unlimited").build()
    replanner = Replanner(problem)
    q, dq = np.asarray(problem.start, dtype=float), np.full(problem.robot.n, 0.01)
    ball = Sphere(tuple(problem.task.position), 0.2, 0.2)
    scene = Scene((*problem.scene.obstacles, ball), problem.scene.ground)
    held = replanner.replan(q, dq, scene)
    assert held.status.value == "infeasible" and "goal blocked" in held.message
    assert len(held.t) == 1
    np.testing.assert_array_equal(held.q[0], q)
    np.testing.assert_array_equal(held.dq[0], dq)
    from mmplan.errors import InputError

    with pytest.raises(InputError, match=r"^q\[0\]: need a finite number, got nan"):
        replanner.replan(np.full_like(q, np.nan), dq, problem.scene)
    with pytest.raises(InputError, match=r"^dq: "):
        replanner.replan(q, dq[:3], problem.scene)
    with pytest.raises(InputError, match=r"^rate: "):
        replanner.replan(q, dq, problem.scene, rate=1.5)
    with pytest.raises(InputError, match=r"^horizon: "):
        replanner.replan(q, dq, problem.scene, horizon=-1.0)
    with pytest.raises(InputError, match=r"^goal: "):
        replanner.replan(q, dq, problem.scene, goal=[1.0, 2.0])
    from mmplan.scene.superellipsoid import Superellipsoid

    many = Scene((*problem.scene.obstacles, *(Sphere((9.0, float(i), 0.4), 0.1, 0.1)
                                              for i in range(6)), ball), None)  # fmt: skip
    held = replanner.replan(q, dq, many)  # more spheres than slots: the near ones in them
    assert held.status.value == "infeasible" and "goal blocked" in held.message
    odd = Superellipsoid((9.0, 0.0, 0.4), (0.1, 0.1, 0.1), (0.5, 0.7))  # in no library
    new_type = Scene((*problem.scene.obstacles, odd, ball))
    with pytest.raises(InputError, match=r"^scene: no slot for superellipsoid \(0\.5, 0\.7\)"):
        replanner.replan(q, dq, new_type)


def test_a_scaled_replan_without_a_path_keeps_the_robots_velocity() -> None:
    """A review's case: a time-scaled re-plan with one sample (the generator diverged at once:
    a ball around the end effector) returned the generator's velocity dq / w; and a rate 0 for
    a moving robot is an error (its velocity was dropped without a word)."""
    from mmplan.errors import InputError

    problem = mmplan.load_scenario("youbot3r-obstacles-torque").build()
    replanner = Replanner(problem)
    q, dq = np.asarray(problem.start, dtype=float), np.full(problem.robot.n, 0.05)
    around = Sphere(tuple(problem.robot.ee_position(q)), 0.1, 0.1)
    scene = Scene((*problem.scene.obstacles, around), problem.scene.ground)
    res = replanner.replan(q, dq, scene, rate=0.5)
    assert len(res.t) == 1, res.message
    np.testing.assert_array_equal(res.dq[0], dq)
    with pytest.raises(InputError, match=r"^rate: 0\.0 with a moving robot"):
        replanner.replan(q, dq, problem.scene, rate=0.0)
    still = replanner.replan(q, np.zeros_like(dq), problem.scene, horizon=1.0, rate=0.0)
    assert len(still.t) > 1 and np.all(still.dq[0] == 0.0)


@pytest.mark.skipif(codegen.compiler() is None, reason="no C compiler")
def test_fewer_obstacles_or_shape_types_use_a_wider_library_without_a_compile(
    counts: Counts, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A new user added a third cylinder to the paper scene (4 cylinder slots compiled), then
    planned the paper scene and one without its sphere: each compiled again (2 s apiece).
    Now a library with at least a scene's slots of each shape type serves it (its unused
    slots parked)."""
    from mmplan.planners.extended_jacobian import compiled as ej_compiled
    from mmplan.scene.cylinder import Cylinder
    from mmplan.verify.check import check

    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    ej_cache.clear()
    base = mmplan.load_scenario("youbot3r-obstacles-torque").build()
    obstacles, ground = base.scene.obstacles, base.scene.ground
    third = Cylinder((3.0, 0.5, 0.0), 0.2, 0.3, 0.35)  # away from the path
    wide = dataclasses.replace(base, scene=Scene((*obstacles, third), ground))
    assert ExtendedJacobian().plan(wide).status.value == "reached"
    assert counts.compiles >= 1
    assert len(list(tmp_path.glob("ej_family_*.json"))) == 1
    for scene in (base.scene, Scene((obstacles[0], obstacles[2]), ground)):
        ej_cache.clear()  # as a new process
        counts.compiles = counts.builds = 0
        problem = dataclasses.replace(base, scene=scene)
        sol = ExtendedJacobian().plan(problem)
        assert sol.status.value == "reached", sol.message
        assert check(sol.trajectory, problem, sol.status).ok
        assert (counts.compiles, counts.builds) == (0, 0)
    # the paper scene through the wider library: the same samples as through its own
    wide_plan = ExtendedJacobian().plan(base).trajectory
    monkeypatch.delenv("MMPLAN_CACHE", raising=False)
    ej_cache.clear()
    own = ExtendedJacobian().plan(base).trajectory
    np.testing.assert_array_equal(wide_plan.t, own.t)
    np.testing.assert_array_equal(wide_plan.q, own.q)
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    ej_cache.clear()
    # without the family's list the same scene compiles (the test can fail)
    for listed in tmp_path.glob("ej_family_*.json"):
        listed.unlink()
    ej_cache.clear()
    counts.compiles = 0
    ExtendedJacobian().plan(dataclasses.replace(base, scene=Scene(obstacles[:1], ground)))
    assert counts.compiles >= 1
    assert ej_compiled.wider("none", ()) == []


def test_the_consistency_rounds_do_not_step_a_moving_start() -> None:
    """A review's case: a ball 0.3-0.8 m from the end effector at t = 0.5 s. The consistency
    caps took x_start = w^2 out of the controllable set and the scaling then started at the
    largest admissible rate: w 0.355 -> 0.064, a step of 4.7 rad/s in a wheel's rate. The last
    round that keeps the start is returned instead."""
    problem = mmplan.load_scenario("youbot3r-obstacles-torque").build()
    plan = ExtendedJacobian().plan(problem).trajectory
    assert plan.u is not None
    replanner = Replanner(problem)
    k = int(np.searchsorted(plan.t, 0.5))
    q, dq, w = plan.q[k], plan.dq[k], float(plan.u[k])
    rng = np.random.default_rng(0)
    ee = problem.robot.ee_position(q)
    for _ in range(3):
        c = ee + np.r_[rng.uniform(0.3, 0.8) * np.sign(rng.normal()), rng.uniform(-0.5, 0.5), 0]
        c[2] = 0.35
        scene = Scene((*problem.scene.obstacles, Sphere(tuple(c), 0.2, 0.2)), problem.scene.ground)
        res = replanner.replan(q, dq, scene, horizon=2.0, rate=w)
        assert res.info["start_rate"] == pytest.approx(w, rel=1e-12), (c, res.message)
        np.testing.assert_allclose(res.dq[0], dq, rtol=1e-12, atol=1e-12)


@pytest.mark.skipif(codegen.compiler() is None, reason="no C compiler")
def test_a_switch_away_from_a_wider_library_keeps_its_slots(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A review's case: a scene served by a wider library (4 cylinder slots) switched to a
    partition the library cannot take; the switched generator was built with the scene's own
    slots and p, cut to that layout, lost the sphere. It is built with the library's slots."""
    from mmplan.planners.extended_jacobian.criterion import Partition
    from mmplan.scene.cylinder import Cylinder

    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    ej_cache.clear()
    base = mmplan.load_scenario("youbot3r-obstacles-torque").build()
    obstacles, ground = base.scene.obstacles, base.scene.ground
    third = Cylinder((3.0, 0.5, 0.0), 0.2, 0.3, 0.35)
    ExtendedJacobian().plan(dataclasses.replace(base, scene=Scene((*obstacles, third), ground)))
    ej_cache.clear()
    prep = ExtendedJacobian()._prepare(base)
    wide = prep.fns.layout.slots
    assert sum(k for _, k in wide) == 6  # the wider library: 4 cylinders, 2 spheres
    other = Partition((0, 3, 4, 5, 6, 7), (1, 2))  # not in the parametric family: built in
    assert not prep.fns.layout.supports(other)
    switched = prep.switch.build(other)
    # the same slots in the same order: retarget keeps every obstacle at its offset
    assert switched.layout.slots == wide
    assert switched.layout.slot_offsets() == prep.fns.layout.slot_offsets()


@pytest.mark.parametrize("elapsed", [3.0, 6.0])
def test_a_ball_ahead_of_a_fast_robot_brakes_along_its_plan(elapsed: float) -> None:
    """A ball appears ahead on the plan the youBot follows at speed: the generator's new path
    diverges at once (the ball inside its neighbourhood); the re-plan then brakes along the
    plan it follows: from the robot's state exactly, on that plan's samples, to rest, within
    the youBot's torque and rate limits (independent check), and says that it meets the ball
    (braking does not steer). A state off the plan with ``elapsed`` and a negative ``elapsed``
    are input errors; without ``elapsed`` it is the diverged one-sample plan as before."""
    from mmplan import interpolant
    from mmplan.errors import InputError

    problem = mmplan.load_scenario("youbot3r-obstacles-torque").build()
    replanner = Replanner(problem)
    start, rest = np.asarray(problem.start, dtype=float), np.zeros(problem.robot.n)
    plan = replanner.replan(start, rest, problem.scene, horizon=60.0)
    with pytest.raises(InputError, match=r"^elapsed: need a finite time >= 0 s, got -1"):
        replanner.replan(start, rest, problem.scene, elapsed=-1.0)
    plan = replanner.replan(start, rest, problem.scene, horizon=60.0)
    elapsed = float(plan.t[np.searchsorted(plan.t, elapsed)])  # a sample: A(q) dq = 0 there
    q, dq, _ = interpolant.evaluate(plan.t, plan.q, plan.dq, np.array([elapsed]))
    rate = float(np.interp(elapsed, plan.t, plan.u))
    ahead, _, _ = interpolant.evaluate(plan.t, plan.q, plan.dq, np.array([elapsed + 0.5]))
    ball = Sphere((float(ahead[0, 0]), float(ahead[0, 1]), 0.35), 0.2, 0.3)
    scene = Scene((*problem.scene.obstacles, ball), problem.scene.ground)
    braked = replanner.replan(q[0], dq[0], scene, horizon=2.0, rate=rate, elapsed=elapsed)
    assert braked.message.startswith("braking along the plan it follows"), braked.message
    np.testing.assert_array_equal(braked.q[0], q[0])
    np.testing.assert_array_equal(braked.dq[0], dq[0])
    assert np.all(braked.dq[-1] == 0.0) and braked.u[-1] == 0.0 and braked.t[-1] < 2.0
    later = plan.q[plan.t > elapsed]
    np.testing.assert_array_equal(braked.q[1:-1], later[: len(braked.q) - 2])  # its path
    moved = dataclasses.replace(problem, start=tuple(q[0]))
    failures = [f for f in _checked(moved, braked) if "start" not in f]
    assert failures == [], failures  # the limits and the wheels' constraints (no ball there)
    # braking does not steer: here the ball already overlaps the arm; the plan says so
    points = np.vstack([problem.robot.collision_points(x) for x in braked.q])
    gap = scene.clearance(points, np.tile(problem.robot.collision_radii, len(braked.q)))
    assert braked.info["min_clearance_m"] == gap < 0.0
    assert braked.status.value == "infeasible" and "it meets obstacles[3]" in braked.message
    replanner.replan(start, rest, problem.scene, horizon=60.0)  # the plan followed again
    with pytest.raises(InputError, match=r"^elapsed: the state is not the last re-plan's"):
        replanner.replan(q[0] + 0.01, dq[0], scene, horizon=2.0, rate=rate, elapsed=elapsed)
    replanner.replan(start, rest, problem.scene, horizon=60.0)
    blind = replanner.replan(q[0], dq[0], scene, horizon=2.0, rate=rate)
    assert len(blind.t) == 1 and blind.status.value == "diverged"
