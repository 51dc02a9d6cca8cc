"""The C of the process's worker thread (:mod:`mmplan.compile.threads` loads it).

One worker thread per process runs one task at a time for a caller that claimed it
(``mmplan_task_post`` / ``mmplan_task_wait``, ``mmplan_pair``: a task here and one on the
worker), and calls of CasADi-generated functions (``mmplan_job_*``). It spins :data:`SPIN_S`
for its next task, then sleeps on a condition variable; a forked child gets a worker of its
own (``pthread_atfork``). Why a worker that spins and not a thread per task:
:mod:`mmplan.compile.threads`.
"""

from __future__ import annotations

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

/* 1 when the job's evaluation is over (its wait returns at once), 0 while the worker runs it. */
int mmplan_job_done(mmplan_job *j) {
    if (!j->started || !j->posted) return 1;
    return atomic_load_explicit(&W.state, memory_order_acquire) == DONE;
}

/* Waits for a job in flight, then frees it. */
void mmplan_job_free(mmplan_job *j) {
    if (!j) return;
    mmplan_job_wait(j);
    free(j);
}
""".replace("SPIN_S", repr(SPIN_S))

__all__ = ["SOURCE", "SPIN_S"]
