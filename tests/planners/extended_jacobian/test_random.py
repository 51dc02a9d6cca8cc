"""Extended-Jacobian planner on a seeded set of random youbot-3r scenarios (issue 7, general use).

Goals in every direction around the robot (the heading is stratified over the full circle:
ahead, beside, behind), 1-3 m from the start, low and high; 1-5 random spheres, cylinders
and boxes, mostly near the straight line to the goal, never covering the start or the goal;
every second scenario with the robot's torque limits. Every plan that reports ``reached``
must pass the independent checker; every other plan must end with an honest status and a
finite trajectory; input errors must be :class:`~mmplan.errors.InputError`.

By default the per-scene checks and the reached fraction run on ``SELECTED`` (10 of the 30
scenarios: those named below as having shown a defect); ``MMPLAN_SLOW_TESTS=1`` also runs
them on the whole set (the ``[whole]`` cases, otherwise skipped with the reason shown). The
set's description is always checked on all 30 scenarios.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from mmplan.cli.main import main
from mmplan.errors import InputError
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.robot.library import get_robot
from mmplan.scenario.loader import Scenario
from mmplan.scene.scene import Scene
from mmplan.trajectory import Status
from mmplan.verify.check import check

COUNT = 30
SEED = 20261122
START = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -0.17, 0.35]
#: Planner settings for the set: RK4 step and horizon chosen so the file runs in minutes.
PLANNER: dict[str, Any] = {"method": "extended-jacobian", "t_max": 30.0, "dt": 0.005}
#: Obstacles keep this clearance [m] from the start's collision points and from the goal.
START_GAP, GOAL_GAP = 0.15, 0.45
#: Floor on the reached fraction (measured 2026-11-22; every goal here is feasible: >= 0.45 m
#: from every obstacle, inside the arm's reach). Reached on this set (SEED) / on a second set
#: (seed 777, same generator, not in the test):
#:   before: 18 / 21 (10 timeouts, 2 diverged);
#:   near-goal push projection (near_goal.project_push): 21 / 26 (random-21, -22, -24 had
#:   stalled 0.009-0.18 m from the goal, body 0.29 m from an obstacle);
#:   + arm push fading at joint limits (fade_at_limits): q2 no longer reaches its limit
#:   (random-11, -18 and 777-23 had 0.005 rad left, cond(E) > 1e8: diverged);
#:   + default delta 0.3 -> 0.15 m: 25 / 25 (delta 0.3: 22 / 26, 0.2: 23 / 25; 0.1 made
#:   random-29 fail the Pfaffian check, |A dq| = 2.7e-6 at t = 0.67 s).
#:   + stall window 3 -> 1.5 s (same 1 mm progress): 28 / 26. The escapes were not spent,
#:   the horizon was: each stall cost a full window before the escape and another after it
#:   (random-0, -7, -25 had used 2-4 of 5 escapes at t_max; now reached at 19.9, 25.7 and
#:   29.4 s; 777-20 too). Other windows: 1.5 s with 0.5 mm: 27 / 26; 1 s, 0.3 mm, 10
#:   escapes: 26 / 27 (loses random-9); 2 s, 0.7 mm, 10 escapes: 25 / 26. On top of 1.5 s:
#:   escape_time 3 s (0.5 mm): 28 / 25; escape_gain 6: 27 / 26; max_escapes 8: 28 / 26.
#:   Paper scenarios: no escape there, identical samples.
#: Not reached now, both timeouts after 5 escapes: random-13 (0.23 m, still closing in at
#: t_max) and random-19 (1.02 m: the platform does not fit between the box and the cylinder
#: in front of the goal and has to go round one of them); on 777: 0, 1, 16, 26.
REACHED_FLOOR = 0.9
#: Reached plans that fail one check (planner bugs, reported); none at present. random-6
#: (torque limits) failed dq consistency (0.246/s vs 0.152) until the TOPP checked the zone
#: at both ends of each interval (time_scaling/topp.py; regression tests in
#: tests/time_scaling/test_topp.py).
KNOWN_CHECK_FAILURES: dict[str, str] = {}
#: The scenarios planned by default: those whose defects are described above (random-0 and
#: -7: stall window; -6: TOPP zone, torque limits; -11 and -18: arm push at joint limits;
#: -21, -22, -24: near-goal push; -29: Pfaffian check at delta 0.1) and random-13, not
#: reached (timeout; the not-reached case of the CLI test). Five with torque limits, five
#: without; 9/10 reached when measured (2026-11-24).
SELECTED = (0, 6, 7, 11, 13, 18, 21, 22, 24, 29)
#: Floor on the reached fraction of ``SELECTED``: the whole set's margin (one scenario).
SELECTED_FLOOR = 0.8
SLOW = bool(os.environ.get("MMPLAN_SLOW_TESTS"))


def _obstacle(rng: np.random.Generator, goal: np.ndarray) -> dict[str, Any]:
    """One random obstacle, centred near the straight start -> goal line (or anywhere near)."""
    along = rng.uniform(0.2, 0.8)
    normal = np.array([-goal[1], goal[0]]) / np.hypot(goal[0], goal[1])
    c = goal[:2] * along + normal * rng.normal(0.0, 0.5)
    kind = str(rng.choice(["cylinder", "sphere", "box"]))
    if kind == "cylinder":
        return {
            "shape": "cylinder",
            "base_center": [float(c[0]), float(c[1]), 0.0],
            "radius": float(rng.uniform(0.08, 0.3)),
            "height": float(rng.uniform(0.05, 0.6)),
        }
    if kind == "sphere":
        return {
            "shape": "sphere",
            "center": [float(c[0]), float(c[1]), float(rng.uniform(0.1, 0.7))],
            "radius": float(rng.uniform(0.06, 0.2)),
        }
    return {
        "shape": "box",
        "center": [float(c[0]), float(c[1]), float(rng.uniform(0.05, 0.4))],
        "size": [float(rng.uniform(0.1, 0.4)), float(rng.uniform(0.1, 0.4)), 0.2],
        "yaw": float(rng.uniform(-np.pi, np.pi)),
    }


def random_scenario(rng: np.random.Generator, index: int, count: int) -> dict[str, Any]:
    """Scenario ``index`` of ``count`` in the YAML form (docs/conventions.md)."""
    robot = get_robot("youbot-3r")
    start_points = robot.collision_points(np.asarray(START))
    heading = 2.0 * np.pi * (index + rng.uniform(0.0, 1.0)) / count - np.pi
    dist = rng.uniform(1.0, 2.5)
    height = rng.uniform(0.02, 0.15) if index % 4 < 2 else rng.uniform(0.3, 0.45)
    goal = np.array([dist * np.cos(heading), dist * np.sin(heading), height])
    obstacles: list[dict[str, Any]] = []
    wanted = int(rng.integers(1, 6))
    for _ in range(200):
        if len(obstacles) == wanted:
            break
        data = _obstacle(rng, goal)
        scene = Scene.from_dicts([data])
        if (
            float(scene.distances(start_points).min()) > START_GAP
            and float(scene.distances(goal[None, :]).min()) > GOAL_GAP
        ):
            obstacles.append(data)
    scenario: dict[str, Any] = {
        "name": f"random-{index}",
        "robot": "youbot-3r",
        "start": START,
        "goal": {"position": [float(v) for v in goal], "tolerance": 0.001},
        "obstacles": obstacles,
        "planner": dict(PLANNER),
    }
    if index % 2:
        scenario["limits"] = {"torque": "unlimited"}
    return scenario


HONEST = {Status.STALLED, Status.DIVERGED, Status.INFEASIBLE, Status.TIMEOUT}


def _scenarios() -> list[dict[str, Any]]:
    rng = np.random.default_rng(SEED)
    return [random_scenario(rng, i, COUNT) for i in range(COUNT)]


@pytest.fixture(scope="module")
def planned() -> dict[int, tuple[dict[str, Any], Any]]:
    """Scenario index -> its outcome, filled as scenarios are asked for (each planned once)."""
    return {}


@pytest.fixture(
    scope="module",
    params=[
        "selected",
        pytest.param("whole", marks=pytest.mark.skipif(
            not SLOW, reason="the whole random youbot-3r set (30 plans, about 1 min): "
                             "MMPLAN_SLOW_TESTS=1 runs it; the [selected] 10 run by default")),
    ],
)
def outcomes(
    request: pytest.FixtureRequest, planned: dict[int, tuple[dict[str, Any], Any]]
) -> list[tuple[dict[str, Any], Any]]:
    """Each selected scenario (or every one) with its (problem, result), or the InputError
    it raised."""
    indices = SELECTED if request.param == "selected" else range(COUNT)
    sets = _scenarios()
    for index in indices:
        if index in planned:
            continue
        data = sets[index]
        try:
            problem = Scenario.from_dict(data, str(data["name"])).build()
            planned[index] = (data, (problem, ExtendedJacobian().plan(problem)))
        except InputError as exc:
            planned[index] = (data, exc)
    return [planned[index] for index in indices]


def test_selection_spans_the_set() -> None:
    """The default selection holds torque-limited and unlimited, low and high scenarios."""
    chosen = [_scenarios()[i] for i in SELECTED]
    assert len(set(SELECTED)) == len(SELECTED) >= 8 and max(SELECTED) < COUNT
    assert sum("limits" not in s for s in chosen) == len(chosen) // 2
    heights = np.array([s["goal"]["position"][2] for s in chosen])
    assert (heights < 0.15).sum() >= 3 and (heights > 0.3).sum() >= 3


def test_set_covers_directions_heights_shapes_and_limits() -> None:
    """The set is as described: every direction, low and high, 1-5 obstacles of each shape."""
    scenarios = _scenarios()
    assert len(scenarios) >= 30
    goals = np.array([s["goal"]["position"] for s in scenarios])
    heading = np.degrees(np.arctan2(goals[:, 1], goals[:, 0]))
    for lo in range(-180, 180, 45):  # ahead, beside, behind: every 45-degree sector
        assert np.any((heading >= lo) & (heading < lo + 45)), lo
    dist = np.hypot(goals[:, 0], goals[:, 1])
    assert dist.min() >= 1.0 and dist.max() <= 2.5
    assert (goals[:, 2] < 0.15).sum() >= 10 and (goals[:, 2] > 0.3).sum() >= 10
    counts = [len(s["obstacles"]) for s in scenarios]
    assert min(counts) >= 1 and max(counts) <= 5 and len(set(counts)) == 5
    shapes = {o["shape"] for s in scenarios for o in s["obstacles"]}
    assert shapes == {"sphere", "cylinder", "box"}
    limited = [s for s in scenarios if "limits" not in s]
    assert len(limited) == len(scenarios) // 2
    robot = get_robot("youbot-3r")
    start_points = robot.collision_points(np.asarray(START))
    for s, goal in zip(scenarios, goals, strict=True):
        scene = Scene.from_dicts(s["obstacles"])
        assert float(scene.distances(start_points).min()) > START_GAP
        assert float(scene.distances(goal[None, :]).min()) > GOAL_GAP


def test_reached_plans_pass_the_checker(outcomes: list[tuple[dict[str, Any], Any]]) -> None:
    """Every plan that reports ``reached`` passes the independent check (mmplan check).

    The only exceptions are listed in ``KNOWN_CHECK_FAILURES`` (planner bugs found by this
    set, reported in issue 7's notes): those may pass, or fail with exactly the named
    check and nothing else.
    """
    bad: dict[str, list[str]] = {}
    for data, outcome in outcomes:
        if isinstance(outcome, InputError) or not outcome[1].reached:
            continue
        problem, result = outcome
        failures = check(result.trajectory, problem, result.status.value).failures()
        known = KNOWN_CHECK_FAILURES.get(str(data["name"]))
        if known is not None:
            failures = [f for f in failures if not f.startswith(known)]
        if failures:
            bad[str(data["name"])] = failures
    assert bad == {}


def test_other_plans_end_honestly(outcomes: list[tuple[dict[str, Any], Any]]) -> None:
    """Not reached: an honest status, a message, a finite trajectory, the task really open."""
    for data, outcome in outcomes:
        if isinstance(outcome, InputError):
            assert outcome.field, data["name"]
            continue
        problem, result = outcome
        assert result.trajectory.is_finite(), data["name"]
        if result.reached:
            continue
        assert result.status in HONEST and result.message, data["name"]
        report = check(result.trajectory, problem, result.status.value)
        assert not report.task_completed, (data["name"], result.status, report.final_error_m)


def test_reached_fraction(outcomes: list[tuple[dict[str, Any], Any]]) -> None:
    """Print the tally and hold the reached fraction above the measured floor."""
    tally: dict[str, int] = {}
    for data, outcome in outcomes:
        key = "input error" if isinstance(outcome, InputError) else outcome[1].status.value
        if not isinstance(outcome, InputError):
            tr = outcome[1].trajectory
            error = float(np.linalg.norm(tr.ee[-1] - np.asarray(data["goal"]["position"])))
            print(
                f"{data['name']:10s} goal {np.round(data['goal']['position'], 2)} "
                f"obstacles {len(data['obstacles'])} limits {'no ' if 'limits' in data else 'yes'} "
                f"{key:9s} t_end {tr.t[-1]:5.1f} s final error {error:.4f} m"
            )
        key += " (torque limits)" if "limits" not in data else ""
        tally[key] = tally.get(key, 0) + 1
    reached = sum(v for k, v in tally.items() if k.startswith("reached"))
    fraction = reached / len(outcomes)
    print(f"\nrandom youbot-3r set: reached {reached}/{len(outcomes)} = {fraction:.0%}; {tally}")
    assert fraction >= (REACHED_FLOOR if len(outcomes) == COUNT else SELECTED_FLOOR), tally


def _base(**changes: Any) -> dict[str, Any]:
    data: dict[str, Any] = {
        "name": "bad",
        "robot": "youbot-3r",
        "start": START,
        "goal": {"position": [1.5, -1.0, 0.2], "tolerance": 0.001},
        "obstacles": [{"shape": "sphere", "center": [0.8, -0.6, 0.4], "radius": 0.1}],
        "planner": dict(PLANNER),
    }
    data.update(changes)
    return data


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"goal": {"position": [1.5, -1.0, 1.5]}}, "goal.position[2]"),
        (
            {
                "obstacles": [
                    {
                        "shape": "cylinder",
                        "base_center": [1.5, -1.0, 0.0],
                        "radius": 0.3,
                        "height": 0.5,
                    }
                ]
            },
            "goal.position",
        ),
        (
            {"obstacles": [{"shape": "box", "center": [0.0, 0.0, 0.1], "size": [0.3, 0.3, 0.3]}]},
            "start",
        ),
        (
            {
                "limits": {
                    "torque": {
                        "min": [-1.5, -1.5, -1.0, -5.0, -5.0],
                        "max": [1.5, 1.5, 1.0, 0.0, 0.0],
                    }
                }
            },
            "limits.torque.min[3]",
        ),
    ],
)
def test_bad_input_is_input_error(changes: dict[str, Any], field: str) -> None:
    """Unreachable height, goal inside an obstacle, start in collision, gravity over the limit."""
    with pytest.raises(InputError) as info:
        problem = Scenario.from_dict(_base(**changes), "bad").build()
        ExtendedJacobian().plan(problem)
    assert field in str(info.value)


def test_cli_not_reached_exits_3(
    outcomes: list[tuple[dict[str, Any], Any]], tmp_path: Path
) -> None:
    """The shortest random plan that does not reach its goal (random-13, timeout, when
    measured) exits 3 from ``mmplan plan`` with the same honest status in summary.json, and
    ``mmplan check`` accepts the written plan."""
    failed = [
        (outcome[1].trajectory.duration, data, outcome[1].status.value)
        for data, outcome in outcomes
        if not isinstance(outcome, InputError) and not outcome[1].reached
    ]
    assert failed, "every random plan reached its goal: pick another not-reached case"
    _, data, status = min(failed, key=lambda item: item[0])
    path = tmp_path / f"{data['name']}.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "plan"
    result = CliRunner().invoke(main, ["plan", str(path), "--out", str(out), "--quiet"])
    assert result.exit_code == 3, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == status
    assert CliRunner().invoke(main, ["check", str(out)]).exit_code == 0
