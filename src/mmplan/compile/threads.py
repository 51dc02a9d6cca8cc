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
"""

from __future__ import annotations

import atexit
import ctypes
import os
import threading
import time
from functools import lru_cache
from typing import Any

from mmplan.compile import codegen

FLAGS = ("-O2", "-pthread")
PREFIX = "threads"

#: Seconds a worker spins for its next job before it sleeps (:data:`SOURCE`).
SPIN_S = 0.005

SOURCE = r"""
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <time.h>
#include <unistd.h>

enum { IDLE = 0, POSTED = 1, DONE = 2 };

/* The process's worker thread: one task at a time, claimed by its poster (busy). */
static struct {
    void (*task)(void *);
    void *data;
    atomic_int state;
    atomic_int busy;
    atomic_int spinning;
    int running;   /* the thread exists (in the process owner) */
    pid_t owner;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    pthread_t thread;
} W = {.mu = PTHREAD_MUTEX_INITIALIZER, .cv = PTHREAD_COND_INITIALIZER};

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void relax(void) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#elif defined(__aarch64__)
    __asm__ __volatile__("yield");
#endif
}

/* Spin SPIN_S seconds for the next task, then sleep until one is posted. */
static void next_task(void) {
    double until = now() + SPIN_S;
    int n = 0;
    atomic_store(&W.spinning, 1);
    while (atomic_load_explicit(&W.state, memory_order_acquire) != POSTED) {
        relax();
        if (++n % 256 == 0 && now() > until) break;
    }
    atomic_store(&W.spinning, 0);
    if (atomic_load_explicit(&W.state, memory_order_acquire) == POSTED) return;
    pthread_mutex_lock(&W.mu);
    while (atomic_load(&W.state) != POSTED) pthread_cond_wait(&W.cv, &W.mu);
    pthread_mutex_unlock(&W.mu);
}

static void *worker(void *unused) {
    (void)unused;
    for (;;) {
        next_task();
        W.task(W.data);
        atomic_store_explicit(&W.state, DONE, memory_order_release);
    }
    return NULL;
}

/* In a forked child: no worker thread (it stayed in the parent), a free worker slot, fresh
   lock and condition (the parent may have held them), and DONE for a task posted before the
   fork (its wait returns at once; the job's result code says it did not run). */
static void after_fork_child(void) {
    W.running = 0;
    atomic_store(&W.busy, 0);
    atomic_store(&W.spinning, 0);
    atomic_store(&W.state, DONE);
    pthread_mutex_init(&W.mu, NULL);
    pthread_cond_init(&W.cv, NULL);
}

static pthread_once_t at_fork_once = PTHREAD_ONCE_INIT;
static void register_at_fork(void) { pthread_atfork(NULL, NULL, after_fork_child); }

/* Post task(data) to the worker: 1 when posted (then mmplan_task_wait), 0 when the worker
   is another poster's now or no thread can start (the caller runs the task itself). */
int mmplan_task_post(void (*task)(void *), void *data) {
    if (atomic_exchange(&W.busy, 1)) return 0;
    if (W.running && W.owner != getpid()) {  /* a child whose atfork handler did not run */
        after_fork_child();
        atomic_store(&W.busy, 1);  /* still this caller's */
    }
    if (!W.running) {
        pthread_once(&at_fork_once, register_at_fork);
        atomic_store(&W.state, IDLE);
        W.owner = getpid();
        W.running = pthread_create(&W.thread, NULL, worker, NULL) == 0;
        if (W.running) pthread_detach(W.thread);
    }
    if (!W.running) {
        atomic_store(&W.busy, 0);
        return 0;
    }
    W.task = task;
    W.data = data;
    pthread_mutex_lock(&W.mu);
    atomic_store_explicit(&W.state, POSTED, memory_order_release);
    pthread_cond_signal(&W.cv);
    pthread_mutex_unlock(&W.mu);
    return 1;
}

/* Wait for the task posted last (by this caller) and release the worker. */
void mmplan_task_wait(void) {
    int n = 0;
    while (atomic_load_explicit(&W.state, memory_order_acquire) != DONE) {
        relax();
        if (++n % 4096 == 0) sched_yield();  /* the worker may be waiting for this CPU */
    }
    atomic_store(&W.state, IDLE);
    atomic_store(&W.busy, 0);
}

/* task(a) here and task(b) on the worker at the same time (both here, one after the other,
   when the worker is not free); returns when both are done. */
void mmplan_pair(void (*task)(void *), void *a, void *b) {
    int posted = mmplan_task_post(task, b);
    task(a);
    if (posted) mmplan_task_wait();
    else task(b);
}

int mmplan_spinning(void) { return atomic_load(&W.spinning); }

/* the signature of a function of CasADi's generated code (casadi_int passed as void*) */
typedef int (*mmplan_fn)(const double **arg, double **res, void *iw, double *w, int mem);

typedef struct mmplan_job mmplan_job;
int mmplan_job_wait(mmplan_job *j);

struct mmplan_job {
    mmplan_fn f;
    const double **arg;
    double **res;
    void *iw;
    double *w;
    int mem;
    int ret;
    int started;  /* a start whose wait has not come yet */
    int posted;   /* ... running on the worker */
};

static void job_run(void *p) {
    mmplan_job *j = (mmplan_job *)p;
    j->ret = j->f(j->arg, j->res, j->iw, j->w, j->mem);
}

mmplan_job *mmplan_job_new(void *f, void *arg, void *res, void *iw, void *w, int mem) {
    mmplan_job *j = (mmplan_job *)calloc(1, sizeof(mmplan_job));
    if (!j) return NULL;
    j->f = (mmplan_fn)f;
    j->arg = (const double **)arg;
    j->res = (double **)res;
    j->iw = iw;
    j->w = w;
    j->mem = mem;
    j->ret = -1;
    return j;
}

/* 1: posted to the worker; 0: evaluated here (the worker busy, or no thread). A job started
   again before its wait is waited for first (else it would run here while the worker runs it
   on the same buffers, and the worker would stay claimed). */
int mmplan_job_start(mmplan_job *j) {
    if (j->started) mmplan_job_wait(j);
    j->started = 1;
    j->posted = mmplan_task_post(job_run, j);
    if (!j->posted) job_run(j);
    return j->posted;
}

int mmplan_job_wait(mmplan_job *j) {
    if (!j->started) return -1;  /* no start since the last wait: no result */
    j->started = 0;
    if (j->posted) mmplan_task_wait();
    j->posted = 0;
    int ret = j->ret;
    j->ret = -1;
    return ret;
}

/* Waits for a job in flight, then frees it. */
void mmplan_job_free(mmplan_job *j) {
    if (!j) return;
    mmplan_job_wait(j);
    free(j);
}
""".replace("SPIN_S", repr(SPIN_S))


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
        lib.mmplan_spinning.argtypes = []
        #: Address of ``void mmplan_pair(void (*task)(void *), void *a, void *b)`` for other
        #: libraries' C (task(a) here, task(b) on the worker).
        self.pair = ctypes.cast(lib.mmplan_pair, ctypes.c_void_p).value
        self.new, self.free = lib.mmplan_job_new, lib.mmplan_job_free
        self.start, self.wait = lib.mmplan_job_start, lib.mmplan_job_wait
        self.spinning = lib.mmplan_spinning


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
    waits for that build when it exits (:func:`_finish_build`)."""
    if _PENDING or ready() or codegen.compiler() is None:
        return
    thread = threading.Thread(target=library, daemon=True)
    thread.start()
    _PENDING.append(thread)


def _finish_build() -> None:
    """At exit, wait for a build :func:`prefetch` started (about 0.1-0.2 s, once per machine):
    found by a new-user trial, ``mmplan plan`` ended its process before the build was done,
    so the helper was never on disk and no plan of the command used the second core (its
    warm plans 0.85x as fast without it)."""
    for thread in _PENDING:
        thread.join(timeout=30.0)


atexit.register(_finish_build)


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

    def close(self) -> None:
        """Wait for a job in flight and free the job (idempotent)."""
        job, self._job = self._job, None
        if job:
            self._lib.free(job)

    def __del__(self) -> None:
        if getattr(self, "_job", None):
            self.close()
