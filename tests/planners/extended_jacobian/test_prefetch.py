"""The next chunk guessed on a C thread (planners/extended_jacobian/prefetch.py): same bits."""

from __future__ import annotations

import os

import numpy as np
import pytest

import mmplan
from mmplan.compile import codegen as cg
from mmplan.planners.extended_jacobian.functions import GeneratorFunctions
from mmplan.planners.extended_jacobian.prefetch import Speculation


def _plan_fns(name: str) -> tuple[object, GeneratorFunctions, mmplan.Problem]:
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    sc = mmplan.load_scenario(name)
    problem = sc.build()
    planner = mmplan.get_planner(sc.method)()
    planner.plan(problem)
    prep = planner._prepare(problem)
    prep.fns._speculate().settle()  # the plan's last guess: the buffers are free again
    return planner, prep.fns, problem


def _native_and_own() -> tuple[object, Speculation]:
    """The paper scenario's compiled chunk and a Speculation of a test's own over it."""
    _, fns, _ = _plan_fns("youbot3r-obstacles-torque")
    return fns.native_chunk, Speculation(fns.native_chunk, enabled=True)


def test_guesses_give_the_same_plan_to_the_bit() -> None:
    planner, fns, problem = _plan_fns("youbot3r-obstacles-torque")
    assert fns.native_chunk is not None
    runs = {}
    spec = fns._speculate()
    try:
        for on in (True, False):
            spec.switch(on)
            hits, misses = spec.hits, spec.misses
            runs[on] = planner.plan(problem).trajectory  # type: ignore[attr-defined]
            assert spec.enabled is on
            if on:  # every chunk is a guess taken; the last guess is still in flight
                assert spec.hits - hits >= 5 and spec.misses - misses <= 1
            else:
                assert (spec.hits, spec.misses) == (hits, misses)
    finally:
        spec.switch(True)
        spec.follow_load = True  # the cached generator guesses as by default for later tests
    for field in ("t", "q", "dq", "ddq", "tau"):
        np.testing.assert_array_equal(getattr(runs[True], field), getattr(runs[False], field))


def test_a_plan_runs_its_chunks_as_one_chain() -> None:
    """The worker runs the rollout's chunks one after the other from one guess, each from the
    last one's final state (a chain, prefetch.Speculation): one start for the plan's 13
    chunks, every one taken (the same samples as without guesses: the test above)."""
    planner, fns, problem = _plan_fns("youbot3r-obstacles-torque")
    spec = fns._speculate()
    spec.switch(True)  # guess whatever the machine's load
    try:
        assert spec._job is not None
        starts: list[int] = []
        original = spec._job.start

        def counted(limit: int, stop: float) -> bool:
            starts.append(limit)
            return original(limit, stop)

        spec._job.start = counted  # type: ignore[method-assign]
        hits, misses = spec.hits, spec.misses
        result = planner.plan(problem)  # type: ignore[attr-defined]
        assert result.status.value == "reached"
        assert spec.hits - hits == 13 and spec.misses == misses
        assert len(starts) == 1 and starts[0] > 13  # t_max = 60 s: up to the chain's depth
        assert not spec.pending  # none after the chunk that reached the goal
        del spec._job.start
    finally:
        spec.follow_load = True


def test_a_guess_at_another_input_is_dropped() -> None:
    native, spec = _native_and_own()
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
    native, spec = _native_and_own()
    x = native.x.copy()
    spec.guess(x)
    assert spec._guess is not None and spec._job is not None and spec._job.running
    from mmplan.planners.extended_jacobian import prefetch

    prefetch._settle_all()
    assert spec._guess is None and spec._job is not None and not spec._job.running
    spec.guess(x)
    spec.__del__()
    assert spec._guess is None and spec.misses == 2


def test_waiting_for_a_running_guess_runs_the_idle_tasks_once() -> None:
    """Idle tasks run while a guess computes, not when it is over (a process's first plan:
    the first chunk was done before the rollout asked, and the task ran on the plan's path)."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    import time

    from mmplan.compile import threads
    from mmplan.planners.extended_jacobian import prefetch

    assert threads.library() is not None  # built now when missing (a fresh cache)
    spec = Speculation(_Slow(), enabled=True)  # 50 ms a call
    ran: list[int] = []

    def task() -> None:
        ran.append(1)

    prefetch.while_waiting(task)
    prefetch.while_waiting(task)  # once
    x = np.array([3.0])
    spec.call(x)  # no guess in flight: nothing to wait for, the task waits
    assert ran == []
    spec.guess(x)
    deadline = time.monotonic() + 10.0
    while spec._job is not None and not spec._job.done() and time.monotonic() < deadline:
        time.sleep(0.01)  # the guess is over: its wait returns at once, the task waits
    np.testing.assert_array_equal(spec.call(x), [6.0])
    assert ran == [] and spec.hits == 1
    spec.guess(x)
    np.testing.assert_array_equal(spec.call(x), [6.0])  # running: the task runs meanwhile
    assert ran == [1] and spec.hits == 2
    spec.guess(x)
    spec.call(x)
    assert ran == [1]


_SLOW = r"""
#include <unistd.h>
int mmplan_test_slow(const double **a, double **r, void *iw, double *w, int m) {
    usleep(50000); r[0][0] = 2.0 * a[0][0]; return 0;
}
"""


class _Slow:
    """A compiled function's stand-in whose call takes 50 ms: y = 2 x."""

    def __init__(self) -> None:
        import ctypes

        path = cg.compile_source(_SLOW, "test_slow")
        assert path is not None
        dbl = ctypes.POINTER(ctypes.c_double)
        self.x, self.y, self._w = np.zeros(1), np.zeros(1), np.zeros(1)
        self._arg, self._res = (dbl * 1)(), (dbl * 1)()
        self._arg[0], self._res[0] = self.x.ctypes.data_as(dbl), self.y.ctypes.data_as(dbl)
        self._iw = (ctypes.c_int * 1)()
        self._fn = ctypes.CDLL(path).mmplan_test_slow

    def signature(self) -> tuple[object, ...]:
        import ctypes

        w = self._w.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        return self._fn, self._arg, self._res, self._iw, w, 0

    def __call__(self) -> np.ndarray:
        self._fn(*self.signature()[1:])
        return self.y


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork()")
def test_a_forked_child_does_not_take_a_guess_of_its_parent() -> None:
    """Before a fork every guess is joined (prefetch._settle_all at fork): a child has no C
    thread, and without the join it returned its parent's half-written output (0.0, found by
    review)."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    spec = Speculation(_Slow(), enabled=True)
    spec.guess(np.array([3.0]))
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.write(write, spec.call(np.array([3.0])).tobytes())
        os._exit(0)
    os.waitpid(pid, 0)
    child = np.frombuffer(os.read(read, 8))
    assert spec.call(np.array([3.0]))[0] == 6.0
    assert child[0] == 6.0


def test_settle_all_joins_every_guess_whatever_an_idle_task_raises() -> None:
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    from mmplan.planners.extended_jacobian import prefetch

    a, b = (Speculation(_Slow(), enabled=True) for _ in range(2))
    a.guess(np.array([1.0]))
    b.guess(np.array([2.0]))

    def fails() -> None:
        raise OSError("a warm-up that failed")

    prefetch.while_waiting(fails)
    prefetch._settle_all()
    assert a._guess is None and b._guess is None
    np.testing.assert_array_equal(a.call(np.array([4.0])), [8.0])  # the task's error stays in it
    prefetch._IDLE.clear()


def test_each_plan_guesses_its_first_chunk() -> None:
    """A guess in flight (e.g. a plan's that ended otherwise than at the goal) is replaced by
    the new plan's first chunk (found by review: it stayed in flight, no first-chunk guess);
    a plan that reaches the goal guesses no chunk after its last (the worker thread stays
    free for the time scaling's backward pass)."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    sc = mmplan.load_scenario("youbot3r-obstacles-torque")
    problem = sc.build()
    planner = mmplan.get_planner(sc.method)()
    planner.plan(problem)
    fns = planner._prepare(problem).fns
    spec = fns._speculate()
    spec.switch(True)  # guess whatever the machine's load
    hits = spec.hits
    result = planner.plan(problem)
    assert result.status.value == "reached" and spec.hits > hits + 5  # chunks were guessed
    assert spec._guess is None  # ... but none after the one that reached the goal
    n = fns.n
    spec.guess(np.asarray(spec._native.x, dtype=float) + 1.0)  # one in flight
    assert spec._guess is not None
    prep = planner._prepare(problem, guess=True)
    first = np.concatenate(
        [prep.q0, np.zeros(n), prep.params, [1.0, 1.0], np.zeros(n), [prep.options.dt]]
    )
    assert spec._guess is not None
    np.testing.assert_array_equal(spec._guess, first)
    spec.settle()
    spec.follow_load = True


def test_ctypes_calls_equal_casadis_calls_of_the_same_library() -> None:
    """E (sparse output, two inputs), terms_flat and effort through ctypes
    (GeneratorFunctions._native, no ``casadi.external``) against CasADi's call of the same
    compiled functions: the same bits, at the samples of a plan and at random states."""
    planner, fns, problem = _plan_fns("youbot3r-obstacles-torque")
    assert fns.library
    prep = planner._prepare(problem)  # type: ignore[attr-defined]
    p = prep.params
    rng = np.random.default_rng(9)
    n = fns.n
    Q = np.vstack([planner.plan(problem).trajectory.q[::40], rng.normal(size=(8, n))])  # type: ignore[attr-defined]
    assert fns._native("E").pattern.rows is not None  # E is stored sparse: scattered here
    for q in Q:
        dq = rng.normal(size=n)
        E = fns.E_at(q, p)
        assert E.shape == (n, n)
        np.testing.assert_array_equal(E.view(np.uint64), np.asarray(fns.E(q, p)).view(np.uint64))
        t = fns.evaluate(q, dq, p)
        v = np.asarray(fns.terms_flat(np.concatenate([q, dq, p])).full()).ravel()
        got = np.concatenate([t.f0, t.fv, t.fp, [t.S], t.T0, t.Tm.T.ravel(), [t.err], t.Tg, t.gK])
        np.testing.assert_array_equal(got.view(np.uint64), v.view(np.uint64))
        g = fns.gravity_efforts(q)
        want = np.asarray(fns.effort(np.concatenate([q, np.zeros(n)]))).ravel()[fns.n_act :]
        np.testing.assert_array_equal(g.view(np.uint64), want.view(np.uint64))


def test_a_library_that_cannot_be_called_through_ctypes_leaves_casadis_call() -> None:
    """_native gives None (and E_at CasADi's call) when the library does not load through
    ctypes, instead of raising inside a plan."""
    planner, fns, problem = _plan_fns("youbot3r-obstacles-torque")
    prep = planner._prepare(problem)  # type: ignore[attr-defined]
    fns._speculate().settle()
    want = fns.E_at(prep.q0, prep.params)
    saved_library, saved = fns.library, dict(fns.cache)
    try:
        fns.library = "/nonexistent/mmplan_missing.so"
        fns.cache.pop("native_E", None)
        assert fns._native("E") is None
        np.testing.assert_array_equal(fns.E_at(prep.q0, prep.params), want)
    finally:
        fns.library = saved_library
        fns.cache.clear()
        fns.cache.update(saved)


def test_a_rollout_that_raises_ends_its_chain(monkeypatch: pytest.MonkeyPatch) -> None:
    """A rollout interrupted between two chunks (here a KeyboardInterrupt from the chunk
    checks, called directly as a Replanner does) leaves no chain holding the worker thread
    (found by review: the chain stayed pending, the worker claimed)."""
    import dataclasses

    from mmplan.planners.extended_jacobian import chunks
    from mmplan.planners.extended_jacobian.generator import wheel_metric_inverse
    from mmplan.planners.extended_jacobian.rollout import rollout

    planner, fns, problem = _plan_fns("youbot3r-obstacles-torque")
    spec = fns._speculate()
    spec.switch(True)  # guess whatever the machine's load
    try:
        prep = planner._prepare(problem, guess=True)  # type: ignore[attr-defined]
        assert spec.pending  # the first chunks are running
        original, calls = chunks.run, []

        def interrupted(*args: object, **kwargs: object) -> object:
            calls.append(1)
            if len(calls) == 2:
                raise KeyboardInterrupt
            return original(*args, **kwargs)  # type: ignore[arg-type]

        monkeypatch.setattr(chunks, "run", interrupted)
        robot = problem.robot
        with pytest.raises(KeyboardInterrupt):
            options = dataclasses.replace(prep.options, torque_control=False)
            rollout(prep.fns, robot.pfaffian, wheel_metric_inverse(robot), prep.q0, prep.params,
                    options, prep.switch)  # fmt: skip
        assert not spec.pending
    finally:
        spec.follow_load = True
