r"""Limits by a true time scaling of the generator's path (docs/extended_jacobian.md, time mode).

[PajakPajak] eq. (23) scales only the feedback v2 (and, as printed, the obstacle push) by u: with
u = 0 the robot coasts on the drift -E^-1 v1, so near an obstacle the limits either cut the
push (the robot coasts into the obstacle) or are broken. Time mode instead plans the
unconstrained generator (u = 1) in its own time sigma, which fixes a collision-free
geometric path, and then traverses that path with the time rate w = dsigma/dt in [0, 1],
chosen time-optimally so that every effort stays in the safety zone at every sample
(:mod:`mmplan.time_scaling.topp`). Velocity terms scale with w^2, so slowing down also scales
them (unlike u in eq. (23)). The ``u`` column is w: 0 at the start (gravity only, like
u0 = 0 of [PajakPajak]), 1 where the limits do not bind.

Velocity and acceleration limits (``robot.limits.rates``) are held the same way, exactly at
every sample (:mod:`mmplan.time_scaling.rates`) and on the cubic Hermite interpolant between
the samples, the trajectory's meaning there (:mod:`mmplan.interpolant`, tightened by
:mod:`mmplan.time_scaling.retime`): with rate limits the planner always re-times its path.
Time mode (torque limits with obstacles, or no torque control at all) scales the free
generator path under efforts and rates together (:func:`rollout_time_scaled`); feedback mode
keeps its virtual control and re-times the path it produced (:func:`retime`, the
smooth torque start kept, w in the extra column ``w``).

Start rate. Both paths start at rest (q' = 0), so w_0 does not change dq_0 = 0 (a re-plan from a
moving robot starts at the robot's rate instead: :func:`scale_path`'s ``start_rate``). Without
rate limits time mode starts at w_0 = 0 (gravity only, like u0 = 0; the reproduction of
[PajakPajak] uses it). Then sigma grows like t^2 on the first interval and q like t^4: a motion
its two end samples represent badly (the trapezoid of dq misses q by a quarter of dq_1 per
second, 1.7 % of the peak wheel rate with the youBot's rate limits, above the checker's 1 %).
With rate limits (and after feedback mode) the scaling therefore starts at the largest
admissible w_0 (efforts within the zone at t = 0): still at rest, and a path that no limit binds
keeps the generator's timing exactly.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mmplan.planners.extended_jacobian.active import ActiveSlots
from mmplan.planners.extended_jacobian.generator import GeneratorFunctions
from mmplan.planners.extended_jacobian.options import RolloutOptions
from mmplan.planners.extended_jacobian.rollout import RolloutResult, rollout
from mmplan.planners.extended_jacobian.switching import PartitionSwitch
from mmplan.time_scaling import native
from mmplan.time_scaling.retime import Retimed, retime_path
from mmplan.trajectory import Status

Array = NDArray[np.float64]


def rollout_time_scaled(
    fns: GeneratorFunctions,
    pfaffian: Any,
    winv: Array,
    q0: Array,
    p: Array,
    opt: RolloutOptions,
    switch: PartitionSwitch | None = None,
    active: ActiveSlots | None = None,
) -> RolloutResult:
    """Unconstrained generator path, then its time-optimal scaling under the torque zone (with
    torque control) and the rate limits (when the robot has them), from rest (w_0 = 0).
    ``active``: as :func:`~mmplan.planners.extended_jacobian.rollout.rollout`'s.

    The efforts' split (T_m, gravity) does not depend on the partition, so ``fns`` serves the
    scaling even when the rollout switched partitions.
    """
    free = rollout(
        fns, pfaffian, winv, q0, p, dataclasses.replace(opt, torque_control=False), switch,
        active=active,
    )  # fmt: skip
    return scale_path(free, fns, opt, time_mode=True)


def retime(path: RolloutResult, fns: GeneratorFunctions, opt: RolloutOptions) -> RolloutResult:
    """A feedback-mode plan re-timed under the rate limits and the torque zone (module
    docstring); its ``u`` stays the virtual control, ``w`` is the time rate."""
    return scale_path(path, fns, opt, time_mode=False)


def _effort_split(path: RolloutResult, fns: GeneratorFunctions) -> tuple[Array, Array]:
    """beta = T_m q' and tau_g at every sample of ``path`` (N, n_act)."""
    if path.effort is not None:  # recorded by the compiled chunks
        a = path.tau.shape[1]
        return path.effort[:, :a], path.effort[:, a:]
    return fns.evaluate_many(path.q, path.dq)  # one call for all samples


#: A moving start's rate w_0 the scaling misses by at most this (relative) is no step.
STEP_TOL = 1e-9
#: Cap of x = w^2 at the last sample of a path that ends at rest (``scale_path``'s
#: ``end_at_rest``): w <= 1e-6 (a cap of 0 would be a row 1/0).
REST_CAP = 1e-12
#: Largest trapezoid residual of a step of the re-timed plan, relative to its peak |dq|:
#: half the checker's dq-consistency tolerance (1 %, :mod:`mmplan.verify.check`).
DQ_STEP_TOL = 0.005
#: Re-timings with capped steps before the plan is returned as it is.
MAX_CONSISTENCY_ROUNDS = 8
#: The checker's dq-consistency tolerance over ``DQ_STEP_TOL``: a residual ratio above this
#: fails the check (the planner then refines its step, planner.py).
CHECK_RATIO = 2.0


def step_residuals(t: Array, q: Array, dq: Array) -> Array:
    r"""Trapezoid residual of every step, :math:`\|(q_{k+1} - q_k)/h_k - (\dot q_k +
    \dot q_{k+1})/2\|_\infty` (N - 1,): how far the samples miss the motion they sample."""
    compiled = native.loaded()
    if compiled is not None and np.ndim(q) == 2:  # one C loop, the same numbers
        return compiled.rounds.step_residuals(t, q, dq)
    h = np.diff(t)[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.abs(np.diff(q, axis=0) / h - 0.5 * (dq[1:] + dq[:-1]))
    return np.asarray(np.nanmax(r, axis=1, initial=0.0), dtype=float)


def _retime_consistent(
    path: RolloutResult, opt: RolloutOptions, rows: tuple[Array, Array, Array, Array, Array],
    x_start: float | None,
    end_at_rest: bool = False,
) -> tuple[Retimed, int, float]:
    """:func:`retime_path`, then, while a step's samples miss its motion (trapezoid residual
    above ``DQ_STEP_TOL`` x peak |dq|), the same scaling with x capped at both ends of those
    steps and run again; returns the result, the extra rounds and the largest residual over
    its target at the end (above 1 when the rounds ran out: the planner then plans again with
    a smaller step, :mod:`~mmplan.planners.extended_jacobian.planner`).

    Cause (measured on random youbot-3r scenes with dt = 20 ms): where the generator's path
    turns sharply within one step (a wheel's q' from -0.03 to -1 per unit sigma), the scaling
    brakes to rest at one sample and the step before it is traversed at speed: q moves 19
    mrad in 88 ms while dq is ~0 at both ends, a residual of 0.215/s against the checker's
    0.16/s. Slowing such a step by c scales its residual by c (h by 1/c, dq by c), so a cap
    x <= x (target / r)^2 at its ends brings it within ``DQ_STEP_TOL``.
    """
    alpha, beta, g, lo, hi = rows
    N = len(path.t)
    cap = np.full(N, np.inf)
    if end_at_rest:  # x = w^2 <= 1e-12 at the last sample: at rest there
        cap[-1] = REST_CAP
    rounds = 0
    last: tuple[Retimed, int, float] | None = None
    while True:
        # x / cap <= 1 where capped; elsewhere x <= 1e9 (no bound: an all-zero row makes the
        # TOPP's controllable sets empty, measured)
        extra = np.where(np.isfinite(cap), 1.0 / np.maximum(cap, 1e-300), 1e-9)[:, None]
        timed = retime_path(
            path.t, path.q, path.dq, path.ddq, opt.rates,
            (np.hstack([alpha, extra]), np.hstack([beta, np.zeros((N, 1))]),
             np.hstack([g, np.zeros((N, 1))]), np.append(lo, -1.0), np.append(hi, 1.0)),
            x_start=x_start,
        )  # fmt: skip
        sc = timed.scaling
        if not sc.feasible and last is not None and x_start is not None and x_start > 0.0:
            # a moving start (a re-plan): the caps took x_start out of the controllable set;
            # the last round that kept it (measured: dropping x_start instead stepped the
            # start velocity, w 0.35 -> 0.06, and once upwards)
            return last
        if not sc.feasible or N < 2:
            return timed, rounds, 0.0
        r = step_residuals(sc.t, path.q, timed.dq)
        target = DQ_STEP_TOL * max(float(np.max(np.abs(timed.dq))), 1e-3)
        over = np.flatnonzero(r > target)
        ratio = float(np.max(r[over]) / target) if over.size else 0.0
        if not over.size or rounds >= MAX_CONSISTENCY_ROUNDS:
            return timed, rounds, ratio
        last = (timed, rounds, ratio)
        rounds += 1
        factor = (target / r[over]) ** 2 * 0.9
        for ends in (over, over + 1):
            cap[ends] = np.minimum(cap[ends], sc.x[ends] * factor)


def scale_path(
    path: RolloutResult,
    fns: GeneratorFunctions,
    opt: RolloutOptions,
    time_mode: bool,
    start_rate: float | None = None,
    end_at_rest: bool = False,
) -> RolloutResult:
    """Time-optimal scaling (w <= 1) of ``path`` (its dq, ddq are q', q'' in its own time,
    from rest) under the safety zone of the efforts (when ``opt.torque_control``) and the rate
    limits; w_0 as the module docstring says.

    Args:
        time_mode: ``u`` is w (time mode); else ``u`` stays the path's virtual control and
            w is returned apart.
        start_rate: w_0 of a path that starts at a velocity (a re-plan of a moving robot:
            dq_0 = q'_0 w_0 is its velocity). Where the limits cannot hold the path from that
            rate on, w_0 is the largest they admit, a step in the velocity;
            ``info["start_rate"]`` is the w_0 used.
        end_at_rest: w = 0 at the path's last sample (a braking plan,
            :mod:`~mmplan.planners.extended_jacobian.braking`).
    """
    beta, g = _effort_split(path, fns)
    alpha = path.tau - g
    n_act = alpha.shape[1]
    lo, hi = opt.zone if opt.torque_control else (np.full(n_act, -np.inf), np.full(n_act, np.inf))
    rows = (alpha, beta, g, lo, hi)
    moving = start_rate is not None
    start = 0.0 if time_mode and opt.rates is None else None
    if start_rate is not None:
        start = start_rate**2
    timed, consistency_rounds, residual = _retime_consistent(
        path, opt, rows, x_start=start, end_at_rest=end_at_rest
    )
    stepped = moving and not timed.scaling.feasible
    if stepped:
        timed, consistency_rounds, residual = _retime_consistent(
            path, opt, rows, x_start=None, end_at_rest=end_at_rest
        )
    sc = timed.scaling
    if stepped and sc.feasible and start_rate is not None:
        # x_start a hair outside the controllable set of a plan that rides its limits (a
        # braking plan from the speed of the plan it slows: w_0 = 1 to 1e-16), or a start at
        # rest (dq_0 = w_0 q'_0 = 0 whatever w_0): no step
        missed = abs(float(np.sqrt(sc.x[0])) - start_rate) > STEP_TOL * start_rate
        stepped = missed and bool(np.any(path.dq[0] != 0.0))
    info = {k: v for k, v in path.info.items() if k != "velocity_step"}
    if moving and sc.feasible:
        info["start_rate"] = float(np.sqrt(sc.x[0]))
    info["consistency_rounds"] = consistency_rounds
    if residual > 1.0:
        info["step_residual_ratio"] = residual
    info["generator_duration_s"] = float(path.t[-1])
    if time_mode:
        info["virtual_control"] = "time"
    info["time_scaling"] = "+".join(
        k for k, on in (("torque", opt.torque_control), ("rates", opt.rates is not None)) if on
    )
    if not sc.feasible:
        where = path.t[sc.first_empty] if sc.first_empty is not None else 0.0
        message = (
            f"limits infeasible along the generator path (empty controllable set at "
            f"sigma = {where:.3f} s; eq. (30) violated); unscaled plan returned ({path.message})"
        )
        off = np.maximum(np.maximum(path.tau - opt.limits[1], opt.limits[0] - path.tau), 0.0)
        info["max_torque_violation"] = float(np.nanmax(off)) if opt.torque_control else 0.0
        return dataclasses.replace(path, status=Status.INFEASIBLE, message=message, info=info)
    w, dq, ddq = np.sqrt(sc.x), timed.dq, timed.ddq
    tau = alpha * sc.x[:, None] + 0.5 * beta * sc.v_at_samples[:, None] + g
    over = 0.0
    if opt.torque_control:
        excess = np.maximum(np.maximum(tau - opt.limits[1], opt.limits[0] - tau), 0.0)
        with np.errstate(invalid="ignore"):
            over = float(np.nanmax(excess))
    info["max_torque_violation"] = over
    status, message = path.status, path.message
    if path.outcome is not None and opt.torque_control:
        # the verdict is the re-timed plan's (over, below): a feedback-mode path that left the
        # limits where the virtual control could not hold them is kept inside by the scaling
        status, message = path.outcome
    if status is Status.REACHED:
        message = f"goal reached at t = {sc.t[-1]:.3f} s (generator path {path.t[-1]:.3f} s)"
        if path.status is Status.INFEASIBLE:
            message += "; the virtual control alone left the torque limits, the re-timing kept them"
    if stepped:
        info["velocity_step"] = True
        message += (
            f"; starts at the time rate {np.sqrt(sc.x[0]):.3g}, not the robot's {start_rate:.3g}"
            " (no rate near it holds the limits on this path: a step in the velocity)"
        )
    if over > 1e-9:
        status = Status.INFEASIBLE
        message = f"torque limits broken by up to {over:.3g} N m; " + message
    if opt.rates is not None:
        ratios = opt.rates.ratios(dq, ddq)
        info["max_rate_ratio"] = float(np.max(ratios, initial=0.0))
        info["max_rate_step_ratio"] = timed.step_ratio
        info["time_scaling_rounds"] = timed.rounds
        # the re-timing's own ratios of these samples and steps (not computed again)
        broken = opt.rates.first_violation(sc.t, dq, ddq, path.q, ratios, timed.peaks)
        if broken is not None:
            status = Status.INFEASIBLE
            message = f"rate limits broken: {broken.message}; " + message
    u, extra_w = (w, None) if time_mode else (path.u, w)
    return RolloutResult(
        status, message, sc.t, path.q, dq, ddq, tau, u, path.s, path.error, info, w=extra_w
    )
