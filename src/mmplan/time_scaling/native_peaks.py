r"""The interpolant's peaks on every step (:meth:`.rates.RateModel.interval_ratios`) as one C loop.

The re-timing rounds (:mod:`.retime`) measure, after every scaling, the largest value of each
limited quantity on each step of the cubic Hermite interpolant (:mod:`mmplan.interpolant`: |dq_j|
at the ends and the vertex of its quadratic, |ddq_j| at the ends, a planar speed at the ends and
its interior maximum, a planar acceleration norm at the ends). In NumPy that is some 60 array
operations a call, 1.0 ms on a 607-sample youbot-3r plan and five calls a plan; here one pass
over the steps (measured 0.11 ms a call on youbot3r-obstacles-torque's 11 quantities at -O3
-march=native, 0.13 ms at -O2; the planar speeds' interior search dominates). The arithmetic
is :mod:`mmplan.interpolant`'s, operation for operation (the planar interior by the same
polynomial coefficients, sub-samples and bisection),
so the values agree with it (tests/time_scaling/test_native_peaks.py: to 1e-15 relative; equal
in almost every entry). NumPy's is the specification and the fallback without a compiler.
"""

from __future__ import annotations

import ctypes
from functools import lru_cache

import numpy as np

from mmplan import interpolant
from mmplan.arrays import Array
from mmplan.compile import codegen

FLAGS = ("-O3", "-march=native")
#: For a compiler that rejects one of :data:`FLAGS`.
FALLBACK = ("-O2",)
PREFIX = "interval_peaks"

SOURCE = r"""
#include <math.h>

#define SUB @SUB@
#define BISECT @BISECT@

/* kind: 0 velocity, 1 acceleration; j2 < 0 for one coordinate */
static double nan_max(double a, double b) {  /* np.maximum: NaN propagates */
    if (isnan(a) || isnan(b)) return NAN;
    return b > a ? b : a;
}

static double quartic(const double *e, double s) {  /* interpolant._horner, same order */
    double out = e[4] + 0.0 * s;
    out = out * s + e[3]; out = out * s + e[2]; out = out * s + e[1]; out = out * s + e[0];
    return out;
}

static double cubic(const double *c, double s) {
    double out = c[3] + 0.0 * s;
    out = out * s + c[2]; out = out * s + c[1]; out = out * s + c[0];
    return out;
}

static double planar_interior(const double *v0, const double *p1, const double *p2) {
    double d00 = v0[0] * v0[0] + v0[1] * v0[1], d01 = v0[0] * p1[0] + v0[1] * p1[1];
    double d02 = v0[0] * p2[0] + v0[1] * p2[1], d11 = p1[0] * p1[0] + p1[1] * p1[1];
    double d12 = p1[0] * p2[0] + p1[1] * p2[1], d22 = p2[0] * p2[0] + p2[1] * p2[1];
    double e[5] = {d00, 2.0 * d01, d11 + 2.0 * d02, 2.0 * d12, d22};
    double c[4] = {d01, 2.0 * d02 + d11, 3.0 * d12, 2.0 * d22};
    double best = -INFINITY, g_prev = 0.0;
    int cross = -1;
    for (int k = 0; k <= SUB; k++) {
        double s = (double)k / SUB;
        double sq = quartic(e, s), g = cubic(c, s);
        best = nan_max(best, sq);  /* np.max: NaN wins */
        if (k > 0 && cross < 0 && g_prev > 0.0 && g <= 0.0) cross = k - 1;
        g_prev = g;
    }
    if (cross >= 0) {
        double lo = (double)cross / SUB, hi = (double)(cross + 1) / SUB;
        for (int it = 0; it < BISECT; it++) {
            double mid = 0.5 * (lo + hi);
            if (cubic(c, mid) > 0.0) lo = mid; else hi = mid;
        }
        best = nan_max(best, nan_max(quartic(e, lo), quartic(e, hi)));
    }
    return sqrt(nan_max(best, 0.0));
}

void mmplan_interval_peaks(int N, int n, const double *t, const double *q, const double *dq,
                           int m, const int *kind, const int *j1, const int *j2,
                           const double *limit, double *out) {
    for (int k = 0; k + 1 < N; k++) {
        double h = t[k + 1] - t[k];
        int ok = isfinite(h) && h > 0.0;
        double hh = ok ? h : 1.0;
        for (int i = 0; i < m; i++) {
            int cols[2] = {j1[i], j2[i]}, w = j2[i] < 0 ? 1 : 2;
            double a[2], b[2], v0[2], v1[2];
            for (int c = 0; c < w; c++) {
                int j = cols[c];
                double x0 = dq[(long)k * n + j], x1 = dq[(long)(k + 1) * n + j];
                double dpos = (q[(long)(k + 1) * n + j] - q[(long)k * n + j]) / hh;
                double aa = (6.0 * dpos - 4.0 * x0 - 2.0 * x1) / hh;
                double bb = (-6.0 * dpos + 2.0 * x0 + 4.0 * x1) / hh;
                a[c] = ok ? aa : 0.0; b[c] = ok ? bb : 0.0; v0[c] = x0; v1[c] = x1;
            }
            double peak;
            if (kind[i] == 1 && w == 1) {
                peak = nan_max(fabs(a[0]), fabs(b[0]));
            } else if (kind[i] == 1) {
                double na = sqrt(a[0] * a[0] + a[1] * a[1]);
                peak = nan_max(na, sqrt(b[0] * b[0] + b[1] * b[1]));
            } else if (w == 1) {
                double ends = nan_max(fabs(v0[0]), fabs(v1[0]));
                double p1 = hh * a[0], p2 = 0.5 * hh * (b[0] - a[0]);
                double s = p2 != 0.0 ? -p1 / (2.0 * p2) : -1.0;
                int inside = ok && s > 0.0 && s < 1.0;
                if (!inside) s = 0.0;
                double vertex = fabs(v0[0] + s * (p1 + s * p2));
                peak = inside ? nan_max(ends, vertex) : ends;
            } else {
                double n0 = sqrt(v0[0] * v0[0] + v0[1] * v0[1]);
                double n1 = sqrt(v1[0] * v1[0] + v1[1] * v1[1]);
                double ends = nan_max(n0, n1);
                if (ok) {
                    double p1[2] = {hh * a[0], hh * a[1]};
                    double p2[2] = {0.5 * hh * (b[0] - a[0]), 0.5 * hh * (b[1] - a[1])};
                    double in = planar_interior(v0, p1, p2);
                    peak = nan_max(ends, in);
                } else {
                    peak = ends;
                }
            }
            out[(long)k * m + i] = peak / limit[i];
        }
    }
}
"""
SOURCE = SOURCE.replace("@SUB@", str(interpolant.SPEED_SUBSAMPLES))
SOURCE = SOURCE.replace("@BISECT@", str(interpolant._BISECTIONS))


class Peaks:
    """:func:`interval_ratios` of one compiled library (:func:`peaks`)."""

    def __init__(self, lib: ctypes.CDLL) -> None:
        self._fn = lib.mmplan_interval_peaks
        self._fn.restype = None
        i, p = ctypes.c_int, ctypes.c_void_p  # arrays by address
        self._fn.argtypes = [i, i, p, p, p, i, p, p, p, p, p]
        #: The loop's address (the re-timing rounds call it from C, :mod:`.native_rounds`).
        self.address = int(ctypes.cast(self._fn, ctypes.c_void_p).value or 0)

    def __call__(
        self, t: Array, q: Array, dq: Array, kind: Array, j1: Array, j2: Array, limit: Array
    ) -> Array:
        """Peak / limit of every quantity on every step, (N - 1, m) (as
        :meth:`.rates.RateModel.interval_ratios`); ``kind`` 0 velocity, 1 acceleration,
        ``j1``/``j2`` the coordinates (j2 = -1 for one)."""
        t, q, dq, limit = (np.ascontiguousarray(a, dtype=np.float64) for a in (t, q, dq, limit))
        ints = [np.ascontiguousarray(a, dtype=np.intc) for a in (kind, j1, j2)]
        N, n = q.shape
        m = len(limit)
        out = np.empty((max(N - 1, 0), m))
        self._fn(
            N,
            n,
            t.ctypes.data,
            q.ctypes.data,
            dq.ctypes.data,
            m,
            *[a.ctypes.data for a in ints],
            limit.ctypes.data,
            out.ctypes.data,
        )
        return out


@lru_cache(maxsize=1)
def peaks() -> Peaks | None:
    """The compiled loop (built at first use, then loaded from the disk cache); None without a
    compiler or when the build fails (the caller keeps NumPy)."""
    return codegen.load_source(SOURCE, PREFIX, FLAGS, Peaks, FALLBACK)
