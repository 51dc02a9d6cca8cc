"""A generated function evaluated on a C thread while Python goes on (no interpreter lock).

A thread of Python's own would need the interpreter lock to start the call, and the thread
holding it gives it up only every ``sys.getswitchinterval()`` (5 ms) while it computes:
measured on youbot3r-obstacles-torque, a Python worker that ran the next compiled chunk
during the rollout's checks made the plan 2 ms slower, not faster. Here the call runs on a
POSIX thread started from C: :meth:`Job.start` returns at once, :meth:`Job.wait` joins it
(ctypes releases the lock while waiting). The few lines of C are compiled once per machine
(:func:`mmplan.compile.codegen.load_source`, about 0.2 s, in the background: :func:`prefetch`,
started by the first rollout that wants it, after the generator's own compile, which it
would otherwise slow) and cached with the other libraries; without threads a job runs inside
:meth:`Job.start` (same result, no overlap).
"""

from __future__ import annotations

import ctypes
import os
import threading
import time
from functools import lru_cache
from typing import Any

from mmplan.compile import codegen

FLAGS = ("-O2", "-pthread")
PREFIX = "threads"

SOURCE = r"""
#include <pthread.h>
#include <stdlib.h>

/* the signature of a function of CasADi's generated code (casadi_int passed as void*) */
typedef int (*mmplan_fn)(const double **arg, double **res, void *iw, double *w, int mem);

typedef struct {
    mmplan_fn f;
    const double **arg;
    double **res;
    void *iw;
    double *w;
    int mem;
    int ret;
    int running;
    pthread_t thread;
} mmplan_job;

static void *mmplan_job_run(void *p) {
    mmplan_job *j = (mmplan_job *)p;
    j->ret = j->f(j->arg, j->res, j->iw, j->w, j->mem);
    return NULL;
}

size_t mmplan_job_size(void) { return sizeof(mmplan_job); }

void mmplan_job_set(mmplan_job *j, void *f, void *arg, void *res, void *iw, void *w, int mem) {
    j->f = (mmplan_fn)f;
    j->arg = (const double **)arg;
    j->res = (double **)res;
    j->iw = iw;
    j->w = w;
    j->mem = mem;
    j->ret = -1;
    j->running = 0;
}

/* 1: running on its own thread; 0: no thread could start, evaluated here */
int mmplan_job_start(mmplan_job *j) {
    j->running = pthread_create(&j->thread, NULL, mmplan_job_run, j) == 0;
    if (!j->running) mmplan_job_run(j);
    return j->running;
}

int mmplan_job_wait(mmplan_job *j) {
    if (j->running) pthread_join(j->thread, NULL);
    j->running = 0;
    int ret = j->ret;
    j->ret = -1;  /* the next wait without a start has no result */
    return ret;
}
"""


def cores() -> int:
    """Cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


_IDLE_CHECK: list[float] = [-1.0, 0.0]  # [checked at (monotonic s), idle (0 or 1)]


def _others_running() -> float:
    """Threads running or ready to run on the machine now, besides the caller: the 4th field
    of /proc/loadavg less one; elsewhere the 1-minute load average."""
    try:
        with open("/proc/loadavg") as f:
            return float(int(f.read().split()[3].split("/")[0]) - 1)
    except (OSError, IndexError, ValueError):
        return os.getloadavg()[0] if hasattr(os, "getloadavg") else 0.0


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
        lib.mmplan_job_size.restype = ctypes.c_size_t
        self.size = int(lib.mmplan_job_size())
        vp = ctypes.c_void_p
        lib.mmplan_job_set.argtypes = [vp, vp, vp, vp, vp, vp, ctypes.c_int]
        lib.mmplan_job_set.restype = None
        lib.mmplan_job_start.argtypes = [vp]
        lib.mmplan_job_wait.argtypes = [vp]
        self.set, self.start = lib.mmplan_job_set, lib.mmplan_job_start
        self.wait = lib.mmplan_job_wait


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
    about 0.1 s; a caller that meets it unbuilt goes without it, :func:`ready`)."""
    if _PENDING or ready() or codegen.compiler() is None:
        return
    thread = threading.Thread(target=library, daemon=True)
    thread.start()
    _PENDING.append(thread)


class Job:
    """One call of a generated function with fixed buffers, run on a C thread.

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
        self._job = ctypes.create_string_buffer(lib.size)
        address = ctypes.cast(function, ctypes.c_void_p)
        lib.set(self._job, address, *(ctypes.cast(x, ctypes.c_void_p) for x in (arg, res, iw, w)),
                mem)  # fmt: skip
        self.running = False

    def start(self) -> None:
        """Evaluate on a new C thread (in this call when none can start)."""
        self._lib.start(self._job)
        self.running = True

    def wait(self) -> int:
        """Join the evaluation; the function's return code (0: success)."""
        self.running = False
        return int(self._lib.wait(self._job))
