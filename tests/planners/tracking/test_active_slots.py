"""More obstacles than a tracker's compiled slots: the near ones in the slots, the same plan.

A library compiled for a scene's slots serves a scene with more obstacles of its kinds (no
compile), the obstacles near the robot in its slots (planners/tracking/active.py); the
samples are those of a library holding every obstacle, to the bit.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mmplan
from mmplan.compile import codegen
from mmplan.planners.near_slots import NearSlots
from mmplan.planners.tracking import compiled as track_compiled
from mmplan.planners.tracking.active import TrackerSlots
from mmplan.planners.tracking.slots import Slots
from mmplan.problem import Problem
from mmplan.scene.cylinder import Cylinder
from mmplan.scene.scene import Scene
from mmplan.verify.check import check

pytestmark = pytest.mark.skipif(codegen.compiler() is None, reason="no C compiler")


def _with(name: str, extra: tuple[tuple[float, float, float], ...]) -> Problem:
    base = mmplan.load_scenario(name).build()
    added = [Cylinder((x, y, 0.0), r, 0.5) for x, y, r in extra]
    scene = Scene((*base.scene.obstacles, *added), base.scene.ground)
    return dataclasses.replace(base, scene=scene)


def _plan(problem: Problem, exact: bool = False) -> mmplan.PlanResult:
    planner = mmplan.get_planner(problem.settings.method)()
    if not exact:
        return planner.plan(problem)
    original = track_compiled.functions

    def whole(*args: Any, **kwargs: Any) -> Any:  # a library holding every obstacle
        return original(*args[:6], exact=True)

    track_compiled.functions = whole
    try:
        return planner.plan(problem)
    finally:
        track_compiled.functions = original


def _compiles(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    found = [0]
    run = codegen.subprocess.run

    def counted(*args: Any, **kwargs: Any) -> Any:
        found[0] += 1
        return run(*args, **kwargs)

    monkeypatch.setattr(codegen.subprocess, "run", counted)
    return found


@pytest.mark.parametrize(
    ("name", "extra", "choices"),
    [
        # the pseudoinverse tracker passes two more posts: the slots are chosen again
        ("diffdrive3-track", ((1.0, 0.6, 0.15), (3.0, -0.55, 0.15), (1.5, 3.0, 0.2)), 2),
        # the impedance tracker's force reaches 1 m: posts beyond it, one far
        (
            "omni3-impedance",
            ((1.3, 1.0, 0.02), (-1.0, 0.4, 0.02), (0.2, -1.0, 0.02), (3.0, 3.0, 0.1)),
            1,
        ),
    ],
)
def test_more_obstacles_than_slots_track_without_a_compile_to_the_bit(
    name: str,
    extra: tuple[tuple[float, float, float], ...],
    choices: int,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    compiles = _compiles(monkeypatch)
    assert _plan(_with(name, ())).status.value == "reached"  # compiles its 2 cylinder slots
    assert compiles[0] >= 1
    problem = _with(name, extra)
    compiles[0] = 0
    sol = _plan(problem)
    assert compiles[0] == 0
    assert sol.status.value == "reached", sol.message
    assert sol.info["slot_choices"] >= choices
    assert check(sol.trajectory, problem, sol.status).ok
    exact = _plan(problem, exact=True)
    assert compiles[0] >= 1 and "slot_choices" not in exact.info
    for field in ("t", "q", "dq"):
        np.testing.assert_array_equal(getattr(sol.trajectory, field),
                                      getattr(exact.trajectory, field))  # fmt: skip
    for key, value in exact.info.items():  # the platform distances of the impedance too
        if key.endswith("_m") or key.endswith("_s"):  # NumPy's distances: to rounding
            assert sol.info[key] == pytest.approx(value, rel=1e-12, abs=1e-15), key


def test_without_the_check_of_the_obstacles_left_out_the_track_differs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same scene as above with the rollout's check switched off: the post the slots
    did not take at the start is ignored and the samples differ (the test above can fail)."""
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    name, extra = "diffdrive3-track", ((1.0, 0.6, 0.15), (3.0, -0.55, 0.15), (1.5, 3.0, 0.2))
    _plan(_with(name, ()))
    problem = _with(name, extra)
    checked = _plan(problem).trajectory
    monkeypatch.setattr(NearSlots, "first_unsafe", lambda self, Q: len(Q))
    blind = _plan(problem).trajectory
    assert blind.q.shape != checked.q.shape or not np.array_equal(blind.q, checked.q)


def test_a_crowded_impedance_scene_uses_its_own_slots(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Three posts within the force's reach at once with 2 slots: said, and tracked with a
    library of the scene's slots (the same samples as with it)."""
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    name = "omni3-impedance"
    _plan(_with(name, ()))
    problem = _with(name, ((0.3, 0.9, 0.02), (0.9, 0.3, 0.02), (-0.5, -0.4, 0.02)))
    capsys.readouterr()
    sol = _plan(problem)
    assert "near at once, 2 slots: a step with 4 of them" in capsys.readouterr().err
    exact = _plan(problem, exact=True)
    np.testing.assert_array_equal(sol.trajectory.q, exact.trajectory.q)


def test_the_gap_is_zero_where_a_term_starts() -> None:
    """The pseudoinverse's gap is the spheres' distance minus radius minus influence (its
    barrier's support); the impedance's also the platform's horizontal distance minus the
    reach max(d_max, d_min), measured independently here."""
    problem = mmplan.load_scenario("omni3-impedance").build()
    robot, q = problem.robot, np.asarray(problem.start, dtype=float)
    post = Cylinder((1.0, 0.1, 0.0), 0.1, 0.5, influence=0.3)
    slots = Slots((("cylinder", 1),))
    spheres = TrackerSlots(robot, slots, [post], 0.2)
    C = robot.collision_points(q)[None]
    want = float(np.min(post.distance(C[0]) - robot.collision_radii)) - 0.3
    assert spheres.gaps(C, q[None], [0])[0, 0] == pytest.approx(want, abs=1e-12)
    platform = TrackerSlots(robot, slots, [post], 1.0, platform=0.15)
    centre = np.array([[q[0], q[1], 0.25]])
    horizontal = float(post.distance(centre)[0]) - 0.3
    clearance = float(np.min(post.distance(C[0]) - robot.collision_radii))
    got = platform.gaps(C, q[None], [0])[0, 0]
    assert got == pytest.approx(min(horizontal, clearance), abs=1e-12)


def test_fewer_obstacles_use_a_wider_library_to_the_bit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """After a scene with 4 posts compiled 4 cylinder slots, the scenario's own scene (one
    post) runs that library, its unused slots parked and switched off: no compile, the same
    samples as with a library of its own (compiled after, for the comparison)."""
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    compiles = _compiles(monkeypatch)
    name = "diffdrive3-track"
    _plan(_with(name, ((1.0, 0.6, 0.15), (3.0, -0.55, 0.15), (1.5, 3.0, 0.2))))
    compiles[0] = 0
    wide = _plan(_with(name, ()))
    assert compiles[0] == 0 and wide.status.value == "reached"
    for listed in tmp_path.glob("track_family_*.json"):
        listed.unlink()  # its own library now compiles
    own = _plan(_with(name, ()))
    assert compiles[0] >= 1
    np.testing.assert_array_equal(wide.trajectory.q, own.trajectory.q)
    np.testing.assert_array_equal(wide.trajectory.dq, own.trajectory.dq)


def test_a_scene_of_many_posts_compiles_at_most_the_cap(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """More posts of a kind than SLOT_CAP in an empty cache: the step compiles SLOT_CAP of them
    (a capped library's model was first built packing every post: "do not fit", a crash),
    and the track equals the one of a library holding every post."""
    from mmplan.planners import near_slots
    from mmplan.planners.near_slots import SLOT_CAP

    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    posts = tuple((x, y, 0.1) for x in (-2.0, 6.0) for y in (-3.0, -1.5, 2.0, 3.5, 5.0))
    problem = _with("diffdrive3-track", posts)  # 11 cylinders
    seen: list[Slots] = []
    original = track_compiled.functions

    def spy(*args: Any, **kwargs: Any) -> Any:
        found = original(*args, **kwargs)
        seen.append(found.slots)
        return found

    monkeypatch.setattr(track_compiled, "functions", spy)
    sol = _plan(problem)
    assert sol.status.value == "reached", sol.message
    assert dict(seen[0].kinds)["cylinder"] == SLOT_CAP
    monkeypatch.setattr(track_compiled, "functions", spy)
    monkeypatch.setattr(near_slots, "SLOT_CAP", 100)  # every post in a slot
    seen.clear()
    whole = _plan(problem, exact=True)
    assert dict(seen[0].kinds)["cylinder"] > SLOT_CAP and "slot_choices" not in whole.info
    np.testing.assert_array_equal(sol.trajectory.q, whole.trajectory.q)
