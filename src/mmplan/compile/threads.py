"""A generated function evaluated on a C thread while Python goes on (no interpreter lock).

A thread of Python's own would need the interpreter lock to start the call, and the thread
holding it gives it up only every ``sys.getswitchinterval()`` (5 ms) while it computes:
measured on youbot3r-obstacles-torque, a Python worker that ran the next compiled chunk
during the rollout's checks made the plan 2 ms slower, not faster. Here the call runs on a
POSIX thread of C: :meth:`Job.start` posts it and returns at once, :meth:`Job.wait` waits
for it (ctypes releases the lock while waiting). The few lines of C are compiled once per
machine (:func:`mmplan.compile.codegen.load_source`, about 0.2 s, in the background:
:func:`prefetch`, started by the first rollout that wants it, after the generator's own
compile, which it would otherwise slow) and cached with the other libraries; without threads
a job runs inside :meth:`Job.start` (same result, no overlap).

One worker thread per process, not a thread per start. Linux queues a new thread on its
creator's CPU and moves it only when that CPU idles or the balancer runs, and a sleeping
thread woken on an idle CPU of a virtual machine waits for its virtual CPU to be scheduled.
Measured on the 2-core VM (a 0.59 ms chunk started on a thread, then 0.6 ms of Python on the
caller): with ``pthread_create`` per start the result came 0.61 ms after the Python (the
thread had waited for the caller's CPU: 1.2 ms in all); with the thread placed on the other
CPU at creation, the rollout's waits for its chunks grew from 4.7 to 9.7 ms a plan (the idle
CPU's wake-up); with the worker spinning :data:`SPIN_S` for its next job (the rollout posts
one every 0.5-1 ms) the result is there 0.002 ms after the Python, and the rollout's waits
fell to 2.8 ms a plan. After :data:`SPIN_S` without a job the worker sleeps on a condition
variable; its spinning is not counted as the machine's load (:func:`idle_core`). The time
scaling's backward pass splits its work with the same worker (``mmplan_pair``,
:attr:`_Library.pair`): with a thread of its own it had to share the two CPUs with the
spinning worker (measured: 2.7-3.9 ms a plan instead of 1.5).

A :class:`Chain` is a run of calls on the worker, each next input made in C from the last
output (the rollout's chunks, each starting where the last one ended: the worker never waits
for the caller between two of them; :mod:`mmplan.planners.extended_jacobian.prefetch`).
:func:`call_rows` calls a generated function at many points in one C loop (no thread).
"""

from __future__ import annotations

import ctypes
import os
import threading
import time
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from mmplan.compile import codegen
from mmplan.compile.worker_c import CHAIN_DEPTH, SOURCE, SPIN_S

FLAGS = ("-O2", "-pthread")
PREFIX = "threads"


def cores() -> int:
    """Cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


_IDLE_CHECK: list[float] = [-1.0, 0.0]  # [checked at (monotonic s), idle (0 or 1)]


def _others_running() -> float:
    """Threads running or ready to run on the machine now, besides the caller and this
    process's workers spinning for their next job (:data:`SPIN_S`): the 4th field of
    /proc/loadavg less those; elsewhere the 1-minute load average."""
    try:
        with open("/proc/loadavg") as f:
            running = int(f.read().split()[3].split("/")[0])
    except (OSError, IndexError, ValueError):
        return os.getloadavg()[0] if hasattr(os, "getloadavg") else 0.0
    lib = library() if library.cache_info().currsize else None
    return float(running - 1 - (int(lib.spinning()) if lib is not None else 0))


def idle_core() -> bool:
    """A core is free for a helper thread beside the caller's: two or more cores and fewer
    other threads ready to run than the cores less one (looked up at most every 0.25 s).
    With every core busy a new thread waits for a time slice beside the other processes:
    measured (``bench/bench_threads.py``, three runs) the rollout's guessed chunks made plans
    1.06-1.35x slower and the two-thread backward pass 1.03-2.8x slower with one or two busy
    processes, against 0.84-0.91x and 0.65-0.66x with none. The count of threads ready now,
    not the load average: a short command's own load is not in the average yet, a
    long-running loop's is."""
    now = time.monotonic()
    if now - _IDLE_CHECK[0] > 0.25:
        n = cores()
        _IDLE_CHECK[0], _IDLE_CHECK[1] = now, float(n >= 2 and _others_running() <= n - 2)
    return _IDLE_CHECK[1] > 0.0


class _Library:
    def __init__(self, lib: ctypes.CDLL) -> None:
        vp = ctypes.c_void_p
        lib.mmplan_job_new.argtypes = [vp, vp, vp, vp, vp, ctypes.c_int]
        lib.mmplan_job_new.restype = vp
        lib.mmplan_job_free.argtypes = [vp]
        lib.mmplan_job_free.restype = None
        lib.mmplan_job_start.argtypes = [vp]
        lib.mmplan_job_wait.argtypes = [vp]
        lib.mmplan_job_done.argtypes = [vp]
        lib.mmplan_spinning.argtypes = []
        i, d = ctypes.c_int, ctypes.c_double
        lib.mmplan_chain_new.argtypes = [vp, vp, vp, vp, vp, i, vp, vp, *[i] * 9]
        lib.mmplan_chain_new.restype = vp
        lib.mmplan_chain_start.argtypes = [vp, i, d]
        lib.mmplan_chain_stop.argtypes = [vp]
        lib.mmplan_chain_stop.restype = None
        lib.mmplan_chain_ready.argtypes = [vp, i]
        lib.mmplan_chain_slot.argtypes = [vp, i]
        lib.mmplan_chain_free.argtypes = [vp]
        lib.mmplan_chain_free.restype = None
        lib.mmplan_call_rows.argtypes = [vp, vp, vp, vp, vp, i, vp, i, vp, i, i]
        #: ``mmplan_call_rows``: a generated function at many points in one call
        #: (:func:`call_rows`).
        self.call_rows = lib.mmplan_call_rows
        #: Address of ``void mmplan_pair(void (*task)(void *), void *a, void *b)`` for other
        #: libraries' C (task(a) here, task(b) on the worker).
        self.pair = ctypes.cast(lib.mmplan_pair, ctypes.c_void_p).value
        self.new, self.free = lib.mmplan_job_new, lib.mmplan_job_free
        self.start, self.wait = lib.mmplan_job_start, lib.mmplan_job_wait
        self.done = lib.mmplan_job_done
        self.spinning = lib.mmplan_spinning
        self.chain_new, self.chain_free = lib.mmplan_chain_new, lib.mmplan_chain_free
        self.chain_start, self.chain_stop = lib.mmplan_chain_start, lib.mmplan_chain_stop
        self.chain_ready, self.chain_slot = lib.mmplan_chain_ready, lib.mmplan_chain_slot


@lru_cache(maxsize=1)
def library() -> _Library | None:
    """The compiled helper (built at first use, then from the disk cache); None without a
    compiler or when it does not build."""
    return codegen.load_source(SOURCE, PREFIX, FLAGS, _Library)


_PENDING: list[threading.Thread] = []


def ready() -> bool:
    """The helper can be loaded without a build (on disk, or loaded already)."""
    if library.cache_info().currsize:
        return library() is not None
    return codegen.compiler() is not None and codegen.source_is_cached(SOURCE, PREFIX, FLAGS)


def prefetch() -> None:
    """Build the helper in a background thread when it is not on disk (once per machine,
    about 0.1 s; a caller that meets it unbuilt goes without it, :func:`ready`). The process
    waits for that build when it exits (:func:`mmplan.compile.codegen.in_background`)."""
    if _PENDING or ready() or codegen.compiler() is None:
        return
    _PENDING.append(codegen.in_background(library))


class Job:
    """One call of a generated function with fixed buffers, run by the process's worker
    thread of C (:data:`SOURCE`; started by the first post, it spins for :data:`SPIN_S` after
    each task for the next one, the rollout posts one every 0.5-1 ms, then sleeps until one
    comes). While the worker runs another caller's task, :meth:`start` evaluates here.

    Args:
        function: The ctypes function (``casadi`` generated signature).
        arg, res, iw, w: Its argument and work arrays (kept alive by the caller).
        mem: Its checked-out memory.
    """

    def __init__(self, function: Any, arg: Any, res: Any, iw: Any, w: Any, mem: int) -> None:
        lib = library()
        if lib is None:
            raise OSError("no thread helper")
        self._lib = lib
        address = ctypes.cast(function, ctypes.c_void_p)
        pointers = (ctypes.cast(x, ctypes.c_void_p) for x in (arg, res, iw, w))
        self._job: int | None = lib.new(address, *pointers, mem)
        if not self._job:
            raise OSError("no memory for a job")
        self._keep = (function, arg, res, iw, w)  # the worker reads them until close
        self.running = False

    def start(self) -> None:
        """Post the evaluation to the worker thread (evaluated in this call when the worker is
        busy or no thread can start)."""
        self._lib.start(self._job)
        self.running = True

    def wait(self) -> int:
        """Wait for the evaluation; the function's return code (0: success; -1: no start
        since the last wait)."""
        self.running = False
        return int(self._lib.wait(self._job))

    def done(self) -> bool:
        """The evaluation is over (:meth:`wait` returns at once); True once closed."""
        return self._job is None or bool(self._lib.done(self._job))

    def close(self) -> None:
        """Wait for a job in flight and free the job (idempotent)."""
        job, self._job = self._job, None
        if job:
            self._lib.free(job)

    def __del__(self) -> None:
        if getattr(self, "_job", None):
            self.close()


def call_rows(signature: tuple[Any, ...], inputs: Any, out: Any) -> bool:
    """A generated function of one dense input and a dense output (``signature``: the
    function and its arg, res, iw, w, mem, as :class:`Job`'s) at each row of ``inputs``
    (count, nx) into the rows of ``out`` (count, ny), both C-contiguous float64, in one C
    loop; False when the helper is not on disk (nothing computed; never built here).
    Raises RuntimeError when a call fails."""
    lib = library() if ready() else None
    if lib is None:
        return False
    function, arg, res, iw, w, mem = signature
    address = ctypes.cast(function, ctypes.c_void_p).value
    code = lib.call_rows(address, arg, res, iw, w, mem, inputs.ctypes.data, inputs.shape[1],
                         out.ctypes.data, out.shape[1], len(inputs))  # fmt: skip
    if code:
        raise RuntimeError("compiled function failed")
    return True


@dataclass(frozen=True)
class Follow:
    """How a :class:`Chain`'s next input follows from its last call: x_{i+1} is x_i with
    ``len`` values at ``dst`` replaced by y_i's at ``src``; the chain ends after a call whose
    values y[err_at + k err_step] (k < err_count) fall below its ``stop`` (NaN ignored)."""

    src: int
    dst: int
    len: int
    err_at: int
    err_step: int
    err_count: int


class Chain:
    """Calls of one generated function run ahead on the worker thread (``mmplan_chain`` of
    :data:`SOURCE`): :meth:`start` from an input, then each next input follows from the
    last output (:class:`Follow`), up to ``depth`` calls, into the rows of ``X`` and ``Y``.
    A compiled rollout chunk's next call starts where the last one ended, so the worker
    runs the chunks one after the other while the caller checks them: no wait for the
    caller between two chunks. While the worker runs another caller's task, the first call
    is evaluated in :meth:`start` and the chain ends there.

    Args:
        function, arg, res, iw, w, mem: As :class:`Job` (arg[0] and res[0] are set to the
            slot's rows).
        X, Y: The slots' inputs and outputs (depth, nx) and (depth, ny), C-contiguous,
            kept alive by the caller until :meth:`close`.
        follow: The next input's rule.
    """

    def __init__(self, function: Any, arg: Any, res: Any, iw: Any, w: Any, mem: int,
                 X: Any, Y: Any, follow: Follow) -> None:  # fmt: skip
        lib = library()
        if lib is None:
            raise OSError("no thread helper")
        self._lib = lib
        depth, nx = X.shape
        address = ctypes.cast(function, ctypes.c_void_p)
        pointers = (ctypes.cast(x, ctypes.c_void_p) for x in (arg, res, iw, w))
        f = follow
        self._job: int | None = lib.chain_new(
            address, *pointers, mem, X.ctypes.data, Y.ctypes.data, nx, Y.shape[1], depth,
            f.src, f.dst, f.len, f.err_at, f.err_step, f.err_count,
        )  # fmt: skip
        if not self._job:
            raise OSError("no memory for a chain (or depth above CHAIN_DEPTH)")
        self._keep = (function, arg, res, iw, w, X, Y)  # the worker reads them until close
        self.running = False

    def start(self, limit: int, stop: float) -> bool:
        """Calls from X[0] (at most ``limit``; ``stop``: :class:`Follow`), after ending a
        chain in flight; False when the worker was busy: slot 0 alone was computed here."""
        if not self._job:
            raise RuntimeError("the chain is closed")
        self.running = True
        return bool(self._lib.chain_start(self._job, limit, stop))

    def ready(self, i: int) -> bool:
        """Slot i is there or never will be (:meth:`slot` returns at once)."""
        return self._job is None or bool(self._lib.chain_ready(self._job, i))

    def slot(self, i: int) -> int:
        """Wait for slot i: its call's return code (0: success), -2 when the chain ended
        before it."""
        return int(self._lib.chain_slot(self._job, i)) if self._job else -2

    def stop(self) -> None:
        """End the chain (waits for the call in flight) and free the worker."""
        if self._job:
            self._lib.chain_stop(self._job)
        self.running = False

    def done(self) -> bool:
        """No call is running (nor will one start)."""
        return not self.running

    def close(self) -> None:
        """Stop and free the chain (idempotent)."""
        job, self._job = self._job, None
        if job:
            self._lib.chain_free(job)
        self.running = False

    def __del__(self) -> None:
        if getattr(self, "_job", None):
            self.close()


__all__ = ["CHAIN_DEPTH", "FLAGS", "PREFIX", "SOURCE", "SPIN_S", "Chain", "Follow", "Job",
           "call_rows", "cores", "idle_core", "library", "prefetch", "ready"]
