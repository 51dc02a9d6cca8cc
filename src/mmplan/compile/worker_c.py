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
#: Most calls a chain runs ahead (``mmplan_chain``).
CHAIN_DEPTH = 16

SOURCE = r"""
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <time.h>
#include <unistd.h>
#include <math.h>

#define MMPLAN_CHAIN_DEPTH @CHAIN_DEPTH@

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

/* A chain: the calls of one function at x_0, x_1, ... on the worker, one after the other,
   x_{i+1} being x_i with len values at dst replaced by y_i's at src (the state after a
   chunk of steps: the next chunk's start), into the rows of X and Y (slots). It ends after
   ``limit`` slots, a failed call, a slot whose values y[err_at + k err_step] (k < err_count)
   fall below ``stop`` (NaN ignored, as NumPy's min then is NaN and not below), or
   ``mmplan_chain_stop`` (checked between slots). The caller takes slot i when ``produced``
   > i; the worker writes nothing a taken slot holds, and the caller reads nothing the
   worker still writes. */
typedef struct {
    mmplan_fn f;
    const double **arg;
    double **res;
    void *iw;
    double *w;
    int mem;
    double *X, *Y;
    int nx, ny, depth, src, dst, len, err_at, err_step, err_count;
    double stop;
    int limit;
    atomic_int produced;
    atomic_int cancel;
    int ret[MMPLAN_CHAIN_DEPTH];
    int started, posted;
} mmplan_chain;

static void chain_run(void *p) {
    mmplan_chain *c = (mmplan_chain *)p;
    for (int i = 0; i < c->limit; i++) {
        if (atomic_load_explicit(&c->cancel, memory_order_acquire)) break;
        double *x = c->X + (long)i * c->nx, *y = c->Y + (long)i * c->ny;
        if (i > 0) {
            const double *before = c->X + (long)(i - 1) * c->nx;
            const double *out = c->Y + (long)(i - 1) * c->ny;
            for (int k = 0; k < c->nx; k++) x[k] = before[k];
            for (int k = 0; k < c->len; k++) x[c->dst + k] = out[c->src + k];
        }
        const double *arg0 = c->arg[0];
        double *res0 = c->res[0];
        c->arg[0] = x;
        c->res[0] = y;
        int r = c->f(c->arg, c->res, c->iw, c->w, c->mem);
        c->arg[0] = arg0;  /* the caller's own calls use them after the chain */
        c->res[0] = res0;
        c->ret[i] = r;
        atomic_store_explicit(&c->produced, i + 1, memory_order_release);
        if (r) break;
        int low = 0;
        for (int k = 0; k < c->err_count; k++)
            if (y[c->err_at + k * c->err_step] < c->stop) low = 1;
        int nan = 0;
        for (int k = 0; k < c->err_count; k++)
            if (isnan(y[c->err_at + k * c->err_step])) nan = 1;
        if (low && !nan) break;
    }
}

mmplan_chain *mmplan_chain_new(void *f, void *arg, void *res, void *iw, void *w, int mem,
                               double *X, double *Y, int nx, int ny, int depth, int src,
                               int dst, int len, int err_at, int err_step, int err_count) {
    if (depth < 1 || depth > MMPLAN_CHAIN_DEPTH) return NULL;
    mmplan_chain *c = (mmplan_chain *)calloc(1, sizeof(mmplan_chain));
    if (!c) return NULL;
    c->f = (mmplan_fn)f;
    c->arg = (const double **)arg;
    c->res = (double **)res;
    c->iw = iw;
    c->w = w;
    c->mem = mem;
    c->X = X; c->Y = Y; c->nx = nx; c->ny = ny; c->depth = depth;
    c->src = src; c->dst = dst; c->len = len;
    c->err_at = err_at; c->err_step = err_step; c->err_count = err_count;
    return c;
}

/* Ends the chain: no slot after the one running, which it waits for; releases the worker. */
void mmplan_chain_stop(mmplan_chain *c) {
    if (!c->started) return;
    atomic_store_explicit(&c->cancel, 1, memory_order_release);
    if (c->posted) mmplan_task_wait();
    c->started = 0;
    c->posted = 0;
}

/* Starts slots 0 .. limit - 1 from X's first row (stopping one in flight first): 1 when
   posted to the worker; 0 when the worker is busy or no thread starts: then slot 0 alone
   is computed here. */
int mmplan_chain_start(mmplan_chain *c, int limit, double stop) {
    mmplan_chain_stop(c);
    c->limit = limit < 1 ? 1 : (limit > c->depth ? c->depth : limit);
    c->stop = stop;
    atomic_store(&c->produced, 0);
    atomic_store(&c->cancel, 0);
    c->started = 1;
    c->posted = mmplan_task_post(chain_run, c);
    if (!c->posted) {
        c->limit = 1;
        chain_run(c);
    }
    return c->posted;
}

/* 1 when slot i is there or never will be (the chain is over): mmplan_chain_slot returns
   at once. */
int mmplan_chain_ready(mmplan_chain *c, int i) {
    if (!c->started || atomic_load_explicit(&c->produced, memory_order_acquire) > i) return 1;
    return !c->posted || atomic_load_explicit(&W.state, memory_order_acquire) == DONE;
}

/* Waits for slot i: its call's return code (0: success), or -2 when the chain ended before
   it (or is not running). */
int mmplan_chain_slot(mmplan_chain *c, int i) {
    int n = 0;
    if (!c->started) return -2;
    for (;;) {
        if (atomic_load_explicit(&c->produced, memory_order_acquire) > i) return c->ret[i];
        if (!c->posted || atomic_load_explicit(&W.state, memory_order_acquire) == DONE) {
            if (atomic_load_explicit(&c->produced, memory_order_acquire) > i) return c->ret[i];
            return -2;
        }
        relax();
        if (++n % 4096 == 0) sched_yield();
    }
}

/* A generated function of one dense input and a dense first output at count points, here:
   row k of ``in`` (nx values) in, row k of ``out`` (ny values) out; the first failed call's
   code, else 0. */
int mmplan_call_rows(void *f, void *arg, void *res, void *iw, void *w, int mem,
                     const double *in, int nx, double *out, int ny, int count) {
    const double **a = (const double **)arg;
    double **r = (double **)res;
    const double *arg0 = a[0];
    double *res0 = r[0];
    int ret = 0;
    for (int k = 0; k < count && !ret; k++) {
        a[0] = in + (long)k * nx;
        r[0] = out + (long)k * ny;
        ret = ((mmplan_fn)f)(a, r, iw, w, mem);
    }
    a[0] = arg0;
    r[0] = res0;
    return ret;
}

void mmplan_chain_free(mmplan_chain *c) {
    if (!c) return;
    mmplan_chain_stop(c);
    free(c);
}
""".replace("SPIN_S", repr(SPIN_S)).replace("@CHAIN_DEPTH@", str(CHAIN_DEPTH))

__all__ = ["CHAIN_DEPTH", "SOURCE", "SPIN_S"]
