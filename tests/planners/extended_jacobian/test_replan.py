"""Compile once per robot model and shape types; re-plan from a moving state with no compile.

Compiles are counted at the C compiler call (``codegen.subprocess.run``) and symbolic
builds at ``generator.build_functions``.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mmplan
from mmplan.compile import codegen
from mmplan.planners.extended_jacobian import cache as ej_cache
from mmplan.planners.extended_jacobian import generator as ej_generator
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.scene.scene import Scene
from mmplan.scene.sphere import Sphere
from mmplan.task import ReachPoint

EXAMPLE = Path(__file__).parents[3] / "examples" / "replan_moving_obstacle.py"


@dataclasses.dataclass
class Counts:
    compiles: int = 0
    builds: int = 0


@pytest.fixture
def counts(monkeypatch: pytest.MonkeyPatch) -> Iterator[Counts]:
    """Counters of C compiler runs and symbolic generator builds."""
    found = Counts()
    run, build = codegen.subprocess.run, ej_generator.build_functions

    def counted_run(*args: Any, **kwargs: Any) -> Any:
        found.compiles += 1
        return run(*args, **kwargs)

    def counted_build(*args: Any, **kwargs: Any) -> Any:
        found.builds += 1
        return build(*args, **kwargs)

    monkeypatch.setattr(codegen.subprocess, "run", counted_run)
    monkeypatch.setattr(ej_cache, "build_functions", counted_build)
    yield found


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
