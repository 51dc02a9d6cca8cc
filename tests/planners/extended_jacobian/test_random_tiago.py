"""Extended-Jacobian planner on a seeded set of random TIAGo scenes (issue 12: a real robot).

The unmodified PAL TIAGo URDF (robot ``tiago``: differential drive, torso lift, 7-dof arm;
n = 13, h = 3, 134 collision spheres) with its own torque and velocity limits; goals all
around the robot, high and low, 1-4 obstacles, every third scene a table with the goal over
it (:mod:`tests.planners.extended_jacobian.tiago_scenes`). Every plan that reports
``reached`` must pass the independent checker; every other plan ends with an honest status
and a finite trajectory whose efforts stay physical. Skipped without example-robot-data.

By default the per-scene checks and the reached fraction run on ``SELECTED`` (10 of the 30
scenes, planning about a quarter of the set's cost); ``MMPLAN_SLOW_TESTS=1`` also runs them
on the whole set (the ``[whole]`` cases, otherwise skipped with the reason shown). The set's
description (directions, heights, tables, obstacles) is always checked on all 30 scenes.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.scenario.loader import Scenario
from mmplan.scene.scene import Scene
from mmplan.trajectory import PlanResult, Status
from mmplan.verify.check import CheckReport, check
from tests.planners.extended_jacobian.tiago_scenes import COUNT, START, scenarios
from tests.robot.urdf_oracle import robot_data_dir

#: Floor on the reached-and-checked fraction (measured 2026-11-24 on this set, SEED; the
#: causes found and fixed on the way: docs/extended_jacobian.md, Real robots):
#:   the planner as it was (mu at the tool point, no posture term, torso in R, sphere radii
#:   ignored, no divergence guard): 0/10 goals reached even without obstacles (NaN after
#:   0.13-2.3 s);
#:   + wrist centre, posture term, divergence guard, sphere radii: 11/30 (11 diverged);
#:   + revolute joints preferred in R (the torso's barrier gradient through
#:   Jc_R^-T H_R): 12/30 (4 diverged, 7 stalled, 6 timeouts);
#:   + table goals with room for the hand (its spheres reach 0.34 m past the flange): 16/30;
#:   + stall test relative to the error, joint-limit fade within 0.3 of a short range: 18/30
#:   (20 reached; t_max 30 s: 18/30, 19 reached);
#:   + re-timing consistent with q, the floor, obstacles as parameters: 19/30 reached, all
#:   19 pass the checker (10 timeouts, 1 diverged; 2026-11-24).
#: Not reached: stalls and timeouts among 2-4 obstacles, or beside a pillar that keeps the
#: base from a high goal (local minima the tangential escape does not leave).
REACHED_FLOOR = 0.6
#: The scenes planned by default, with their status when measured (2026-11-24): every kind of
#: outcome (the one diverged plan, two timeouts: nine timeouts and one reached plan failed
#: the dq-consistency check before the re-timing fix), tables, low and high goals, 1-4
#: obstacles, and the reached plans the re-timing stretched most (23: 25.1 s of path ->
#: 30.0 s, 25: 12.7 -> 16.3 s, 24: 10.9 -> 13.0 s).
#:   1 reached (low, 4 obstacles), 2 reached (high), 3 reached (table), 7 diverged (low),
#:   8 timeout (high, 1 obstacle), 16 timeout (low, 4 obstacles), 18 reached (table),
#:   23 reached (high), 24 reached (table), 25 reached (low, 3 obstacles).
#: 7/10 reached and checked: REACHED_FLOOR holds here with the whole set's margin (one scene).
SELECTED = (1, 2, 3, 7, 8, 16, 18, 23, 24, 25)
SLOW = bool(os.environ.get("MMPLAN_SLOW_TESTS"))
HONEST = {Status.STALLED, Status.DIVERGED, Status.INFEASIBLE, Status.TIMEOUT}


@dataclass(frozen=True)
class Outcome:
    """One scene's plan: problem, result, compute time [s] and the checker's report."""

    data: dict[str, Any]
    problem: Any
    result: PlanResult
    seconds: float
    report: CheckReport


@pytest.fixture(scope="module")
def planned() -> dict[int, Outcome]:
    """Scene index -> its outcome, filled as scenes are asked for (each planned once)."""
    return {}


@pytest.fixture(
    scope="module",
    params=[
        "selected",
        pytest.param("whole", marks=pytest.mark.skipif(
            not SLOW, reason="the whole random TIAGo set (30 plans, about 2-4 min): "
                             "MMPLAN_SLOW_TESTS=1 runs it; the [selected] 10 run by default")),
    ],
)
def outcomes(request: pytest.FixtureRequest, planned: dict[int, Outcome]) -> list[Outcome]:
    """The selected scenes (or all of them) planned and checked once (an InputError fails the
    test: every scene is a valid problem)."""
    robot_data_dir()  # skips without example-robot-data
    indices = SELECTED if request.param == "selected" else range(COUNT)
    sets = scenarios()
    for index in indices:
        if index in planned:
            continue
        data = sets[index]
        problem = Scenario.from_dict(data, str(data["name"])).build()
        clock = time.perf_counter()
        result = ExtendedJacobian().plan(problem)
        seconds = time.perf_counter() - clock
        report = check(result.trajectory, problem, result.status.value)
        planned[index] = Outcome(data, problem, result, seconds, report)
    return [planned[index] for index in indices]


def test_set_covers_directions_heights_tables_and_obstacles() -> None:
    """The set is as described: every direction, low and high goals, tables, 1-4 obstacles."""
    robot_data_dir()
    sets = scenarios()
    assert len(sets) >= 30 and len(sets) == COUNT
    goals = np.array([s["goal"]["position"] for s in sets])
    heading = np.degrees(np.arctan2(goals[:, 1], goals[:, 0]))
    for lo in range(-180, 180, 45):
        assert np.any((heading >= lo) & (heading < lo + 45)), lo
    assert (goals[:, 2] < 0.65).sum() >= 8 and (goals[:, 2] > 0.8).sum() >= 8
    counts = [len(s["obstacles"]) for s in sets]
    assert min(counts) >= 1 and max(counts) <= 4
    tables = [s for s in sets if s["obstacles"][0].get("size", [0, 0, 0])[2] >= 0.6]
    assert len(tables) >= COUNT // 3
    shapes = {o["shape"] for s in sets for o in s["obstacles"]}
    assert shapes == {"sphere", "cylinder", "box"}
    for s in sets:
        assert "limits" not in s  # the robot's own torque and rate limits
        scene = Scene.from_dicts(s["obstacles"])
        assert float(scene.distances(np.asarray([s["goal"]["position"]])).min()) > 0.25
        assert s["start"] == START


def test_selection_spans_the_set() -> None:
    """The default selection holds tables, low and high goals and 1-4 obstacles."""
    robot_data_dir()
    chosen = [scenarios()[i] for i in SELECTED]
    assert len(set(SELECTED)) == len(SELECTED) >= 8 and max(SELECTED) < COUNT
    goals = np.array([s["goal"]["position"] for s in chosen])
    assert (goals[:, 2] < 0.65).sum() >= 3 and (goals[:, 2] > 0.8).sum() >= 3
    tables = [s for s in chosen if s["obstacles"][0].get("size", [0, 0, 0])[2] >= 0.6]
    assert len(tables) >= 3
    assert {len(s["obstacles"]) for s in chosen} == {1, 2, 3, 4}


def test_reached_plans_pass_the_checker(outcomes: list[Outcome]) -> None:
    """Every reached plan passes every check of mmplan.check; so does every plan that stopped
    early without diverging (timeout, stalled: a consistent motion that ends short of the
    goal). Before the re-timing capped the steps whose dq missed q (2026-11-24), one reached
    plan and nine timeouts failed the dq-consistency check (0.11-0.16 /s per step)."""
    bad: dict[str, list[str]] = {}
    for o in outcomes:
        if o.result.reached or o.result.status in (Status.TIMEOUT, Status.STALLED):
            failures = o.report.failures()
            if failures:
                bad[f"{o.data['name']} ({o.result.status.value})"] = failures
    assert bad == {}


def test_other_plans_end_honestly(outcomes: list[Outcome]) -> None:
    """Not reached: an honest status and message, finite samples, physical efforts."""
    for o in outcomes:
        name, result, tr = o.data["name"], o.result, o.result.trajectory
        assert tr.is_finite(), name
        assert tr.tau is not None and float(np.abs(tr.tau).max()) < 1e4, name
        if result.reached:
            continue
        assert result.status in HONEST and result.message, name
        if result.status is Status.DIVERGED:
            assert "diverged at t = " in result.message, result.message
        assert not o.report.task_completed, (name, result.status, o.report.final_error_m)


def test_reached_fraction(outcomes: list[Outcome]) -> None:
    """Print the tally and compute times; hold the reached-and-checked fraction."""
    tally: dict[str, int] = {}
    ok, motion, compute = 0, 0.0, 0.0
    for o in outcomes:
        result, tr = o.result, o.result.trajectory
        good = result.reached and not o.report.failures()
        key = result.status.value + ("" if good or not result.reached else " (check)")
        tally[key] = tally.get(key, 0) + 1
        ok += good
        if good:
            motion, compute = motion + float(tr.t[-1]), compute + o.seconds
        error = float(np.linalg.norm(tr.ee[-1] - np.asarray(o.data["goal"]["position"])))
        print(f"{o.data['name']:16s} goal {np.round(o.data['goal']['position'], 2)} obstacles "
              f"{len(o.data['obstacles'])} {key:16s} t_end {tr.t[-1]:5.1f} s error "
              f"{error:.4f} m compute {o.seconds:4.1f} s")
    fraction = ok / len(outcomes)
    print(f"\nrandom TIAGo set ({len(outcomes)} scenes): reached and checked {ok}/"
          f"{len(outcomes)} = {fraction:.0%}; {tally}; motion/compute of the reached plans "
          f"{motion / max(compute, 1e-9):.1f}")
    assert fraction >= REACHED_FLOOR, tally
