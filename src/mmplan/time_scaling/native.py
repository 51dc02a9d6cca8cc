r"""The backward and forward passes of :mod:`.passes` as plain C loops.

The passes' arithmetic (:mod:`.passes` module docstring: oriented slabs, the projection of
every pair of slabs in the backward step, the greedy forward step) written once more as two
C functions over the whole path, compiled with the system compiler at first use and cached
on disk (:func:`mmplan.compile.codegen.compile_source`), called through ctypes.

Why not CasADi's generated code: the backward step projects every pair of its 2 n + 2 slabs
(496 pairs for youbot-3r's 15 rows), and the generated code of the mapped pair function
(:func:`.passes._mapped_backward_step`, used above 8 rows because gcc needs 28 s for the
straight-line version) spent 23-46 ns a pair (1.5 ms per 64 intervals, measured under load
2.4), where a loop spends about 2 (same operations, no per-call argument and work arrays).
The operations and their order are those of :func:`.passes.backward_step` and
:func:`.passes.forward_step`, so the results are the same to the bit
(tests/time_scaling/test_native.py compares them with the CasADi functions on the VM).
Builds in about 0.2 s instead of 1.75 s for the generated passes.

The backward step's pairs fall in two groups: those among the interval's own slabs and the
box on u (most of them: 528 of 561 for 16 rows), which do not depend on the recursion, and
the 2 n + 1 pairs with the slab of K_{i+1}. The first group runs for all intervals before
the recursion, split between this thread and the process's worker thread
(:mod:`mmplan.compile.threads`, ``mmplan_pair``) on paths of 64 intervals or more while a core
is idle (:func:`mmplan.compile.threads.idle_core`); max and min are exact and drop NaN in any
order, so the bounds are those of the one loop to the bit (tests). Measured on the paper
scenario's 606 intervals x 15 rows (``bench/bench_threads.py``): two threads 0.64-0.66x the
time of one with no other process running for the one-pair loop (session 6), 0.85-0.96x for
the vectorized loop below (session 7: the pass is shorter, the thread's start weighs more);
1.03-1.12x and 2.4-6x with one and two busy processes (a new thread waits for a time slice),
hence the gate.

The pairs of an interval's slab j with every later slab run as one loop over arrays that gcc
vectorizes (``pair_bounds``: -march=native, -fno-trapping-math, without which gcc keeps the
selects as branches and the loop scalar, and the dynamic cost model: -O3 gave the same speed
and compiled in 0.30 s instead of 0.22 s); each pair's bounds are folded into one
accumulator per later slab, and those into the interval's bounds at the end, which is exact in
any order as above. Measured on the paper scenario's four backward passes (606, 208, 120 and
119 intervals x 15 rows, both libraries in one process, 200 alternations): 0.53 of the one-pair
loop's time on two threads, 0.43 on one; the forward pass, unchanged, 0.95 (the flags).
"""

from __future__ import annotations

import ctypes
from functools import lru_cache

import numpy as np

from mmplan.arrays import Array
from mmplan.compile import codegen, threads
from mmplan.time_scaling import native_rounds

FLAGS = ("-O2", "-march=native", "-fno-trapping-math", "-fvect-cost-model=dynamic")
#: For a compiler that rejects one of :data:`FLAGS` (the loops then stay scalar; same bits).
FALLBACK = ("-O2",)
PREFIX = "topp_native"

SOURCE = r"""
#include <math.h>
#include <stdlib.h>

#define BIG 1e30
#define V_BOX 1e6
#define TOL 1e-9

typedef struct { double a, b, lo, hi; } slab;

/* CasADi's if_else(c, x, y) evaluates (c ? x : 0) + (c ? 0 : y): the chosen value plus +0.0,
   which turns -0.0 into +0.0 (and decides the sign of a division by a zero det) */
static double sel(int c, double x, double y) { return (c ? x : y) + 0.0; }
static double mn(double a, double b) { return sel(b < a, b, a); }  /* passes._min */
static double mx(double a, double b) { return sel(b > a, b, a); }  /* passes._max */

static slab oriented(double a, double b, double lo, double hi) {
    slab s;
    int flip = b < 0;
    s.a = sel(flip, -a, a);
    s.lo = sel(flip, -hi, lo);
    s.hi = sel(flip, -lo, hi);
    s.b = fabs(b);
    int zero = s.a == 0 && s.b == 0;
    s.lo = sel(zero && s.lo <= TOL, -BIG, s.lo);
    s.hi = sel(zero && s.hi >= -TOL, BIG, s.hi);
    return s;
}

/* the 2 n slabs of interval [i, i + 1]; returns delta */
static double interval(int n, int i, const double *alpha, const double *beta,
                       const double *g, const double *sigma, const double *zone, slab *out) {
    const double *lo = zone, *hi = zone + n;
    double delta = sigma[i + 1] - sigma[i];
    const double *a0 = alpha + (long)i * n, *b0 = beta + (long)i * n, *g0 = g + (long)i * n;
    const double *a1 = a0 + n, *b1 = b0 + n, *g1 = g0 + n;
    for (int k = 0; k < n; k++)
        out[k] = oriented(a0[k], 0.5 * b0[k], lo[k] - g0[k], hi[k] - g0[k]);
    for (int k = 0; k < n; k++)
        out[n + k] = oriented(a1[k], a1[k] * delta + 0.5 * b1[k], lo[k] - g1[k], hi[k] - g1[k]);
    return delta;
}

/* Bounds on x_i from every pair of the slabs that do not depend on the recursion (the 2 n
   slabs of interval i and the box on u), intervals [i0, i1), into pre_lo / pre_hi (with x_lo
   from 0 and x_hi from x_upper[i]). */
typedef struct {
    int n, i0, i1;
    const double *alpha, *beta, *g, *sigma, *x_upper, *zone;
    double *pre_lo, *pre_hi;
    int failed;
} fixed_job;

/* The bounds on x of the vertex of two slabs (passes._pair): of f and each slab k < count
   given as arrays (a, b, lo, hi), f the first of the pair when f_first, else the second;
   folded into acc_lo[k] by mx and acc_hi[k] by mn. A loop gcc vectorizes (-fno-trapping-math:
   the selects become blends; the divisions dominate, four a vector instruction with AVX2;
   f_first is the same for the whole loop); each lane does the operations of the one-pair
   code. The caller folds the accumulators into one bound at the end: max and min are exact
   and drop NaN in any order, so the bounds are those of the one loop to the bit. */
static void pair_bounds(slab f, int f_first, const double *restrict a,
                        const double *restrict b, const double *restrict lo,
                        const double *restrict hi, double *restrict acc_lo,
                        double *restrict acc_hi, int count) {
    for (int k = 0; k < count; k++) {
        double a1 = f_first ? f.a : a[k], b1 = f_first ? f.b : b[k];
        double lo1 = f_first ? f.lo : lo[k], hi1 = f_first ? f.hi : hi[k];
        double a2 = f_first ? a[k] : f.a, b2 = f_first ? b[k] : f.b;
        double lo2 = f_first ? lo[k] : f.lo, hi2 = f_first ? hi[k] : f.hi;
        double det = a1 * b2 - a2 * b1;
        double r1 = (lo1 * b2 - hi2 * b1) / det;
        double r2 = (hi1 * b2 - lo2 * b1) / det;
        int pos = det >= 0;
        double c_lo = (pos ? r1 : r2) + 0.0, c_hi = (pos ? r2 : r1) + 0.0;  /* sel */
        acc_lo[k] = (c_lo > acc_lo[k] ? c_lo : acc_lo[k]) + 0.0;  /* mx */
        acc_hi[k] = (c_hi < acc_hi[k] ? c_hi : acc_hi[k]) + 0.0;  /* mn */
    }
}

/* The slabs s[0 .. m) as arrays (v: room for 4 m numbers: a, b, lo, hi). */
static void arrays_of(const slab *s, int m, double *v) {
    for (int k = 0; k < m; k++) {
        v[k] = s[k].a; v[m + k] = s[k].b; v[2 * m + k] = s[k].lo; v[3 * m + k] = s[k].hi;
    }
}

static void fixed_pairs(void *arg) {
    fixed_job *J = (fixed_job *)arg;
    int n = J->n, m = 2 * n + 1;
    slab *s = malloc(sizeof(slab) * (size_t)m);
    double *v = malloc(sizeof(double) * 6 * (size_t)m);  /* a, b, lo, hi, acc_lo, acc_hi */
    if (!s || !v) { free(s); free(v); J->failed = 1; return; }
    double *a = v, *b = v + m, *lo = v + 2 * m, *hi = v + 3 * m, *acc_lo = v + 4 * m,
           *acc_hi = v + 5 * m;
    for (int i = J->i0; i < J->i1; i++) {
        interval(n, i, J->alpha, J->beta, J->g, J->sigma, J->zone, s);
        s[2 * n].a = 0.0; s[2 * n].b = 1.0; s[2 * n].lo = -V_BOX; s[2 * n].hi = V_BOX;
        arrays_of(s, m, v);
        double x_lo = 0.0, x_hi = J->x_upper[i];
        for (int k = 0; k < m; k++) { acc_lo[k] = x_lo; acc_hi[k] = x_hi; }
        for (int j = 0; j + 1 < m; j++)  /* the pairs (j, k > j) */
            pair_bounds(s[j], 1, a + j + 1, b + j + 1, lo + j + 1, hi + j + 1, acc_lo + j + 1,
                        acc_hi + j + 1, m - j - 1);
        for (int k = 1; k < m; k++) {
            x_lo = mx(x_lo, acc_lo[k]);
            x_hi = mn(x_hi, acc_hi[k]);
        }
        J->pre_lo[i] = x_lo;
        J->pre_hi[i] = x_hi;
    }
    free(s);
    free(v);
}

/* void mmplan_pair(task, a, b) of mmplan.compile.threads: task(a) here, task(b) on its worker */
typedef void (*pair_fn)(void (*task)(void *), void *a, void *b);

/* Intervals from which the fixed pairs are split between two threads. */
#define SPLIT_FROM 64

int mmplan_topp_backward(int n, int top, const double *alpha, const double *beta,
                         const double *g, const double *sigma, const double *x_upper,
                         const double *zone, double k_lo, double k_hi,
                         double *out_lo, double *out_hi, double *out_empty, void *pair) {
    int m = 2 * n + 2, count = top + 1;
    slab *s = malloc(sizeof(slab) * (size_t)m);
    double *pre = malloc(sizeof(double) * 2 * (size_t)(count > 0 ? count : 1));
    double *v = malloc(sizeof(double) * 6 * (size_t)m);
    if (!s || !pre || !v) { free(s); free(pre); free(v); return 1; }
    /* phase 1: the pairs without the recursion's slab, on two threads for long paths */
    fixed_job jobs[2];
    int parts = pair && count >= SPLIT_FROM ? 2 : 1, half = count / parts;
    for (int t = 0; t < parts; t++) {
        fixed_job J = {n, t * half, t + 1 == parts ? count : (t + 1) * half,
                       alpha, beta, g, sigma, x_upper, zone, pre, pre + count, 0};
        jobs[t] = J;
    }
    if (parts == 2) ((pair_fn)pair)(fixed_pairs, &jobs[0], &jobs[1]);
    else for (int t = 0; t < parts; t++) fixed_pairs(&jobs[t]);
    if (jobs[0].failed || (parts == 2 && jobs[1].failed)) {
        free(s); free(pre); free(v);
        return 1;
    }
    /* phase 2: the recursion, the pairs with slab 2n+1 = [1, delta] in [K_lo, K_hi] of i+1
       (max and min are exact and drop NaN whatever the order: the same bits as all pairs in
       one loop) */
    int r = m - 1;  /* the interval's slabs and the box, each paired with K_{i+1}'s */
    double *a = v, *b = v + r, *lo = v + 2 * r, *hi = v + 3 * r, *acc_lo = v + 4 * r,
           *acc_hi = v + 5 * r;
    for (int i = top; i >= 0; i--) {
        double delta = interval(n, i, alpha, beta, g, sigma, zone, s);
        s[2 * n].a = 0.0; s[2 * n].b = 1.0; s[2 * n].lo = -V_BOX; s[2 * n].hi = V_BOX;
        slab next = {1.0, delta, k_lo, k_hi};
        double x_lo = pre[i], x_hi = pre[count + i];
        arrays_of(s, r, v);
        for (int j = 0; j < r; j++) { acc_lo[j] = x_lo; acc_hi[j] = x_hi; }
        pair_bounds(next, 0, a, b, lo, hi, acc_lo, acc_hi, r);  /* the pairs (j, next) */
        for (int j = 0; j < r; j++) {
            x_lo = mx(x_lo, acc_lo[j]);
            x_hi = mn(x_hi, acc_hi[j]);
        }
        x_hi = mx(x_hi, -BIG);
        out_empty[i] = x_lo > x_hi + TOL * (1.0 + fabs(x_hi)) ? 1.0 : 0.0;
        k_lo = mx(mn(x_lo, x_hi), 0.0);
        k_hi = x_hi;
        out_lo[i] = k_lo;
        out_hi[i] = k_hi;
    }
    free(s);
    free(pre);
    free(v);
    return 0;
}

/* x_{i+1} of the greedy pass from x = x_i (s: room for the interval's 2 n slabs) */
static double forward_step(int n, int i, const double *alpha, const double *beta,
                           const double *g, const double *sigma, const double *x_upper,
                           const double *zone, const double *K_lo, const double *K_hi,
                           double x, slab *s) {
    int m = 2 * n;
    double delta = interval(n, i, alpha, beta, g, sigma, zone, s);
    double v_hi = (K_hi[i + 1] - x) / delta, v_lo = (K_lo[i + 1] - x) / delta;
    for (int k = 0; k < m; k++) {
        int use = s[k].b > 1e-14;
        double ax = s[k].a * x;
        v_hi = mn(v_hi, sel(use, (s[k].hi - ax) / s[k].b, BIG));
        v_lo = mx(v_lo, sel(use, (s[k].lo - ax) / s[k].b, -BIG));
    }
    double x_next = mn(mx(x + mx(v_hi, v_lo) * delta, K_lo[i + 1]), K_hi[i + 1]);
    return mn(mx(x_next, 0.0), x_upper[i + 1]);
}

int mmplan_topp_forward(int n, int N, const double *alpha, const double *beta,
                        const double *g, const double *sigma, const double *x_upper,
                        const double *zone, const double *K_lo, const double *K_hi,
                        double x, double *out_x) {
    slab *s = malloc(sizeof(slab) * (size_t)(n > 0 ? 2 * n : 1));
    if (!s) return 1;
    for (int i = 0; i + 1 < N; i++) {
        x = forward_step(n, i, alpha, beta, g, sigma, x_upper, zone, K_lo, K_hi, x, s);
        out_x[i] = x;
    }
    free(s);
    return 0;
}
""" + native_rounds.SOURCE


class Kernels:
    """The compiled passes of one loaded library (:func:`kernels`)."""

    def __init__(self, lib: ctypes.CDLL) -> None:
        self._bw, self._fw = lib.mmplan_topp_backward, lib.mmplan_topp_forward
        self._bw.restype = self._fw.restype = ctypes.c_int
        # declared arguments: arrays go in as their addresses (ints), without a ctypes
        # pointer object each (72 a plan: ~0.2 ms of the time scaling, measured)
        i, d, p = ctypes.c_int, ctypes.c_double, ctypes.c_void_p
        self._bw.argtypes = [i, i, p, p, p, p, p, p, d, d, p, p, p, p]
        self._fw.argtypes = [i, i, p, p, p, p, p, p, p, p, d, p]
        #: Split the backward pass's fixed pairs over two threads when a core is idle.
        self.split = True
        #: The re-timing rounds (:mod:`.native_rounds`).
        self.rounds = native_rounds.Rounds(lib)

    def pair(self) -> int | None:
        """The thread helper's ``mmplan_pair`` for a backward pass now (None: one thread)."""
        return _pair() if self.split and threads.idle_core() else None

    def backward(
        self, alpha: Array, beta: Array, g: Array, sigma: Array, x_upper: Array, zone: Array,
        last: tuple[float, float], top: int,
    ) -> tuple[Array, Array, Array]:
        """K_lo, K_hi and empty flags (1.0 / 0.0) of intervals 0 .. ``top`` (as
        :func:`.passes.backward` with ``start`` = top)."""
        n = alpha.shape[1]
        out = np.empty((3, top + 1))
        arrays = _contiguous(alpha, beta, g, sigma, x_upper, zone)  # alive during the call
        pair = self.pair()
        base, row = out.ctypes.data, out.strides[0]
        status = self._bw(n, top, *[a.ctypes.data for a in arrays], last[0], last[1],
                          base, base + row, base + 2 * row, pair)  # fmt: skip
        if status != 0:
            raise MemoryError("time scaling: no memory for the backward pass")
        return out[0], out[1], out[2]

    def forward(
        self, alpha: Array, beta: Array, g: Array, sigma: Array, x_upper: Array, zone: Array,
        K_lo: Array, K_hi: Array, x_start: float,
    ) -> Array:
        """x_1 .. x_{N-1} (as :func:`.passes.forward`)."""
        N, n = alpha.shape
        x = np.empty(max(N - 1, 0))
        arrays = _contiguous(alpha, beta, g, sigma, x_upper, zone, K_lo, K_hi)
        status = self._fw(n, N, *[a.ctypes.data for a in arrays], x_start, x.ctypes.data)
        if status != 0:
            raise MemoryError("time scaling: no memory for the forward pass")
        return x


def _pair() -> int | None:
    """Address of the thread helper's ``mmplan_pair`` (None while it is not loaded: the pass
    then runs on one thread; :func:`mmplan.compile.threads.prefetch` builds it)."""
    if not threads.ready():
        threads.prefetch()
        return None
    lib = threads.library()
    return None if lib is None else lib.pair


def _contiguous(*arrays: Array) -> list[Array]:
    return [np.ascontiguousarray(a, dtype=np.float64) for a in arrays]


@lru_cache(maxsize=1)
def kernels() -> Kernels | None:
    """The compiled passes (built at first use, then loaded from the disk cache); None
    without a compiler or when the build fails (the callers keep the CasADi VM)."""
    return codegen.load_source(SOURCE, PREFIX, FLAGS, Kernels, FALLBACK)


def loaded() -> Kernels | None:
    """The compiled passes when this process has loaded them already (never a build or a
    load: callers with a NumPy path of their own, e.g. :meth:`.rates.RateModel.path_rows`)."""
    return kernels() if kernels.cache_info().currsize else None
