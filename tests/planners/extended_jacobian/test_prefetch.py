"""The next chunk guessed on a C thread (planners/extended_jacobian/prefetch.py): same bits."""

from __future__ import annotations

import numpy as np
import pytest

import mmplan
from mmplan.compile import codegen as cg
from mmplan.planners.extended_jacobian.functions import GeneratorFunctions
from mmplan.planners.extended_jacobian.prefetch import Speculation


def _plan_fns(name: str) -> tuple[object, GeneratorFunctions, mmplan.Problem]:
    sc = mmplan.load_scenario(name)
    problem = sc.build()
    planner = mmplan.get_planner(sc.method)()
    planner.plan(problem)
    prep = planner._prepare(problem)
    return planner, prep.fns, problem


def test_guesses_give_the_same_plan_to_the_bit() -> None:
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    planner, fns, problem = _plan_fns("youbot3r-obstacles-torque")
    assert fns.native_chunk is not None
    runs = {}
    for on in (True, False):
        fns._speculation = Speculation(fns.native_chunk, enabled=on)
        result = planner.plan(problem)
        runs[on] = result.trajectory
        spec = fns._speculation
        assert spec.enabled is on
        if on:  # every chunk but the first is a guess taken; the last guess is dropped
            assert spec.hits >= 5 and spec.misses <= 2
        else:
            assert spec.hits == spec.misses == 0
    for field in ("t", "q", "dq", "ddq", "tau"):
        np.testing.assert_array_equal(getattr(runs[True], field), getattr(runs[False], field))


def test_a_guess_at_another_input_is_dropped() -> None:
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    _, fns, _ = _plan_fns("youbot3r-obstacles-torque")
    native = fns.native_chunk
    spec = Speculation(native, enabled=True)
    x = native.x.copy()
    native.x[:] = x
    expected = native().copy()
    other = x.copy()
    other[0] += 1e-3
    spec.guess(other)
    np.testing.assert_array_equal(spec.call(x), expected)  # computed again at x
    assert (spec.hits, spec.misses) == (0, 1)
    spec.guess(x)
    np.testing.assert_array_equal(spec.call(x), expected)
    assert (spec.hits, spec.misses) == (1, 1)
    spec.guess(other)
    spec.settle()
    assert spec.misses == 2


def test_compiled_end_effector_positions_equal_the_robot_function() -> None:
    """The trajectory's ee column (functions.ee_positions, compiled) against the robot's own
    function on CasADi's virtual machine, at the samples of a plan and at random states."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    planner, fns, problem = _plan_fns("youbot3r-obstacles-torque")
    robot = problem.robot
    rng = np.random.default_rng(8)
    Q = np.vstack([planner.plan(problem).trajectory.q, rng.normal(size=(37, robot.n))])
    want = np.asarray(robot.functions["ee_position"].map(len(Q))(Q.T), dtype=float).T
    got = fns.ee_positions(Q)
    assert got is not None and got.shape == (len(Q), 3)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-14)
    assert fns.ee_positions(Q[:1]).shape == (1, 3)


def test_a_guess_in_flight_is_joined_before_its_buffers_go() -> None:
    """Dropping a Speculation (or the interpreter exiting, prefetch._settle_all) while its
    C thread runs waits for the thread: the guess is settled, nothing left in flight."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    _, fns, _ = _plan_fns("youbot3r-obstacles-torque")
    native = fns.native_chunk
    spec = Speculation(native, enabled=True)
    x = native.x.copy()
    spec.guess(x)
    assert spec._guess is not None and spec._job is not None and spec._job.running
    from mmplan.planners.extended_jacobian import prefetch

    prefetch._settle_all()
    assert spec._guess is None and spec._job is not None and not spec._job.running
    spec.guess(x)
    spec.__del__()
    assert spec._guess is None and spec.misses == 2


def test_waiting_for_a_guess_runs_the_idle_tasks_once() -> None:
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    from mmplan.planners.extended_jacobian import prefetch

    _, fns, _ = _plan_fns("youbot3r-obstacles-torque")
    native = fns.native_chunk
    spec = Speculation(native, enabled=True)
    ran: list[int] = []

    def task() -> None:
        ran.append(1)

    prefetch.while_waiting(task)
    prefetch.while_waiting(task)  # once
    x = native.x.copy()
    spec.call(x)  # no guess in flight: nothing to wait for, the task waits
    assert ran == []
    spec.guess(x)
    spec.call(x)
    assert ran == [1] and spec.hits == 1
    spec.guess(x)
    spec.call(x)
    assert ran == [1]
