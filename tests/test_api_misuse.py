# mypy: disable-error-code="arg-type, call-overload, misc"
"""Misuse of the Python API: every wrong argument is a package error with one line (issue 16).

Each case calls a public function (or constructor) with an argument of the wrong type or
value; the call must raise :class:`~mmplan.errors.MmplanError` (never a bare ``TypeError``,
``AttributeError`` or ``ValueError``) whose message is one line of bounded length naming the
argument. A few right uses with loose but exact forms (a status as its string) are accepted.
No case plans anything: the errors come before any model is built.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mmplan
from mmplan.errors import MAX_MESSAGE, InputError, MmplanError
from mmplan.io.export import export_plan, resample
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.problem import PlannerSettings, Problem
from mmplan.robot.robot import EndEffector, Robot
from mmplan.trajectory import PlanResult, Solution, Status, Trajectory
from mmplan.verify.check import check


class Ctx:
    """A problem, a short trajectory at its start and a result to misuse, built once."""

    def __init__(self, tmp: Path) -> None:
        self.tmp = tmp
        self.scenario = mmplan.load_scenario("youbot3r-obstacles")
        self.problem = self.scenario.build()
        robot = self.problem.robot
        n = robot.n
        q = np.tile(self.problem.start, (2, 1))
        ee = np.tile(robot.ee_position(self.problem.start), (2, 1))
        self.trajectory = Trajectory(robot.coordinates, np.array([0.0, 0.1]), q,
                                     np.zeros((2, n)), np.zeros((2, n)), ee)
        self.result = PlanResult(Status.STALLED, self.trajectory, "extended-jacobian")
        self.car = mmplan.load_scenario("car-rtr-free").build()

    def out(self, name: str) -> str:
        return str(self.tmp / name)


@pytest.fixture(scope="module")
def ctx(tmp_path_factory: pytest.TempPathFactory) -> Ctx:
    return Ctx(tmp_path_factory.mktemp("misuse"))


def _problem(c: Ctx, **changes: Any) -> Problem:
    p = c.problem
    parts = {"robot": p.robot, "scene": p.scene, "task": p.task, "start": p.start,
             "settings": p.settings, **changes}
    return Problem(**parts)


EJ = ExtendedJacobian
#: (name, call, a word the message must hold): each call must raise a package error.
CASES: list[tuple[str, Callable[[Ctx], Any], str]] = [
    # write_plan
    ("write_plan status bogus",
     lambda c: mmplan.write_plan(c.out("a"), replace(c.result, status="bogus"), c.problem),
     "status"),
    ("write_plan status int",
     lambda c: mmplan.write_plan(c.out("a"), replace(c.result, status=1), c.problem), "status"),
    ("write_plan status upper case",
     lambda c: mmplan.write_plan(c.out("a"), replace(c.result, status="REACHED"), c.problem),
     "status"),
    ("write_plan result None", lambda c: mmplan.write_plan(c.out("b"), None, c.problem),
     "result"),
    ("write_plan result trajectory",
     lambda c: mmplan.write_plan(c.out("b"), c.trajectory, c.problem), "result"),
    ("write_plan problem str", lambda c: mmplan.write_plan(c.out("c"), c.result, "x"), "problem"),
    ("write_plan scenario int",
     lambda c: mmplan.write_plan(c.out("d"), c.result, c.problem, 3), "scenario"),
    ("write_plan out int", lambda c: mmplan.write_plan(3, c.result, c.problem), "out"),
    ("write_plan out None", lambda c: mmplan.write_plan(None, c.result, c.problem), "out"),
    ("write_plan fmt xml",
     lambda c: mmplan.write_plan(c.out("e"), c.result, c.problem, fmt="xml"), "format"),
    ("write_plan fmt int",
     lambda c: mmplan.write_plan(c.out("e"), c.result, c.problem, fmt=3), "format"),
    # check
    ("check trajectory None", lambda c: check(None, c.problem), "trajectory"),
    ("check trajectory array", lambda c: check(np.zeros((3, 3)), c.problem), "trajectory"),
    ("check problem None", lambda c: check(c.trajectory, None), "problem"),
    ("check problem scenario", lambda c: check(c.trajectory, c.scenario), "problem"),
    ("check status int", lambda c: check(c.trajectory, c.problem, status=5), "status"),
    ("check status list", lambda c: check(c.trajectory, c.problem, status=["reached"]),
     "status"),
    ("check other robot", lambda c: check(c.trajectory, c.car), "trajectory"),
    # Planner.plan and settings
    ("plan problem None", lambda c: EJ().plan(None), "problem"),
    ("plan problem name", lambda c: EJ().plan("youbot3r-obstacles"), "problem"),
    ("plan problem scenario", lambda c: EJ().plan(c.scenario), "problem"),
    ("plan progress int", lambda c: EJ().plan(c.problem, progress=3), "progress"),
    ("plan settings of another method", lambda c: EJ().plan(c.car), "method"),
    ("plan settings renamed",  # 13 unknown keys of the endogenous model: one line
     lambda c: EJ().plan(replace(c.car, settings=c.car.settings.model_copy(
         update={"method": "extended-jacobian"}))), "planner"),
    ("plan car-rtr with its settings",
     lambda c: EJ().plan(replace(c.car, settings=PlannerSettings(
         method="extended-jacobian", t_max=60.0))),
     "start"),
    ("settings None", lambda c: EJ.settings(None), "planner"),
    ("settings dict", lambda c: EJ.settings({"method": "extended-jacobian"}), "planner"),
    # Problem
    ("Problem robot None", lambda c: _problem(c, robot=None), "robot"),
    ("Problem robot name", lambda c: _problem(c, robot="youbot-3r"), "robot"),
    ("Problem scene list", lambda c: _problem(c, scene=[]), "scene"),
    ("Problem task str", lambda c: _problem(c, task="reach"), "task"),
    ("Problem task tuple", lambda c: _problem(c, task=(3.5, 4.0, 0.16)), "task"),
    ("Problem settings dict", lambda c: _problem(c, settings={"method": "x"}), "settings"),
    ("Problem start str", lambda c: _problem(c, start="abc"), "start"),
    ("Problem start None", lambda c: _problem(c, start=None), "start"),
    ("Problem start short", lambda c: _problem(c, start=[0.0, 1.0]), "start"),
    ("Problem start NaN", lambda c: _problem(c, start=np.full(8, np.nan)), "start"),
    ("Problem start strings", lambda c: _problem(c, start=["0.1"] * 8), "start"),
    ("Problem start booleans", lambda c: _problem(c, start=[True] * 8), "start"),
    ("Problem start ragged", lambda c: _problem(c, start=[[0.0], [1.0, 2.0]]), "start"),
    # Scene, Robot, tasks
    ("Scene obstacles int", lambda c: mmplan.Scene(3), "obstacles"),
    ("Scene obstacles str", lambda c: mmplan.Scene("sphere"), "obstacles"),
    ("Scene obstacle dict", lambda c: mmplan.Scene([{"shape": "sphere"}]), "obstacles"),
    ("Scene ground str", lambda c: mmplan.Scene((), ground="x"), "ground"),
    ("Robot name int",
     lambda c: Robot(3, c.problem.robot.platform, [], [], EndEffector("platform"),
                     c.problem.robot.limits), "name"),
    ("Robot platform None",
     lambda c: Robot("r", None, [], [], EndEffector("platform"), c.problem.robot.limits),
     "platform"),
    ("Robot limits dict",
     lambda c: Robot("r", c.problem.robot.platform, [], [], EndEffector("platform"), {}), "limits"),
    ("ReachPoint str", lambda c: mmplan.ReachPoint("abc"), "position"),
    ("ReachPoint two values", lambda c: mmplan.ReachPoint((1.0, 2.0)), "position"),
    ("ReachPoint NaN", lambda c: mmplan.ReachPoint((1.0, np.nan, 0.0)), "position"),
    ("ReachPoint tolerance str", lambda c: mmplan.ReachPoint((1, 2, 3), tolerance="x"),
     "tolerance"),
    ("ReachPoint tolerance negative", lambda c: mmplan.ReachPoint((1, 2, 3), tolerance=-1.0),
     "tolerance"),
    ("get_robot int", lambda c: mmplan.get_robot(3), "robot"),
    ("get_planner None", lambda c: mmplan.get_planner(None), "method"),
    # scenarios and plan folders
    ("load_scenario int", lambda c: mmplan.load_scenario(3), "scenario"),
    ("load_scenario None", lambda c: mmplan.load_scenario(None), "scenario"),
    ("load_scenario list", lambda c: mmplan.load_scenario(["youbot3r-obstacles"]), "scenario"),
    ("load_scenario require_planner str",
     lambda c: mmplan.load_scenario("youbot3r-obstacles", require_planner="no"),
     "require_planner"),
    ("load_scenario check_start int",
     lambda c: mmplan.load_scenario("youbot3r-obstacles", check_start=0), "check_start"),
    ("scenario_header int", lambda c: mmplan.scenario_header(3), "scenario"),
    ("read_plan int", lambda c: mmplan.read_plan(3), "directory"),
    ("read_plan missing", lambda c: mmplan.read_plan(c.out("none")), "no such"),
    ("read_summary None", lambda c: mmplan.read_summary(None), "directory"),
    ("read_trajectory_csv None", lambda c: mmplan.read_trajectory_csv(None), "path"),
    # export
    ("export_plan plan None", lambda c: export_plan(None, out=c.out("o")), "plan_dir"),
    ("export_plan out int", lambda c: export_plan(c.tmp, out=5), "out"),
    ("export_plan ros2 list", lambda c: export_plan(c.tmp, ros2=["a"]), "ros2"),
    ("export_plan rate str", lambda c: export_plan(c.tmp, rate="x", out=c.out("o")), "rate"),
    ("export_plan nothing to write", lambda c: export_plan(c.tmp), "nothing"),
    ("resample trajectory None", lambda c: resample(None, 50.0, c.problem.robot),
     "trajectory"),
    ("resample robot None", lambda c: resample(c.trajectory, 50.0, None), "robot"),
    ("resample rate str", lambda c: resample(c.trajectory, "x", c.problem.robot), "rate"),
    # results and statuses
    ("Status bogus", lambda c: Status("bogus"), "status"),
    ("Status int", lambda c: Status(3), "status"),
    ("PlanResult status bogus", lambda c: PlanResult("bogus", c.trajectory, "x"), "status"),
    ("PlanResult trajectory None", lambda c: PlanResult(Status.REACHED, None, "x"),
     "trajectory"),
    ("PlanResult planner int", lambda c: PlanResult(Status.REACHED, c.trajectory, 3),
     "planner"),
    ("Solution status None", lambda c: Solution(None, c.trajectory), "status"),
]


@pytest.mark.parametrize(("name", "call", "word"), CASES, ids=[c[0] for c in CASES])
def test_misuse_is_a_one_line_package_error(
    ctx: Ctx, name: str, call: Callable[[Ctx], Any], word: str
) -> None:
    with pytest.raises(MmplanError) as info:
        call(ctx)
    message = str(info.value)
    assert "\n" not in message and 0 < len(message) <= MAX_MESSAGE, message
    assert word.lower() in message.lower(), message


def test_case_count() -> None:
    """The issue asks for at least 40 misuse cases."""
    assert len(CASES) >= 40


def test_a_status_is_its_exact_string(ctx: Ctx) -> None:
    """A status given as its string value is the enum member everywhere."""
    result = replace(ctx.result, status="stalled")
    assert result.status is Status.STALLED
    assert PlanResult("reached", ctx.trajectory, "x").status is Status.REACHED
    assert Solution("timeout", ctx.trajectory).status is Status.TIMEOUT
    out = mmplan.write_plan(ctx.out("accepted"), result, ctx.problem)
    assert mmplan.read_summary(out)["status"] == "stalled"


def test_a_bogus_claimed_status_is_a_failed_check(ctx: Ctx) -> None:
    """``check`` judges a claimed status read from a file: an unknown string is a failure
    (exit 3 in ``mmplan check``), not an input error."""
    failures = check(ctx.trajectory, ctx.problem, status="bogus").failures()
    assert any(f.startswith("status: 'bogus' is not one of") for f in failures)
    assert not any(f.startswith("status") for f in
                   check(ctx.trajectory, ctx.problem, status=Status.STALLED).failures())


def test_input_error_messages_are_one_bounded_line() -> None:
    """Whatever a message holds, an InputError prints one line of at most MAX_MESSAGE."""
    err = InputError("field\nname", "line one\nline two " + "x" * 5000)
    assert "\n" not in str(err) and len(str(err)) <= MAX_MESSAGE
    assert str(err).startswith("field\\nname: line one\\nline two")


def test_problem_start_is_a_float_copy(ctx: Ctx) -> None:
    start = [0, 0, 0, 0, 0, 0, 0, 0]
    problem = _problem(ctx, start=start)
    assert problem.start.dtype == float and problem.start.shape == (8,)
