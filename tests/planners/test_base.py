"""The planner template (mmplan.planners.base) and the method registry (mmplan.planners)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

import mmplan
from mmplan.errors import InputError
from mmplan.planners import builtin_methods, get_planner, settings_model
from mmplan.problem import PlannerSettings
from mmplan.task import LinePath


def test_each_method_is_named_once_by_its_settings_model() -> None:
    for method in builtin_methods():
        planner = get_planner(method)
        assert planner.method == method
        assert planner.settings_model is settings_model(method)
        assert planner.settings_model.model_fields["method"].default == method


def test_settings_of_another_method_are_one_input_error() -> None:
    """Before the template, the extended-Jacobian planner re-validated foreign settings and
    raised a 13-error pydantic ValidationError."""
    problem = mmplan.load_scenario("car-rtr-free").build()
    with pytest.raises(InputError) as err:
        get_planner("extended-jacobian")().plan(problem)
    assert err.value.field == "planner.method" and "\n" not in str(err.value)


def test_plain_settings_of_the_right_method_are_validated_by_its_model() -> None:
    problem = mmplan.load_scenario("car-rtr-free").build()
    plain = PlannerSettings.model_construct(method="endogenous", t_max=-1.0)
    with pytest.raises(InputError) as err:
        get_planner("endogenous")().plan(dataclasses.replace(problem, settings=plain))
    assert err.value.field.startswith("planner.") and "\n" not in str(err.value)


def test_goal_kind_and_start_are_checked_before_solving() -> None:
    problem = mmplan.load_scenario("car-rtr-free").build()
    line = LinePath(start=(0.0, 0.0, 1.0), speed=(0.1, 0.0, 0.0), duration=1.0)
    with pytest.raises(InputError, match="needs a goal position") as err:
        get_planner("endogenous")().plan(dataclasses.replace(problem, task=line))
    assert err.value.field == "goal"
    with pytest.raises(InputError, match="expected 7 values") as err:
        get_planner("endogenous")().plan(dataclasses.replace(problem, start=np.zeros(3)))
    assert err.value.field == "start"


def test_plan_stamps_method_and_compute_time_and_reports_progress() -> None:
    problem = mmplan.load_scenario("car-rtr-steer30").build()
    seen: list[float] = []
    result = get_planner("endogenous")().plan(problem, progress=seen.append)
    assert result.planner == "endogenous" and result.compute_time_s > 0
    assert seen and seen[-1] == 1.0


def test_listing_methods_imports_no_planner() -> None:
    code = (
        "import sys, mmplan; from mmplan.planners import methods, settings_model; "
        "methods(); settings_model('extended-jacobian'); "
        "print([m for m in sys.modules if m.endswith('.planner')])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


def test_method_table_matches_the_settings_modules_and_loads_one_package() -> None:
    """The static method -> package table equals what the settings modules declare, and one
    method's settings model loads no other method's settings module."""
    from mmplan.planners import METHOD_PACKAGES, _builtin

    assert {m: package for m, (package, _) in _builtin().items()} == METHOD_PACKAGES
    code = (
        "import sys; from mmplan.planners import settings_model; "
        "settings_model('extended-jacobian'); "
        "print(sorted(m for m in sys.modules if m.endswith('.settings')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "['mmplan.planners.extended_jacobian.settings']"


def test_plans_for_a_robot_with_effort_limits_carry_the_model_efforts() -> None:
    """A tracker writes no efforts; on a robot with torque limits the template adds the
    model's efforts of the planned motion (the checker requires and judges them)."""
    problem = mmplan.load_scenario("diffdrive3-track").build()
    robot = problem.robot
    n_act = len(robot.actuators)
    limited = robot.with_limits(dataclasses.replace(
        robot.limits, torque_min=np.full(n_act, -50.0), torque_max=np.full(n_act, 50.0)))
    free = get_planner("pseudoinverse")().plan(problem)
    assert free.trajectory.tau is None
    result = get_planner("pseudoinverse")().plan(dataclasses.replace(problem, robot=limited))
    tau = result.trajectory.tau
    assert tau is not None and tau.shape == (result.trajectory.samples, n_act)
    k = result.trajectory.samples // 2
    tr = result.trajectory
    np.testing.assert_allclose(tau[k], limited.actuator_efforts(tr.q[k], tr.dq[k], tr.ddq[k]))
    assert mmplan.check(tr, dataclasses.replace(problem, robot=limited),
                        status=result.status.value).failures() == []
