r"""The tightening rounds of :func:`.retime.retime_path` as one C function.

A re-timing under rate limits runs the time-optimal scaling, measures the interpolant's peaks
on every step, tightens the rows of the steps over a limit and runs again (:mod:`.retime`,
1-4 rounds on the youBot scenarios). Each round is three compiled calls (the backward and
forward passes of :mod:`.native`, the step peaks of :mod:`.native_peaks`) and some forty
NumPy operations around them: building the rows, the controllable set of the last sample,
the times, the real-time dq and ddq, the stall test and the tightening. Measured on
youbot3r-obstacles-torque (4 rounds, 607 samples): 4.6 ms a re-timing, of which 2.2 ms in
the compiled calls; the rest was Python and NumPy. Here the whole loop is one C call (it is
compiled into the passes' library and calls the step peaks through their address).

The operations and their order are those of :func:`.retime.retime_path`,
:func:`.topp.scaling_with_sets` (with the reuse of the controllable sets after the last
tightened sample) and :func:`.retime._tighten`, with NumPy's NaN rules for minimum, maximum
and max (``np_min``, ``np_max``), so the results are the same to the bit
(tests/time_scaling/test_native_rounds.py compares every output with the NumPy loop, which
stays the specification and the fallback without a compiler).
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mmplan.arrays import Array

#: C of the rounds; compiled with the passes (:data:`.native.SOURCE`), whose ``interval``,
#: ``mmplan_topp_backward`` and ``mmplan_topp_forward`` it calls.
SOURCE = r"""
/* np.minimum / np.maximum: NaN propagates */
static double np_min(double a, double b) { return (a <= b || isnan(a)) ? a : b; }
static double np_max(double a, double b) { return (a >= b || isnan(a)) ? a : b; }

typedef void (*peaks_fn)(int N, int n, const double *t, const double *q, const double *dq,
                         int m, const int *kind, const int *j1, const int *j2,
                         const double *limit, double *out);

/* np.max(a, initial=0.0) */
static double max_of(const double *a, long count) {
    double out = 0.0;
    for (long k = 0; k < count; k++) {
        if (isnan(a[k])) return NAN;
        if (a[k] > out) out = a[k];
    }
    return out;
}

/* topp._last_set; returns 0 when the set is empty */
static int last_set(int R, const double *a, const double *g, const double *zone,
                    double x_max, double *k_lo, double *k_hi) {
    double lo_max = -BIG, hi_min = BIG;
    int lo_nan = 0, hi_nan = 0, bad = 0;
    for (int k = 0; k < R; k++) {
        double c_lo = zone[k] - g[k], c_hi = zone[R + k] - g[k];
        int ok = fabs(a[k]) > 1e-14;
        double safe = ok ? a[k] : 1.0;
        double r1 = c_lo / safe, r2 = c_hi / safe;
        if (ok) {
            double lo = np_min(r1, r2), hi = np_max(r1, r2);
            if (isnan(lo)) lo_nan = 1; else if (lo > lo_max) lo_max = lo;
            if (isnan(hi)) hi_nan = 1; else if (hi < hi_min) hi_min = hi;
        } else if (c_lo > TOL || c_hi < -TOL) {
            bad = 1;
        }
    }
    double m_lo = lo_nan ? NAN : lo_max, m_hi = hi_nan ? NAN : hi_min;
    double x_lo = m_lo > 0.0 ? m_lo : 0.0;            /* max(0.0, m_lo) */
    double x_hi = m_hi < x_max ? m_hi : x_max;        /* min(x_max, m_hi) */
    if (bad || x_lo > x_hi + TOL * (1.0 + fabs(x_hi))) return 0;
    double low = x_hi < x_lo ? x_hi : x_lo;           /* min(x_lo, x_hi) */
    *k_lo = 0.0 > low ? 0.0 : low;                    /* max(., 0.0) */
    *k_hi = x_hi;
    return 1;
}

/* rates.RateModel.path_rows: the bound of x from the velocity quantities (limit2: their
   limits squared; x_upper from inf, np.minimum in their order) and the acceleration rows
   (a one-coordinate row copies q'' and q'; a side of the planar polygon is c a_i + s a_j). */
void mmplan_path_rows(int N, int n, int nq, const int *kind, const int *j1, const int *j2,
                      const double *limit2, int m, const int *row_i, const int *row_j,
                      const double *row_c, const double *row_s, const double *dq,
                      const double *ddq, double *x_upper, double *alpha, double *beta) {
    for (int k = 0; k < N; k++) {
        const double *v = dq + (long)k * n, *a = ddq + (long)k * n;
        double up = INFINITY;
        for (int i = 0; i < nq; i++) {
            if (kind[i] != 0) continue;
            double speed2 = v[j1[i]] * v[j1[i]];
            if (j2[i] >= 0) speed2 = speed2 + v[j2[i]] * v[j2[i]];
            up = np_min(up, speed2 > 0.0 ? limit2[i] / speed2 : INFINITY);
        }
        x_upper[k] = up;
        for (int r = 0; r < m; r++) {
            long at = (long)k * m + r;
            if (row_j[r] < 0) {
                alpha[at] = a[row_i[r]];
                beta[at] = v[row_i[r]];
            } else {
                alpha[at] = row_c[r] * a[row_i[r]] + row_s[r] * a[row_j[r]];
                beta[at] = row_c[r] * v[row_i[r]] + row_s[r] * v[row_j[r]];
            }
        }
    }
}

/* rates.RateModel.ratios: value / limit of every quantity at every sample, (N, nq). */
void mmplan_rate_ratios(int N, int n, int nq, const int *kind, const int *j1, const int *j2,
                        const double *limit, const double *dq, const double *ddq, double *out) {
    for (int k = 0; k < N; k++)
        for (int i = 0; i < nq; i++) {
            const double *m = (kind[i] == 0 ? dq : ddq) + (long)k * n;
            double value = j2[i] < 0 ? fabs(m[j1[i]]) : hypot(m[j1[i]], m[j2[i]]);
            out[(long)k * nq + i] = value / limit[i];
        }
}

/* time_scaling.step_residuals: max over coordinates (NaN ignored, from 0) of the step's
   |(q+ - q) / h - (dq + dq+) / 2|, (N - 1). */
void mmplan_step_residuals(int N, int n, const double *t, const double *q, const double *dq,
                           double *out) {
    for (int k = 0; k + 1 < N; k++) {
        double h = t[k + 1] - t[k], best = 0.0;
        for (int j = 0; j < n; j++) {
            long i = (long)k * n + j;
            double r = fabs((q[i + n] - q[i]) / h - 0.5 * (dq[i + n] + dq[i]));
            if (r > best) best = r;  /* np.nanmax: NaN ignored */
        }
        out[k] = best;
    }
}

/* Returns 0, 1 without memory or when a pass failed, 2 when x is unbounded or x_upper < 0
   at some sample (the caller raises as topp._upper). out_int: rounds, feasible,
   first_empty (-1: none), peaks computed. */
int mmplan_retime_rounds(
    int N, int n, int e, int r, int nq,
    const double *sigma, const double *q, const double *dq_ds, const double *ddq_ds2,
    const double *fixed_alpha, const double *fixed_beta, const double *g_all,
    const double *rate_alpha, const double *rate_beta, const double *rate_x_upper,
    const double *lo_all, const double *hi_all,
    const int *owner, const int *kind, const int *j1, const int *j2, const double *limit,
    double w_max, int given_start, double x_start, int max_rounds, double overshoot,
    double stall, void *pair, void *peaks_address,
    double *x, double *v, double *t, double *dq, double *ddq, double *peaks,
    int *out_int, double *out_ratio) {
    peaks_fn peaks_of = (peaks_fn)peaks_address;
    int R = e + r;
    long NR = (long)N * R, Nr = (long)N * r, P = (long)(N - 1) * nq;
    double *work = malloc(sizeof(double) * (size_t)(2 * NR + 2 * Nr + 14 * (long)N + 2 * R
                                                     + P + 1));
    slab *slabs = malloc(sizeof(slab) * (size_t)(R > 0 ? 2 * R : 1));
    if (!work || !slabs) { free(work); free(slabs); return 1; }
    double *alpha = work, *beta = alpha + NR, *tight = beta + NR, *before_tight = tight + Nr;
    double *x_up = before_tight + Nr, *x_cap = x_up + N, *before_cap = x_cap + N;
    double *K_lo = before_cap + N, *K_hi = K_lo + N, *set_lo = K_hi + N, *set_hi = set_lo + N;
    double *empty = set_hi + N, *share = empty + N, *w = share + N, *v_at = w + N;
    double *zone = v_at + N, *previous = zone + 2 * R, *old_x = previous + P + 1;
    double *old_lo = old_x + N, *old_hi = old_lo + N;
    int status = 0, rounds = 0, reuse = -1, have_previous = 0, feasible = 0, first_empty = -1;
    int rows_first = 0, rows_last = N - 1;  /* samples whose rows the last tightening changed */
    int with_peaks = 0;
    double ratio = 0.0, w2 = pow(w_max, 2.0);
    for (long k = 0; k < Nr; k++) tight[k] = 1.0;
    for (int k = 0; k < N; k++) x_cap[k] = 1.0;
    for (int k = 0; k < R; k++) {
        zone[k] = isfinite(lo_all[k]) ? lo_all[k] : -BIG;
        zone[R + k] = isfinite(hi_all[k]) ? hi_all[k] : BIG;
    }
    for (;;) {
        rounds++;
        /* the rows of this round (retime_path) and the bound of x (topp._upper) */
        for (int k = 0; k < N; k++) {
            for (int c = 0; c < e; c++) {
                alpha[(long)k * R + c] = fixed_alpha[(long)k * e + c];
                beta[(long)k * R + c] = fixed_beta[(long)k * e + c];
            }
            for (int c = 0; c < r; c++) {
                alpha[(long)k * R + e + c] = rate_alpha[(long)k * r + c] * tight[(long)k * r + c];
                beta[(long)k * R + e + c] = rate_beta[(long)k * r + c] * tight[(long)k * r + c];
            }
            x_up[k] = np_min(w2, np_min(rate_x_upper[k], w2) * x_cap[k]);
            if (!(isfinite(x_up[k]) && x_up[k] >= 0.0)) { status = 2; goto done; }
        }
        /* topp.scaling_with_sets */
        int later = rounds > 1;  /* the round before was feasible (else the loop ended) */
        if (later)
            for (int k = 0; k < N; k++) {
                old_x[k] = x[k];
                old_lo[k] = K_lo[k];
                old_hi[k] = K_hi[k];
            }
        int top = N - 2, have_last;
        double last_lo = 0.0, last_hi = 0.0;
        first_empty = N - 1;
        if (reuse >= 0 && reuse < N - 2) {
            top = reuse > 0 ? reuse : 0;
            last_lo = K_lo[top + 1];
            last_hi = K_hi[top + 1];
            have_last = 1;
        } else {
            for (int k = 0; k < N; k++) { K_lo[k] = 0.0; K_hi[k] = 0.0; }
            have_last = last_set(R, alpha + (long)(N - 1) * R, g_all + (long)(N - 1) * R, zone,
                                 x_up[N - 1], &last_lo, &last_hi);
            if (have_last) { K_lo[N - 1] = last_lo; K_hi[N - 1] = last_hi; }
        }
        if (have_last) {
            if (mmplan_topp_backward(R, top, alpha, beta, g_all, sigma, x_up, zone, last_lo,
                                     last_hi, set_lo, set_hi, empty, pair)) {
                status = 1;
                goto done;
            }
            first_empty = -1;
            for (int k = top; k >= 0; k--)
                if (empty[k] > 0.5) { first_empty = k; break; }
            int start = first_empty < 0 ? 0 : first_empty + 1;
            for (int k = 0; k < start; k++) { K_lo[k] = 0.0; K_hi[k] = 0.0; }
            for (int k = start; k <= top; k++) { K_lo[k] = set_lo[k]; K_hi[k] = set_hi[k]; }
        }
        /* topp._start */
        double x0 = given_start ? x_start : K_hi[0];
        feasible = first_empty < 0 && K_lo[0] <= x0 + 1e-12
                   && x0 <= K_hi[0] + TOL * (1.0 + fabs(K_hi[0]));
        /* the forward pass; in a later round only from the first sample whose rows or
           controllable set changed (x before it is the same: x_{i+1} depends on x_i, the rows
           of i and i + 1 and K and x_upper of i + 1) until x meets the last round's again
           past the last change (then the rest is the same too) */
        int from = 0, settled = N;
        if (later) {
            int first = rows_first, last = rows_last;
            for (int k = 0; k < N; k++)
                if (K_lo[k] != old_lo[k] || K_hi[k] != old_hi[k]) {
                    if (k < first) first = k;
                    if (k > last) last = k;
                }
            from = first > 0 ? first - 1 : 0;
            settled = last;
        }
        for (int k = from + 1; k < N; k++) x[k] = 0.0;
        for (int k = 0; k < N; k++) v[k] = 0.0;
        if (!feasible) for (int k = 0; k <= from; k++) x[k] = 0.0;
        if (feasible) {
            if (from == 0) x[0] = x0;
            for (int i = from; i + 1 < N; i++) {
                x[i + 1] = forward_step(R, i, alpha, beta, g_all, sigma, x_up, zone, K_lo, K_hi,
                                        x[i], slabs);
                if (later && i + 1 > settled && x[i + 1] == old_x[i + 1]) {
                    for (int k = i + 2; k < N; k++) x[k] = old_x[k];
                    break;
                }
            }
            for (int k = 0; k + 1 < N; k++) v[k] = (x[k + 1] - x[k]) / (sigma[k + 1] - sigma[k]);
        }
        /* topp._times, Scaling.v_at_samples, the real-time rates */
        for (int k = 0; k < N; k++) w[k] = sqrt(x[k]);
        t[0] = 0.0;
        for (int k = 0; k + 1 < N; k++) {
            double s = w[k + 1] + w[k];
            t[k + 1] = t[k] + (s > 0 ? 2.0 * (sigma[k + 1] - sigma[k]) / s : INFINITY);
        }
        for (int k = 0; k < N; k++) v_at[k] = v[k];
        v_at[N - 1] = v[N - 2];
        for (int k = 0; k < N; k++)
            for (int j = 0; j < n; j++) {
                long i = (long)k * n + j;
                dq[i] = w[k] * dq_ds[i];
                ddq[i] = x[k] * ddq_ds2[i] + 0.5 * v_at[k] * dq_ds[i];
            }
        if (!feasible) { ratio = 0.0; with_peaks = 0; goto done; }  /* no peaks, as NumPy */
        peaks_of(N, n, t, q, dq, nq, kind, j1, j2, limit, peaks);
        with_peaks = 1;
        ratio = max_of(peaks, P);
        if (ratio <= 1.0) goto done;
        if (rounds >= max_rounds) {  /* slowed down as a whole (retime_path) */
            double c = ratio * (1.0 + 1e-9), c2 = pow(c, 2.0), t0 = t[0];
            for (int k = 0; k < N; k++) {
                x[k] = x[k] / c2;
                v[k] = v[k] / c2;
                t[k] = t0 + (t[k] - t0) * c;
            }
            for (long i = 0; i < (long)N * n; i++) { dq[i] = dq[i] / c; ddq[i] = ddq[i] / c2; }
            peaks_of(N, n, t, q, dq, nq, kind, j1, j2, limit, peaks);
            ratio = max_of(peaks, P);
            goto done;
        }
        /* retime._tighten, with the stall test and the samples' share of their bound */
        for (long k = 0; k < Nr; k++) before_tight[k] = tight[k];
        for (int k = 0; k < N; k++) {
            before_cap[k] = x_cap[k];
            double base = np_min(rate_x_upper[k], w2);
            share[k] = base > 0.0 ? x[k] / base : 0.0;
        }
        for (int k = 0; k + 1 < N; k++)
            for (int j = 0; j < nq; j++) {
                double p = peaks[(long)k * nq + j];
                if (!(p > 1.0)) continue;
                double pp = previous[(long)k * nq + j];
                int stuck = have_previous && pp > 1.0 && p >= pp * (1.0 - stall);
                double f = p * overshoot;
                for (int end = k; end <= k + 1; end++) {
                    if (kind[j] == 0) {
                        x_cap[end] = np_min(x_cap[end], before_cap[end] / (f * f));
                        continue;
                    }
                    for (int c = 0; c < r; c++)
                        if (owner[c] == j) {
                            long i = (long)end * r + c;
                            tight[i] = np_max(tight[i], before_tight[i] * f);
                        }
                    if (stuck) x_cap[end] = np_min(x_cap[end], share[end] / f);
                }
            }
        for (long k = 0; k < P; k++) previous[k] = peaks[k];
        have_previous = 1;
        int last_changed = -1, first_changed = N;
        for (int k = 0; k < N; k++) {
            int changed = x_cap[k] != before_cap[k];
            for (int c = 0; c < r && !changed; c++)
                changed = tight[(long)k * r + c] != before_tight[(long)k * r + c];
            if (changed) {
                if (k < first_changed) first_changed = k;
                last_changed = k;
            }
        }
        rows_first = first_changed;
        rows_last = last_changed;
        if (last_changed < 0) last_changed = N - 1;
        reuse = first_empty < 0 ? last_changed : -1;
    }
done:
    free(work);
    free(slabs);
    out_int[0] = rounds;
    out_int[1] = feasible;
    out_int[2] = first_empty;
    out_int[3] = with_peaks;
    *out_ratio = ratio;
    return status;
}
"""


@dataclass(frozen=True)
class Outcome:
    """What :class:`Rounds` returns: the last round's x, v, t, real-time dq, ddq and step
    peaks (None when not computed: an infeasible scaling), rounds, feasibility, the first
    empty controllable set and the largest peak ratio (as :func:`.retime.retime_path`)."""

    x: Array
    v: Array
    t: Array
    dq: Array
    ddq: Array
    peaks: Array | None
    rounds: int
    feasible: bool
    first_empty: int | None
    ratio: float


class Rounds:
    """``mmplan_retime_rounds`` of a loaded passes library, called through ctypes."""

    def __init__(self, lib: ctypes.CDLL) -> None:
        self._fn = lib.mmplan_retime_rounds
        self._fn.restype = ctypes.c_int
        i, d, p = ctypes.c_int, ctypes.c_double, ctypes.c_void_p
        self._fn.argtypes = [i, i, i, i, i, *[p] * 17, d, i, d, i, d, d, p, p, *[p] * 8]
        self._rows = lib.mmplan_path_rows
        self._rows.restype = None
        self._rows.argtypes = [i, i, i, p, p, p, p, i, *[p] * 9]
        self._ratios = lib.mmplan_rate_ratios
        self._ratios.restype = None
        self._ratios.argtypes = [i, i, i, *[p] * 7]
        self._residuals = lib.mmplan_step_residuals
        self._residuals.restype = None
        self._residuals.argtypes = [i, i, p, p, p, p]

    def path_rows(
        self, dq_ds: Array, ddq_ds2: Array, columns: tuple[Array, Array, Array, Array],
        rows: tuple[Array, Array, Array, Array],
    ) -> tuple[Array, Array, Array]:
        """x_upper (N,) and the acceleration rows' alpha, beta (N, m) of
        :meth:`.rates.RateModel.path_rows` (``columns``: the quantities' kind, j1, j2 and
        limit squared; ``rows``: each row's coordinates i, j (-1: a one-coordinate row) and
        polygon cosine and sine)."""
        v, a = _dense(dq_ds), _dense(ddq_ds2)
        N, n = v.shape
        kind, j1, j2 = (_dense(c, np.intc) for c in columns[:3])
        limit2 = _dense(columns[3])
        ri, rj = (_dense(c, np.intc) for c in rows[:2])
        rc, rs = _dense(rows[2]), _dense(rows[3])
        m = len(ri)
        x_upper, alpha, beta = np.empty(N), np.empty((N, m)), np.empty((N, m))
        arrays = (ri, rj, rc, rs, v, a, x_upper, alpha, beta)
        self._rows(N, n, len(kind), *[x.ctypes.data for x in (kind, j1, j2, limit2)], m,
                   *[x.ctypes.data for x in arrays])  # fmt: skip
        return x_upper, alpha, beta

    def ratios(self, dq: Array, ddq: Array, columns: tuple[Array, Array, Array, Array]) -> Array:
        """:meth:`.rates.RateModel.ratios` (``columns``: kind, j1, j2, limit)."""
        v, a = _dense(dq), _dense(ddq)
        N, n = v.shape
        kind, j1, j2 = (_dense(c, np.intc) for c in columns[:3])
        limit = _dense(columns[3])
        out = np.empty((N, len(limit)))
        self._ratios(N, n, len(limit), *[x.ctypes.data for x in (kind, j1, j2, limit, v, a, out)])
        return out

    def step_residuals(self, t: Array, q: Array, dq: Array) -> Array:
        """:func:`mmplan.planners.extended_jacobian.time_scaling.step_residuals`."""
        t, q, dq = _dense(t), _dense(q), _dense(dq)
        N, n = q.shape
        out = np.empty(max(N - 1, 0))
        self._residuals(N, n, *[x.ctypes.data for x in (t, q, dq, out)])
        return out

    def __call__(
        self, path: tuple[Array, Array, Array, Array], fixed: tuple[Array, Array],
        g_all: Array, rates: tuple[Array, Array, Array], bounds: tuple[Array, Array],
        owner: Sequence[int], columns: tuple[Array, Array, Array, Array],
        settings: tuple[float, float | None, int, float, float], pair: int | None,
        peaks: int,
    ) -> Outcome | None:
        """The rounds on ``path`` = (sigma, q, q', q'') with the fixed rows (alpha, beta),
        every row's g, the rate rows (alpha, beta, x_upper), every row's (lo, hi), each rate
        row's quantity, the quantities' (kind, j1, j2, limit) (:mod:`.native_peaks`),
        ``settings`` = (w_max, x_start, rounds, overshoot, stall), the thread helper's
        ``pair`` and the step peaks' address. None when x is unbounded at some sample (the
        caller's NumPy loop raises)."""
        sigma, q, dq_ds, ddq_ds2 = (_dense(a) for a in path)
        N, n = q.shape
        fa, fb = (_dense(a) for a in fixed)
        ra, rb, rx = (_dense(a) for a in rates)
        lo, hi, g = _dense(bounds[0]), _dense(bounds[1]), _dense(g_all)
        ints = [_dense(a, np.intc) for a in (owner, *columns[:3])]
        limit = _dense(columns[3])
        e, r, nq = fa.shape[1], ra.shape[1], len(limit)
        w_max, x_start, max_rounds, overshoot, stall = settings
        x, v, t = np.empty(N), np.empty(N), np.empty(N)
        dq, ddq = np.empty((N, n)), np.empty((N, n))
        out_peaks = np.empty((N - 1, nq))
        out_int, ratio = np.zeros(4, dtype=np.intc), np.zeros(1)
        inputs = [sigma, q, dq_ds, ddq_ds2, fa, fb, g, ra, rb, rx, lo, hi, *ints, limit]
        outputs = [x, v, t, dq, ddq, out_peaks, out_int, ratio]
        status = self._fn(
            N, n, e, r, nq, *[a.ctypes.data for a in inputs], w_max, x_start is not None,
            0.0 if x_start is None else x_start, max_rounds, overshoot, stall, pair, peaks,
            *[a.ctypes.data for a in outputs],
        )  # fmt: skip
        if status == 2:
            return None
        if status != 0:
            raise MemoryError("time scaling: no memory for the re-timing rounds")
        rounds, feasible, first_empty, with_peaks = (int(k) for k in out_int)
        return Outcome(x, v, t, dq, ddq, out_peaks if with_peaks else None, rounds,
                       bool(feasible), None if first_empty < 0 else first_empty,
                       float(ratio[0]))  # fmt: skip


def _dense(a: Any, dtype: Any = np.float64) -> Array:
    return np.ascontiguousarray(a, dtype=dtype)
