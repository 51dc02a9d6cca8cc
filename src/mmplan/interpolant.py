r"""Between samples: the continuous-time meaning of a sampled trajectory (docs/conventions.md).

A trajectory is a list of samples :math:`(t_k, q_k, \dot q_k, \ddot q_k)`. Between two
samples the motion is the **cubic Hermite interpolant** through :math:`(t_k, q_k, \dot q_k)`
and :math:`(t_{k+1}, q_{k+1}, \dot q_{k+1})`: C1 everywhere, its acceleration linear on each
step. With :math:`h = t_{k+1} - t_k`, :math:`s = (t - t_k)/h \in [0, 1]`,
:math:`\Delta q = q_{k+1} - q_k`:

.. math::

    \ddot q(s) = (1 - s)\,a_k + s\,b_k,\qquad
    a_k = \frac{6\Delta q/h - 4\dot q_k - 2\dot q_{k+1}}{h},\quad
    b_k = \frac{-6\Delta q/h + 2\dot q_k + 4\dot q_{k+1}}{h},

    \dot q(s) = \dot q_k + h\,(a_k s + (b_k - a_k)\,s^2/2),\qquad
    q(s) = q_k + h\dot q_k s + h^2 (a_k s^2/2 + (b_k - a_k)\,s^3/6).

The mean of :math:`\ddot q` over the step is :math:`(\dot q_{k+1} - \dot q_k)/h` exactly;
:math:`a_k` and :math:`b_k` lie :math:`6e_k/h^2` either side of it, with
:math:`e_k = \Delta q - h(\dot q_k + \dot q_{k+1})/2` the trapezoid error of the step. The
acceleration may jump at a sample (from :math:`b_{k-1}` to :math:`a_k`); the ``ddq`` column
is not part of the interpolant (a planner writes its own one-sided value there).

Extremes on a step, exactly: :math:`|\ddot q_j|` at the two ends (linear); :math:`|\dot q_j|`
at the two ends and at the vertex of the quadratic when it lies inside; a planar norm of
accelerations at the two ends (the norm of a linear function is convex); a planar speed
:math:`|(\dot q_i, \dot q_j)|` at the ends and at its one interior maximum (the square is a
quartic with a non-negative leading coefficient: at most one interior local maximum, found by
bracketing on :data:`SPEED_SUBSAMPLES` sub-samples and bisection).

The time-scaling planners hold their limits on these extremes
(:meth:`mmplan.time_scaling.rates.RateModel.interval_ratios`), and ``mmplan export`` samples
this interpolant (:mod:`mmplan.io.control_rate`). Steps of non-finite length (a time scaling
at rest) count as no motion.
"""

from __future__ import annotations

import numpy as np

from mmplan.arrays import Array, BoolArray

#: Sub-samples per step that bracket the interior maximum of a planar speed.
SPEED_SUBSAMPLES = 8
_BISECTIONS = 48


def _steps(t: Array) -> tuple[Array, BoolArray]:
    """Step lengths (N - 1, 1) and a mask of finite positive ones (N - 1,)."""
    h = np.diff(np.asarray(t, dtype=float))
    ok: BoolArray = np.isfinite(h) & (h > 0.0)
    return np.asarray(np.where(ok, h, 1.0)[:, None], dtype=float), ok


def step_accelerations(t: Array, q: Array, dq: Array) -> tuple[Array, Array]:
    """Acceleration of the interpolant at the start (a) and end (b) of every step, each
    (N - 1, n); zero on steps of non-finite length."""
    steps = Steps(t, q, dq)
    return steps.a, steps.b


def evaluate(t: Array, q: Array, dq: Array, times: Array) -> tuple[Array, Array, Array]:
    """q, dq, ddq of the interpolant at ``times`` (M,) within [t[0], t[-1]], each (M, n).

    At a sample time the acceleration is that of the step starting there (of the last step at
    the final sample). ``t`` must be finite and strictly increasing, N >= 2.
    """
    a, b = step_accelerations(t, q, dq)
    i = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 2)
    h = (t[i + 1] - t[i])[:, None]
    s = ((times - t[i]) / (t[i + 1] - t[i]))[:, None]
    ai, bi = a[i], b[i]
    acc = ai + (bi - ai) * s
    vel = dq[i] + h * s * (ai + (bi - ai) * s / 2.0)
    pos = q[i] + h * s * (dq[i] + h * s * (ai / 2.0 + (bi - ai) * s / 6.0))
    return pos, vel, acc


def peak_acceleration(t: Array, q: Array, dq: Array, index: tuple[int, ...]) -> Array:
    """Largest |ddq_j| (one index) or planar norm (two) of the interpolant on each step
    (N - 1,): the larger of its two ends."""
    return Steps(t, q, dq).peak_acceleration(index)


def peak_velocity(t: Array, q: Array, dq: Array, index: tuple[int, ...]) -> Array:
    """Largest |dq_j| (one index) or planar speed (two) of the interpolant on each step,
    (N - 1,) (module docstring); on steps of non-finite length the larger end value."""
    return Steps(t, q, dq).peak_velocity(index)


class Steps:
    """The interpolant of one trajectory, step by step: lengths and end accelerations computed
    once, for the peaks of several quantities (:meth:`peak_velocity`, :meth:`peak_acceleration`).

    Attributes:
        h: Step lengths (N - 1, 1) (1 where not finite and positive).
        ok: Steps of finite positive length (N - 1,).
        a, b: Acceleration at the start and end of every step (N - 1, n); 0 where not ``ok``.
        dq: The velocities (N, n).
    """

    def __init__(self, t: Array, q: Array, dq: Array) -> None:
        self.h, self.ok = _steps(t)
        dpos = np.diff(q, axis=0) / self.h
        a = (6.0 * dpos - 4.0 * dq[:-1] - 2.0 * dq[1:]) / self.h
        b = (-6.0 * dpos + 2.0 * dq[:-1] + 4.0 * dq[1:]) / self.h
        self.a = np.asarray(np.where(self.ok[:, None], a, 0.0), dtype=float)
        self.b = np.asarray(np.where(self.ok[:, None], b, 0.0), dtype=float)
        self.dq = dq

    def peak_acceleration(self, index: tuple[int, ...]) -> Array:
        """See :func:`peak_acceleration`."""
        cols = list(index)
        na = np.sqrt(np.sum(self.a[:, cols] ** 2, axis=1))
        nb = np.sqrt(np.sum(self.b[:, cols] ** 2, axis=1))
        return np.asarray(np.maximum(na, nb), dtype=float)

    def peak_velocity(self, index: tuple[int, ...]) -> Array:
        """See :func:`peak_velocity`."""
        cols, h, ok = list(index), self.h, self.ok
        a, b = self.a[:, cols], self.b[:, cols]
        v0, v1 = self.dq[:-1, cols], self.dq[1:, cols]
        p1, p2 = h * a, 0.5 * h * (b - a)  # dq(s) = v0 + p1 s + p2 s^2
        ends = np.maximum(np.sqrt(np.sum(v0**2, axis=1)), np.sqrt(np.sum(v1**2, axis=1)))
        if len(cols) == 1:
            v0, p1, p2 = v0[:, 0], p1[:, 0], p2[:, 0]
            with np.errstate(divide="ignore", invalid="ignore"):
                s = np.where(p2 != 0.0, -p1 / (2.0 * p2), -1.0)  # vertex of the quadratic
            inside = ok & (s > 0.0) & (s < 1.0)
            s = np.where(inside, s, 0.0)
            vertex = np.abs(v0 + s * (p1 + s * p2))
            return np.asarray(np.where(inside, np.maximum(ends, vertex), ends), dtype=float)
        return np.asarray(np.where(ok, np.maximum(ends, _planar_interior(v0, p1, p2)), ends),
                          dtype=float)


def _planar_interior(v0: Array, p1: Array, p2: Array) -> Array:
    """max over s in [0, 1] of |v0 + p1 s + p2 s^2| (rows (M, 2)), sub-samples and the
    interior maximum: g(s) = v . v' changes sign from + to - there (at most once)."""

    def speed(s: Array) -> Array:
        v = v0 + s[:, None] * (p1 + s[:, None] * p2)
        return np.asarray(np.sqrt(np.sum(v * v, axis=1)), dtype=float)

    def slope(s: Array) -> Array:
        v = v0 + s[:, None] * (p1 + s[:, None] * p2)
        return np.asarray(np.sum(v * (p1 + 2.0 * s[:, None] * p2), axis=1), dtype=float)

    M = len(v0)
    grid = np.linspace(0.0, 1.0, SPEED_SUBSAMPLES + 1)
    best = np.zeros(M)
    g = np.empty((M, len(grid)))
    for j, s in enumerate(grid):
        sj = np.full(M, s)
        best = np.maximum(best, speed(sj))
        g[:, j] = slope(sj)
    cross = (g[:, :-1] > 0.0) & (g[:, 1:] <= 0.0)
    rows = np.flatnonzero(cross.any(axis=1))
    if rows.size:
        j = np.argmax(cross[rows], axis=1)
        lo, hi = grid[j], grid[j + 1]
        v0, p1, p2 = v0[rows], p1[rows], p2[rows]
        for _ in range(_BISECTIONS):
            mid = 0.5 * (lo + hi)
            v = v0 + mid[:, None] * (p1 + mid[:, None] * p2)
            up = np.sum(v * (p1 + 2.0 * mid[:, None] * p2), axis=1) > 0.0
            lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
        v = v0 + lo[:, None] * (p1 + lo[:, None] * p2)
        best[rows] = np.maximum(best[rows], np.sqrt(np.sum(v * v, axis=1)))
    return best
