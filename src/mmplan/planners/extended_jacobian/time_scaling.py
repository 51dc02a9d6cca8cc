r"""Torque limits by a true time scaling of the generator (docs/extended_jacobian.md, time mode).

[PajakPajak] eq. (23) scales only the feedback v2 (and, as printed, the obstacle push) by u: with
u = 0 the robot coasts on the drift -E^-1 v1, so near an obstacle the limits either cut the
push (the robot coasts into the obstacle) or are broken. Time mode instead plans the
unconstrained generator (u = 1) in its own time sigma, which fixes a collision-free
geometric path, and then traverses that path with the time rate w = dsigma/dt in [0, 1],
chosen time-optimally so that every effort stays in the safety zone at every sample
(:mod:`mmplan.time_scaling.topp`). Velocity terms scale with w^2, so slowing down also scales
them (unlike u in eq. (23)). The ``u`` column is w: 0 at the start (gravity only, like
u0 = 0 of [PajakPajak]), 1 where the limits do not bind.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from mmplan.arrays import Array
from mmplan.planners.extended_jacobian.generator import GeneratorFunctions
from mmplan.planners.extended_jacobian.options import RolloutOptions
from mmplan.planners.extended_jacobian.rollout import RolloutResult, rollout
from mmplan.time_scaling.topp import time_optimal_scaling
from mmplan.trajectory import Status


def rollout_time_scaled(
    fns: GeneratorFunctions,
    pfaffian: Any,
    winv: Array,
    q0: Array,
    p_f: Array,
    opt: RolloutOptions,
    switch: Callable[[Array], GeneratorFunctions | None] | None = None,
) -> RolloutResult:
    """Unconstrained generator path, then its time-optimal scaling under the torque zone.

    The efforts' split (T_m, gravity) does not depend on the partition, so ``fns`` serves the
    scaling even when the rollout switched partitions.
    """
    free = rollout(
        fns, pfaffian, winv, q0, p_f, dataclasses.replace(opt, torque_control=False), switch
    )
    if free.effort is not None:  # recorded by the compiled chunks
        a = free.tau.shape[1]
        beta, g = free.effort[:, :a], free.effort[:, a:]
    else:
        beta, g = fns.evaluate_many(free.q, free.dq)  # one call for all samples
    alpha = free.tau - g
    lo, hi = opt.zone
    sc = time_optimal_scaling(free.t, alpha, beta, g, lo, hi)
    info = dict(free.info)
    info.update({"generator_duration_s": float(free.t[-1]), "virtual_control": "time"})
    if not sc.feasible:
        where = free.t[sc.first_empty] if sc.first_empty is not None else 0.0
        message = (
            f"torque limits infeasible along the generator path (empty controllable set at "
            f"sigma = {where:.3f} s; eq. (30) violated); unscaled plan returned ({free.message})"
        )
        over = np.maximum(np.maximum(free.tau - opt.limits[1], opt.limits[0] - free.tau), 0.0)
        info["max_torque_violation"] = float(np.nanmax(over))
        return dataclasses.replace(free, status=Status.INFEASIBLE, message=message, info=info)
    w = np.sqrt(sc.x)
    ddq = sc.x[:, None] * free.ddq + 0.5 * sc.v[:, None] * free.dq
    tau = alpha * sc.x[:, None] + 0.5 * beta * sc.v[:, None] + g
    with np.errstate(invalid="ignore"):
        over = np.nanmax(np.maximum(np.maximum(tau - opt.limits[1], opt.limits[0] - tau), 0.0))
    info["max_torque_violation"] = float(over)
    status, message = free.status, free.message
    if free.status is Status.REACHED:
        message = f"goal reached at t = {sc.t[-1]:.3f} s (generator path {free.t[-1]:.3f} s)"
    if over > 1e-9:
        status = Status.INFEASIBLE
        message = f"torque limits broken by up to {over:.3g} N m; " + message
    return RolloutResult(
        status, message, sc.t, free.q, w[:, None] * free.dq, ddq, tau, w, free.s, free.error, info
    )
