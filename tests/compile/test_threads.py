"""Generated functions evaluated on a C thread (mmplan.compile.threads)."""

from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from mmplan.compile import codegen as cg
from mmplan.compile import threads


@pytest.fixture()
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    threads.library.cache_clear()
    yield tmp_path
    threads.library.cache_clear()


def _native() -> cg.NativeFunction:
    x = ca.SX.sym("x", 4)
    y = ca.vertcat(ca.sin(x[0]) * x[1], ca.exp(x[2]) - x[3] ** 2, x[0] * x[3])
    library = cg.compile_library([ca.Function("mmplan_thr_fn", [x], [y])], "thr", ("-O0",))
    assert library is not None
    return cg.NativeFunction(library, "mmplan_thr_fn")


def test_a_job_computes_what_the_direct_call_computes(cache: Path) -> None:
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    native = _native()
    job = threads.Job(*native.signature())
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = rng.normal(size=4)
        native.x[:] = x
        direct = native().copy()
        native.y[:] = np.nan
        job.start()
        assert job.wait() == 0
        np.testing.assert_array_equal(native.y, direct)


def test_a_failing_function_returns_its_code(cache: Path) -> None:
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    source = (
        "int mmplan_fails(const double **a, double **r, void *iw, double *w, int m)"
        " { return 7; }\n"
    )
    path = cg.compile_source(source, "thr_fail")
    assert path is not None
    fn = ctypes.CDLL(path).mmplan_fails
    job = threads.Job(fn, None, None, None, None, 0)
    job.start()
    assert job.wait() == 7


def test_without_a_compiler_there_is_no_job(cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CC", "/nonexistent/cc")
    monkeypatch.setenv("PATH", "/nonexistent")
    assert threads.library() is None
    with pytest.raises(OSError):
        threads.Job(None, None, None, None, None, 0)


def test_the_helper_is_built_in_the_background_when_missing(cache: Path) -> None:
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    threads._PENDING.clear()
    assert not threads.ready()  # an empty cache
    threads.prefetch()
    assert len(threads._PENDING) == 1
    threads._PENDING.pop().join()
    assert threads.ready() and threads.library() is not None


def test_a_wait_without_a_start_has_no_result(cache: Path) -> None:
    """After a job's result was taken, another wait (no start between: an interrupted guess)
    returns -1, not the old code 0 that would count stale output as computed (review)."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    native = _native()
    job = threads.Job(*native.signature())
    assert job.done() and job.wait() == -1  # never started
    job.start()
    assert job.wait() == 0
    assert job.done() and job.wait() == -1


def test_a_core_is_idle_only_when_fewer_threads_are_ready_than_the_other_cores(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    for n, others, idle in ((2, 0.0, True), (2, 1.0, False), (4, 2.0, True), (4, 3.0, False),
                            (1, 0.0, False)):  # fmt: skip
        monkeypatch.setattr(threads, "cores", lambda n=n: n)
        monkeypatch.setattr(threads, "_others_running", lambda o=others: o)
        threads._IDLE_CHECK[0] = -1.0  # look again
        assert threads.idle_core() is idle, (n, others)
    threads._IDLE_CHECK[0] = -1.0


def _tasks() -> int:
    return len(os.listdir("/proc/self/task"))


@pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="needs Linux's /proc")
def test_one_worker_serves_every_job_and_a_busy_worker_means_here(cache: Path) -> None:
    """The process has one worker thread, kept between starts (it spins, then sleeps, for the
    next); a job started while another one is in flight is evaluated in the caller; results
    stay those of the direct call either way."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    first, second = _native(), _native()
    before = _tasks()
    jobs = [threads.Job(*first.signature()), threads.Job(*second.signature())]
    rng = np.random.default_rng(5)
    for i in range(20):
        x, z = rng.normal(size=4), rng.normal(size=4)
        first.x[:], second.x[:] = x, z
        want_x, want_z = first().copy(), second().copy()
        first.y[:] = second.y[:] = np.nan
        jobs[0].start()
        jobs[1].start()  # the worker is busy (or has just finished): here, or on it
        assert jobs[1].wait() == 0 and jobs[0].wait() == 0
        np.testing.assert_array_equal(first.y, want_x)
        np.testing.assert_array_equal(second.y, want_z)
        assert _tasks() <= before + 1
        if i == 10:
            time.sleep(3 * threads.SPIN_S)  # the worker sleeps now; a start wakes it
    for job in jobs:
        job.close()
        job.close()  # again: nothing
    assert _tasks() <= before + 1


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")
def test_a_forked_child_gets_its_own_worker(cache: Path) -> None:
    """The worker thread stays in the parent: a child's first start makes its own (else its
    wait would spin for a result no thread computes)."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    native = _native()
    job = threads.Job(*native.signature())
    native.x[:] = [0.3, -1.0, 0.5, 2.0]
    direct = native().copy()
    job.start()
    assert job.wait() == 0
    pid = os.fork()
    if pid == 0:  # the child: exit code 0 when its job computed the right values
        code = 1
        try:
            signal.alarm(20)  # a child that spins for ever is killed (the test fails)
            native.y[:] = np.nan
            job.start()
            code = 0 if job.wait() == 0 and np.array_equal(native.y, direct) else 1
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0
    job.start()  # the parent's worker still serves it
    assert job.wait() == 0


def test_a_job_started_twice_is_waited_for_and_the_worker_stays_free(cache: Path) -> None:
    """A second start before the wait waits for the first (found by review: it ran the job
    here on the buffers the worker was writing, and the worker stayed claimed for good)."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    native, other = _native(), _native()
    job, second = threads.Job(*native.signature()), threads.Job(*other.signature())
    native.x[:] = [0.1, 2.0, -0.3, 1.5]
    want = native().copy()
    native.y[:] = np.nan
    job.start()
    job.start()
    assert job.wait() == 0
    np.testing.assert_array_equal(native.y, want)
    lib = threads.library()
    assert lib is not None
    assert lib.start(second._job) == 1  # posted to the worker: it is free again
    assert second.wait() == 0


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")
def test_a_child_forked_while_the_worker_is_busy_gets_a_worker(cache: Path) -> None:
    """The worker claimed by a job in flight at the fork is free in the child (an atfork
    handler; found by review: the child's posts all ran in the caller)."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    native, other = _native(), _native()
    job, second = threads.Job(*native.signature()), threads.Job(*other.signature())
    other.x[:] = [0.7, 0.2, 0.1, -1.0]
    want = other().copy()
    lib = threads.library()
    assert lib is not None
    job.start()  # in flight (or just done) at the fork: the worker is claimed
    pid = os.fork()
    if pid == 0:
        code = 1
        try:
            signal.alarm(20)
            other.y[:] = np.nan
            posted = lib.start(second._job)
            ok = second.wait() == 0 and np.array_equal(other.y, want)
            code = 0 if ok and posted == 1 else 1
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert job.wait() == 0
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0


def test_a_process_that_exits_waits_for_the_helpers_build(tmp_path: Path) -> None:
    """A build started in the background is finished when the process exits (found by a
    new-user trial: `mmplan plan` exited first, so the helper never reached the disk). The
    process's own temporary folder registers the weakref finalizers' exit hook after the
    helper's: it runs first and, when the build used a TemporaryDirectory, removed the build's
    folder under the compiler (CI)."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    env = dict(os.environ, MMPLAN_CACHE=str(tmp_path))
    code = ("import tempfile; from mmplan.compile import threads; "
            "keep = tempfile.TemporaryDirectory(); "
            "threads.prefetch(); print(len(threads._PENDING))")  # fmt: skip
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=120, check=True)  # fmt: skip
    assert run.stdout.strip() == "1"  # started in the background, not finished
    assert list(tmp_path.glob(f"{threads.PREFIX}_*.so"))


def _stepper() -> cg.NativeFunction:
    """y = [x0 + x1, x1, x0 + x1 - 10]: a state x0 advanced by x1 a call, and an 'error'."""
    x = ca.SX.sym("x", 2)
    y = ca.vertcat(x[0] + x[1], x[1], x[0] + x[1] - 10.0)
    library = cg.compile_library([ca.Function("mmplan_thr_step", [x], [y])], "thr", ("-O0",))
    assert library is not None
    return cg.NativeFunction(library, "mmplan_thr_step")


def _chain(native: cg.NativeFunction, depth: int = 8) -> tuple[threads.Chain, np.ndarray,
                                                                np.ndarray]:  # fmt: skip
    X, Y = np.zeros((depth, 2)), np.zeros((depth, 3))
    follow = threads.Follow(src=0, dst=0, len=1, err_at=2, err_step=1, err_count=1)
    return threads.Chain(*native.signature(), X, Y, follow), X, Y


def test_a_chain_runs_ahead_from_each_output(cache: Path) -> None:
    """Slot i's input is slot i - 1's with the state replaced by its output; it ends at its
    limit, after a slot whose error falls below the stop, and when stopped; afterwards the
    function's own buffers are its direct calls' again."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    native = _stepper()
    chain, X, Y = _chain(native)
    X[0] = [0.0, 1.0]
    chain.start(5, -np.inf)
    assert [chain.slot(i) for i in range(5)] == [0] * 5
    assert chain.slot(5) == -2 and chain.ready(5)  # the limit
    np.testing.assert_array_equal(Y[:5, 0], [1.0, 2.0, 3.0, 4.0, 5.0])
    np.testing.assert_array_equal(X[:5, 0], [0.0, 1.0, 2.0, 3.0, 4.0])
    chain.stop()
    X[0] = [0.0, 3.0]
    chain.start(8, -6.5)  # errors -7, -4: ends after the first below -6.5
    assert chain.slot(0) == 0 and chain.slot(1) == -2
    chain.stop()
    native.x[:] = [2.0, 5.0]
    np.testing.assert_array_equal(native(), [7.0, 5.0, -3.0])  # not a slot's buffers
    X[0] = [0.0, 1.0]
    chain.start(8, -np.inf)
    chain.stop()  # waits for the call in flight: the buffers are the caller's again
    assert chain.slot(0) == -2 and chain.ready(0)
    np.testing.assert_array_equal(native(), [7.0, 5.0, -3.0])
    chain.close()
    assert chain.ready(0) and chain.slot(0) == -2


def test_a_speculation_that_follows_takes_every_chained_call(cache: Path) -> None:
    """Speculation with a follow rule: one guess, then each call at the following input is a
    chained slot (hits), the same outputs as direct calls; another input ends the chain."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    from mmplan.planners.extended_jacobian.prefetch import Speculation

    assert threads.library() is not None  # built now (a fresh cache): guesses need it
    native = _stepper()
    follow = threads.Follow(src=0, dst=0, len=1, err_at=2, err_step=1, err_count=1)
    spec = Speculation(native, enabled=True, follow=follow)
    spec.guess(np.array([0.0, 2.0]), ahead=4, stop=-np.inf)
    x = np.array([0.0, 2.0])
    for _ in range(5):
        y = spec.call(x)
        native.x[:] = x
        np.testing.assert_array_equal(y, native().copy())
        x = np.array([y[0], 2.0])
    assert (spec.hits, spec.misses) == (5, 0) and not spec.pending  # the limit: 1 + 4
    spec.guess(np.array([0.0, 2.0]), ahead=4, stop=-np.inf)
    spec.call(np.array([0.0, 2.0]))
    assert spec.pending
    np.testing.assert_array_equal(spec.call(np.array([9.0, 1.0])), [10.0, 1.0, 0.0])
    assert (spec.hits, spec.misses) == (6, 1) and not spec.pending


def test_call_rows_equals_a_call_per_row(cache: Path) -> None:
    """threads.call_rows: one C loop over the rows, the same bits as a call per row; the
    function's own buffers are its calls' again afterwards; False without the helper."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    native = _native()
    rows = np.random.default_rng(4).normal(size=(9, 4))
    assert not threads.call_rows(native.signature(), rows, np.empty((9, 3)))  # not on disk
    assert threads.library() is not None
    out = np.full((9, 3), np.nan)
    assert threads.call_rows(native.signature(), rows, out)
    for k in range(9):
        native.x[:] = rows[k]
        np.testing.assert_array_equal(native().copy(), out[k])


def test_a_job_keeps_the_function_buffers_and_a_closed_chain_does_not_start(
    cache: Path,
) -> None:
    """A Job made from a NativeFunction's signature keeps its argument and work buffers
    alive after the function is gone (found by review: the addresses owned nothing); a
    closed chain raises instead of passing NULL to C."""
    if cg.compiler() is None:
        pytest.fail("no C compiler on this machine")
    import gc
    import weakref

    assert threads.library() is not None
    native = _native()
    buffers = [weakref.ref(a) for a in (native._arg, native._res, native._iw, native._w)]
    job = threads.Job(*native.signature())
    del native
    gc.collect()
    assert all(ref() is not None for ref in buffers)
    del job
    gc.collect()
    assert all(ref() is None for ref in buffers)
    chain, _, _ = _chain(_stepper())
    chain.close()
    with pytest.raises(RuntimeError, match="closed"):
        chain.start(2, -np.inf)
