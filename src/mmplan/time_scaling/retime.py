r"""Re-time a sampled path under rate limits (and further rows such as efforts), holding the
limits at the samples and on the motion between them.

:func:`retime_path` runs :func:`.topp.time_optimal_scaling` with the rate constraints of
:class:`.rates.RateModel`; they hold at every sample. Between samples a trajectory means the
cubic Hermite interpolant through (t, q, dq) (:mod:`mmplan.interpolant`), and that may exceed
a limit which holds at both ends: its acceleration runs linearly from :math:`a_k` to
:math:`b_k`, :math:`6e_k/h^2` either side of the step mean, with :math:`e_k` the trapezoid
error of the step; where the time rate rises fast while the path's curvature turns (the
youbot3r-obstacles path sampled every 20 ms), the wheels' Hermite reached 23.9 rad/s^2 against
20 held at the samples. Every step whose interpolant exceeds a limit
(:meth:`.rates.RateModel.interval_ratios`: |ddq| at both ends of the step, |dq| at the ends
and at the vertex of its quadratic, planar norms exactly) gets the constraints at both its
end samples tightened by the excess ratio (rate rows multiplied by it, velocity bounds of x
divided by its square), and the scaling runs again, until the interpolant holds every limit
(at most :data:`MAX_ROUNDS` rounds; 1-4 on the youBot scenarios). Efforts are never tightened
(they are held at the samples, :mod:`.topp`).

With the passes compiled the rounds run as one C call (:mod:`.native_rounds`: the same
results to the bit, 2.7 ms instead of 4.7 ms a re-timing of the paper scenario's path); the
NumPy loop here is their specification and the fallback without a compiler.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from mmplan.time_scaling import native_peaks, passes
from mmplan.time_scaling.rates import PathRates, RateModel
from mmplan.time_scaling.topp import Scaling, scaling_with_sets, time_optimal_scaling

Array = NDArray[np.float64]

#: Rounds of tightening before the result is returned as it is.
MAX_ROUNDS = 12
#: Tightening beyond the measured excess (converges in fewer rounds).
OVERSHOOT = 1.002
#: A step over a limit whose excess shrank by less than this fraction since the round before
#: has stalled (:func:`_tighten`).
STALL = 1e-3

Rows = tuple[Array, Array, Array, Array, Array]


@dataclass(frozen=True)
class Retimed:
    """Result of :func:`retime_path`.

    Attributes:
        scaling: The time scaling (x = w^2, v, t, feasibility) of the last round.
        dq, ddq: Real-time velocities and accelerations at the samples (N, n).
        rounds: Scalings run (1 when no step needed tightening).
        step_ratio: Largest peak of the interpolant between samples / limit over every
            limited quantity (<= 1 unless the rounds ran out; 0 without rate limits).
        peaks: Those peaks / limits on every step, (N - 1, quantities)
            (:meth:`.rates.RateModel.interval_ratios` of the result; None where not
            computed: no rate limits, an infeasible scaling).
    """

    scaling: Scaling
    dq: Array
    ddq: Array
    rounds: int
    step_ratio: float
    peaks: Array | None = None


def retime_path(
    sigma: Array,
    q: Array,
    dq_ds: Array,
    ddq_ds2: Array,
    model: RateModel | None,
    rows: Rows | None = None,
    w_max: float = 1.0,
    x_start: float | None = 0.0,
) -> Retimed:
    """Time-optimal re-timing of the path q(sigma) under the rate limits of ``model`` (None:
    none) and further ``rows`` = (alpha, beta, g, lo, hi) in the form of :mod:`.topp`, with
    the interpolant between the samples held too (module docstring).

    Args:
        sigma: Path parameter (N,). q, dq_ds, ddq_ds2: q, q', q'' at the samples (N, n).
        model: Rate limits. rows: Further constraint rows (e.g. efforts), (N, m) and (m,).
        w_max, x_start: As :func:`.topp.time_optimal_scaling`.
    """
    N = len(sigma)
    extra = rows or (np.zeros((N, 0)), np.zeros((N, 0)), np.zeros((N, 0)), np.zeros(0),
                     np.zeros(0))  # fmt: skip
    rr = model.path_rows(dq_ds, ddq_ds2) if model is not None else None
    if model is not None and rr is not None and N >= 2:
        compiled = _compiled_rounds((sigma, q, dq_ds, ddq_ds2), model, rr, extra, w_max, x_start)
        if compiled is not None:
            return compiled
    tight = np.ones((N, 0 if rr is None else len(rr.hi)))  # factor on each rate row
    x_cap = np.ones(N)  # factor on x_upper
    rounds, ratio = 0, 0.0
    # A round changes the constraints only up to the last end sample it tightened: the
    # controllable sets after it are those of the round before (:func:`.topp.scaling_with_sets`).
    reuse: tuple[Array, Array, int] | None = None
    previous_peaks: Array | None = None
    if rr is not None:  # the rows the rounds do not tighten
        g_all = np.hstack([extra[2], rr.g])
        lo_all, hi_all = np.concatenate([extra[3], rr.lo]), np.concatenate([extra[4], rr.hi])
    while True:
        rounds += 1
        if rr is None:
            sc = time_optimal_scaling(sigma, *extra, w_max=w_max, x_start=x_start)
        else:
            sc, k_lo, k_hi = scaling_with_sets(
                sigma, np.hstack([extra[0], rr.alpha * tight]),
                np.hstack([extra[1], rr.beta * tight]), g_all, lo_all, hi_all,
                w_max=w_max, x_upper=np.minimum(rr.x_upper, w_max**2) * x_cap, x_start=x_start,
                reuse=reuse,
            )  # fmt: skip
        w = np.sqrt(sc.x)
        dq = w[:, None] * dq_ds
        ddq = sc.x[:, None] * ddq_ds2 + 0.5 * sc.v_at_samples[:, None] * dq_ds
        if model is None or rr is None or not sc.feasible:
            return Retimed(sc, dq, ddq, rounds, 0.0)
        peaks = model.interval_ratios(sc.t, q, dq)  # (N - 1, quantities)
        ratio = float(np.max(peaks, initial=0.0))
        if ratio <= 1.0:
            return Retimed(sc, dq, ddq, rounds, ratio, peaks)
        if rounds >= MAX_ROUNDS:
            # Local tightening can oscillate on a marginal excess (measured: a random youbot-3r
            # scene still 2e-6 over a wheel's acceleration after 12 rounds). Slow the whole
            # motion down by c = ratio: speeds scale by 1/c, accelerations by 1/c^2 (both
            # within limits again), and every effort row, affine in (x, v) around the gravity
            # term g, moves towards g: a convex combination of two admissible values.
            c = ratio * (1.0 + 1e-9)
            sc = replace(sc, x=sc.x / c**2, v=sc.v / c**2, t=sc.t[0] + (sc.t - sc.t[0]) * c)
            dq, ddq = dq / c, ddq / c**2
            peaks = model.interval_ratios(sc.t, q, dq)
            return Retimed(sc, dq, ddq, rounds, float(np.max(peaks, initial=0.0)), peaks)
        before_tight, before_cap = tight.copy(), x_cap.copy()
        stalled = np.zeros_like(peaks, dtype=bool)
        if previous_peaks is not None:  # over again, by as much as before: no progress
            stalled = (peaks > 1.0) & (previous_peaks > 1.0)
            stalled &= peaks >= previous_peaks * (1.0 - STALL)
        previous_peaks = peaks
        base = np.minimum(rr.x_upper, w_max**2)
        share = np.divide(sc.x, base, out=np.zeros_like(sc.x), where=base > 0.0)
        _tighten(model, rr.quantity, peaks, tight, x_cap, stalled, share)
        changed = np.flatnonzero(np.any(tight != before_tight, axis=1) | (x_cap != before_cap))
        last_changed = int(changed[-1]) if len(changed) else len(sigma) - 1
        reuse = (k_lo, k_hi, last_changed) if sc.first_empty is None else None


def _compiled_rounds(
    path: tuple[Array, Array, Array, Array], model: RateModel, rr: PathRates, extra: Rows,
    w_max: float, x_start: float | None,
) -> Retimed | None:
    """The rounds of :func:`retime_path` as one C call (:mod:`.native_rounds`: the same
    results to the bit); None without the compiled passes and step peaks, or when x is
    unbounded at some sample (the NumPy loop then raises)."""
    kernels, peaks = passes.kernels(), native_peaks.peaks()
    if kernels is None or peaks is None:
        return None
    out = kernels.rounds(
        path, (extra[0], extra[1]), np.hstack([extra[2], rr.g]), (rr.alpha, rr.beta, rr.x_upper),
        (np.concatenate([extra[3], rr.lo]), np.concatenate([extra[4], rr.hi])), rr.quantity,
        model.peak_columns, (w_max, x_start, MAX_ROUNDS, OVERSHOOT, STALL), kernels.pair(),
        peaks.address,
    )  # fmt: skip
    if out is None:
        return None
    sc = Scaling(out.x, out.v, out.t, out.feasible, out.first_empty)
    return Retimed(sc, out.dq, out.ddq, out.rounds, out.ratio, out.peaks)


def _tighten(
    model: RateModel, owner: tuple[int, ...], peaks: Array, tight: Array, x_cap: Array,
    stalled: Array, x_share: Array,
) -> None:
    """Scale the constraints of each step whose interpolant exceeds a limit, at both ends, by
    the excess (in place): rate rows multiplied by it, velocity bounds of x divided by its
    square.

    A rate row tightened by f only moves the scaling where it then binds: at an end sample
    whose own value stays below the tightened bound, the interpolant's peak comes from the
    step's shape (its trapezoid error), not from the sample, and the next round returns the
    same x there. Measured on youbot3r-obstacles-torque: one step 0.28 % over a wheel's
    acceleration limit for three rounds with x unchanged; youbot3r-obstacles ran out of
    rounds (12) and was slowed down as a whole. On a ``stalled`` step (over again by as much
    as the round before, (N - 1, quantities)) x itself is capped at both ends at f^-1 times its
    value (``x_share``: x / its upper bound, (N,)): the accelerations of the slowed motion
    scale like x (``x_share`` is x over the bound without the caps, so the new cap is
    x_share / f). (Capping x on every step from the first round converges in fewer rounds but
    gives slower plans: 17.27 s instead of 16.18 s for youbot3r-obstacles-torque.)
    """
    previous_tight, previous_cap = tight.copy(), x_cap.copy()
    exceeded = peaks > 1.0
    # only the quantities over somewhere (the updates are maxima and minima against the
    # values before: the same in any order)
    for j in np.flatnonzero(exceeded.any(axis=0)):
        qt = model.quantities[j]
        over = np.flatnonzero(exceeded[:, j])
        f = peaks[over, j] * OVERSHOOT
        cols = [k for k, o in enumerate(owner) if o == j]
        stuck = stalled[over, j]
        for ends in (over, over + 1):
            if qt.kind == "velocity":
                x_cap[ends] = np.minimum(x_cap[ends], previous_cap[ends] / f**2)
                continue
            for c in cols:
                tight[ends, c] = np.maximum(tight[ends, c], previous_tight[ends, c] * f)
            e = ends[stuck]
            x_cap[e] = np.minimum(x_cap[e], x_share[e] / f[stuck])  # x <= x_now / f
