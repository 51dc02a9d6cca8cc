"""More obstacles than a compiled library's slots: the near ones in the slots, the same plan.

Compiles are counted at the C compiler call and symbolic builds at ``build_functions``
(the ``counts`` fixture of test_replan.py, repeated here).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mmplan
from mmplan.compile import codegen
from mmplan.planners.extended_jacobian import cache as ej_cache
from mmplan.planners.extended_jacobian.active import ActiveSlots, CrowdedError
from mmplan.planners.extended_jacobian.parameters import ParameterLayout
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.planners.extended_jacobian.replan import Replanner
from mmplan.problem import Problem
from mmplan.scene.box import Box
from mmplan.scene.cylinder import Cylinder
from mmplan.scene.scene import Scene
from mmplan.scene.sphere import Sphere
from mmplan.verify.check import check
from tests.planners.extended_jacobian.conftest import Counts

NAME = "youbot3r-obstacles-torque"
#: Cylinders the paper scene's robot passes near (three slot choices with 2 cylinder slots).
NEAR = ((2.6, 3.6), (-0.8, 0.2), (3.5, 1.0))
#: Cylinders crowding the path: three within their neighbourhoods at once.
CROWD = ((0.9, 1.5), (2.2, 3.3), (2.9, 2.4), (-0.6, 0.3), (0.6, 3.0))

def _with(extra: tuple[tuple[float, float], ...]) -> Problem:
    base = mmplan.load_scenario(NAME).build()
    added = [Cylinder((x, y, 0.0), 0.15, 0.4, 0.35) for x, y in extra]
    scene = Scene((*base.scene.obstacles, *added), base.scene.ground)
    return dataclasses.replace(base, scene=scene)


def _exact(problem: Problem) -> mmplan.PlanResult:
    """The plan with a library holding every obstacle (compiled if none is on disk)."""
    original = ExtendedJacobian.__dict__["_prepare"]

    def prepare(cls: type, problem: Problem, guess: bool = False, *_: Any, **__: Any) -> Any:
        return original.__func__(cls, problem, guess, whole=True)

    ExtendedJacobian._prepare = classmethod(prepare)  # type: ignore[method-assign,assignment]
    try:
        ej_cache.clear()
        return ExtendedJacobian().plan(problem)
    finally:
        ExtendedJacobian._prepare = original  # type: ignore[method-assign]
        ej_cache.clear()


def test_the_gap_bounds_the_clearance_from_below() -> None:
    """Where gap_o (box distance - radius - delta) > 0, it is at most C - radius - delta for
    the smooth models the generator uses (cylinder, sphere, a yawed box), at random points: an
    obstacle whose gap is positive adds exact zeros; and the bound is not vacuous far away."""
    robot = mmplan.load_scenario(NAME).build().robot
    shapes = [Cylinder((1.0, 2.0, 0.0), 0.3, 0.5), Sphere((-1.0, 0.5, 0.6), 0.25),
              Box((0.5, -1.0, 0.4), (0.8, 0.3, 0.5), yaw=0.7)]  # fmt: skip
    models = [s.superellipsoid() for s in shapes]
    layout = ParameterLayout(tuple((m.exponents, 1) for m in models))
    active = ActiveSlots(robot, layout, [(m, 0.2) for m in models])
    rng = np.random.default_rng(7)
    centres = rng.uniform([-3.0, -3.0, -0.5], [3.0, 4.0, 1.5], size=(400, 1, 3))
    pts = centres + rng.uniform(-0.3, 0.3, size=(1, len(robot.collision), 3))  # robot-like
    g = active.gaps(pts, np.zeros((len(pts), robot.n)), range(len(models)))
    for o, model in enumerate(models):
        C = model.radial_distance(pts.reshape(-1, 3)).reshape(pts.shape[:2])
        true = (C - robot.collision_radii[None, :]).min(axis=1) - 0.2
        pos = g[:, o] > 0.0  # where the choice may leave the obstacle out
        assert pos.sum() > 50 and np.all(g[pos, o] <= true[pos] + 1e-9)
        far = true > 1.0
        assert far.any() and np.all(g[far, o] > 0.5 * true[far])


def test_choice_and_crowding() -> None:
    """The slots take the nearest obstacles in the scene's order; a flagged one is taken; more
    within the margin than slots is CrowdedError."""
    problem = mmplan.load_scenario(NAME).build()
    robot, q = problem.robot, np.asarray(problem.start, dtype=float)
    model = Sphere((0.0, 0.0, 0.0), 0.1).superellipsoid()
    layout = ParameterLayout(((model.exponents, 2),))
    here = robot.collision_points(q).mean(axis=0)
    balls = [Sphere(tuple(here + [d, 0.0, 0.0]), 0.1) for d in (5.0, 1.0, 8.0, 1.5)]
    active = ActiveSlots(robot, layout, [(b.superellipsoid(), 0.1) for b in balls])
    p = active.start(layout.pack([0, 0, 0], [1, 1, 1]), q)
    assert active.chosen == {1, 3}
    starts = layout.starts()[model.exponents]
    np.testing.assert_array_equal(p[starts[0] : starts[0] + 3], balls[1].center)  # scene order
    np.testing.assert_array_equal(p[starts[1] : starts[1] + 3], balls[3].center)
    active.flagged = {2}
    p = active.choose(p, q[None, :])
    assert active.chosen == {1, 2} and not active.flagged
    spheres = robot.collision_points(q)
    near = [Sphere(tuple(spheres[i] + [0.0, 0.0, 0.3]), 0.1) for i in (0, 5, 10)]
    crowded = ActiveSlots(robot, layout, [(b.superellipsoid(), 0.3) for b in near])
    with pytest.raises(CrowdedError, match=r"3 sphere obstacles near at once, 2 slots"):
        crowded.start(p, q)
    with pytest.raises(ValueError, match="no slot"):
        ActiveSlots(robot, layout, [(Box((0, 0, 0), (1, 1, 1)).superellipsoid(), 0.1)])


@pytest.mark.skipif(codegen.compiler() is None, reason="no C compiler")
def test_more_obstacles_than_slots_plan_without_a_compile_to_the_bit(
    counts: Counts, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The paper scene compiles a library with 2 cylinder slots; the scene with 3 more
    cylinders near the path then plans with it (no compile, no symbolic build; the slots
    chosen 3 times), passes the check, and its samples (t, q, dq, tau) are those of a library
    holding all 5 cylinders to the bit (a chunk that came near an obstacle left out ran again
    with the slots chosen for it: the same chunks as with every obstacle in a slot). Without
    the check of the obstacles left out the samples differ (the test can fail)."""
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    ej_cache.clear()
    assert ExtendedJacobian().plan(_with(())).status.value == "reached"
    problem = _with(NEAR)
    ej_cache.clear()  # as a new process
    counts.compiles = counts.builds = 0
    sol = ExtendedJacobian().plan(problem)
    assert (counts.compiles, counts.builds) == (0, 0)
    assert sol.status.value == "reached", sol.message
    assert sol.info["slot_choices"] >= 2
    assert check(sol.trajectory, problem, sol.status).ok
    with monkeypatch.context() as patch:  # the obstacles left out never checked
        patch.setattr(ActiveSlots, "first_unsafe", lambda self, Q: len(Q))
        ej_cache.clear()
        blind = ExtendedJacobian().plan(problem)
    assert blind.info["slot_choices"] == 1
    exact = _exact(problem)
    assert counts.compiles >= 1 and "slot_choices" not in exact.info
    np.testing.assert_array_equal(sol.trajectory.t, exact.trajectory.t)
    np.testing.assert_array_equal(sol.trajectory.q, exact.trajectory.q)
    np.testing.assert_array_equal(sol.trajectory.dq, exact.trajectory.dq)
    np.testing.assert_array_equal(sol.trajectory.tau, exact.trajectory.tau)
    b, e = blind.trajectory.q, exact.trajectory.q
    assert b.shape != e.shape or not np.array_equal(b, e)


@pytest.mark.skipif(codegen.compiler() is None, reason="no C compiler")
def test_a_crowded_scene_uses_its_own_slots(
    counts: Counts,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Three cylinders within their neighbourhoods at once with 2 slots: the planner says so
    and plans with a library of twice the slots (compiled; 4 of the 7 cylinders, the near ones
    in them), the same plan as with a library holding every obstacle."""
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    ej_cache.clear()
    ExtendedJacobian().plan(_with(()))
    problem = _with(CROWD)
    ej_cache.clear()
    counts.compiles = 0
    sol = ExtendedJacobian().plan(problem)
    assert "near at once, 2 slots: a generator with 4 of them" in capsys.readouterr().err
    assert counts.compiles >= 1 and sol.info["slot_choices"] >= 1  # 4 of 7 cylinders held
    assert check(sol.trajectory, problem, sol.status).ok
    exact = _exact(problem)
    assert sol.status == exact.status
    np.testing.assert_array_equal(sol.trajectory.q, exact.trajectory.q)


@pytest.mark.skipif(codegen.compiler() is None, reason="no C compiler")
def test_a_replanner_gets_the_slots_it_asks_for(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A review's case: with a narrower library on disk, Replanner(problem, spare) got it (its
    spare slots gone, and the advice "make the Replanner with more spare slots" could not
    help). Its slots are a choice: it gets at least them (a wider library may serve)."""
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    ej_cache.clear()
    ExtendedJacobian().plan(_with(()))  # a library with 2 cylinder and 2 sphere slots
    ej_cache.clear()
    replanner = Replanner(mmplan.load_scenario(NAME).build(), spare=4)
    assert all(k >= 6 for _, k in replanner.fns.layout.slots), replanner.fns.layout.slots


def test_a_replan_among_more_spheres_than_slots_is_the_replan_without_the_far_ones() -> None:
    """The Replanner's slots hold the near spheres: six far spheres more than its slots change
    nothing (the same samples to the bit as the re-plan without them)."""
    problem = mmplan.load_scenario("youbot3r-obstacles-unlimited").build()
    replanner = Replanner(problem)
    q, dq = np.asarray(problem.start, dtype=float), np.zeros(problem.robot.n)
    far = tuple(Sphere((9.0, float(i), 0.4), 0.1, 0.1) for i in range(8))
    many = Scene((*problem.scene.obstacles, *far), problem.scene.ground)
    a = replanner.replan(q, dq, problem.scene)
    b = replanner.replan(q, dq, many)
    assert a.status == b.status and len(a.t) > 100
    assert b.info["slot_choices"] >= 1 and "slot_choices" not in a.info
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.q, b.q)


@pytest.mark.skipif(codegen.compiler() is None, reason="no C compiler")
def test_a_compile_for_a_new_shape_type_says_why(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A new user's scene with boxes compiled with only "compiling ej to C": now the notice
    names the shape no compiled generator of the robot has a slot for."""
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    ej_cache.clear()
    ExtendedJacobian().plan(_with(()))
    assert "has a slot for" not in capsys.readouterr().err  # the first: nothing to say
    base = _with(())
    box = Box((3.0, 0.5, 0.2), (0.3, 0.3, 0.4))
    scene = Scene((*base.scene.obstacles, box), base.scene.ground)
    ej_cache.clear()
    ExtendedJacobian().plan(dataclasses.replace(base, scene=scene))
    err = capsys.readouterr().err
    assert "no compiled generator of this robot has a slot for box obstacles" in err, err


@pytest.mark.skipif(codegen.compiler() is None, reason="no C compiler")
def test_a_scene_of_many_obstacles_compiles_at_most_the_cap(
    counts: Counts, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A new user's 200-obstacle scene compiled 62 cylinder slots (9.2 s): a first compile now
    holds at most SLOT_CAP of a type, the near ones in them; the same samples as a library of
    every obstacle."""
    from mmplan.planners.near_slots import SLOT_CAP

    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    ej_cache.clear()
    spread = tuple((x, y) for x in (-3.0, 6.0) for y in np.linspace(-3.0, 7.0, 5))
    problem = _with(NEAR + spread)  # 15 cylinders
    sol = ExtendedJacobian().plan(problem)
    assert counts.compiles >= 1 and sol.status.value == "reached", sol.message
    cyl = problem.scene.obstacles[0].superellipsoid().exponents
    built = ExtendedJacobian._prepare(problem).fns.layout.slots
    assert dict(built)[cyl] == SLOT_CAP, built
    whole = _exact(problem)
    np.testing.assert_array_equal(sol.trajectory.q, whole.trajectory.q)
