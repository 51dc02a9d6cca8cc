r"""Braking along the plan the robot follows, when a re-plan's path cannot be taken at its speed.

A re-plan (:mod:`~mmplan.planners.extended_jacobian.replan`) starts the generator's new path at
the robot's velocity and time-scales it under the limits from the robot's time rate. When an
obstacle appears close ahead, the new path turns more sharply than the limits allow at that
speed (the scaling can only start slower than the robot moves: a step in the velocity that no
robot can follow; measured on the example's youBot with its limits: w 0.43 to 0.32, then 0.31
to 0.13, 0.13 to 0.009 in three cycles, after which the generator, started at q' = dq / w with
w tiny, diverged), or the generator finds no path at all (it diverges at once from a state
deep inside an obstacle's neighbourhood). Instead the robot slows down to rest along the path
it follows, which its limits hold at its speed; the next cycles re-plan from the slower state.

The old plan q_o(s) (s its time, from the robot's state at ``elapsed``) is the path of a time
scaling (:func:`~mmplan.planners.extended_jacobian.time_scaling.scale_path`, with sigma = s,
q' = dq_o, q'' = ddq_o and its efforts at x = 1): from x = 1 (the robot's speed: its state to
the bit) to rest (x <= 1e-12 at the last sample of a stretch), time-optimal under the torque
zone and the rate limits. Of stretches of 3, 4, 6, 9, ... samples of the old plan up to all of
it, the one at rest soonest is taken, among those whose scaling starts at x = 1, keeps its
samples consistent with their motion (the checker's dq test) and stops within 10 s (the
shortest that can stop does so on a knife's edge and creeps). The geometric path, and with
it the wheels' constraints, are the old plan's: braking does not steer (the re-planner
measures its clearance to the new scene and says when it meets an obstacle). A braking plan
followed further is continued, not braked again. Tested
(tests/planners/extended_jacobian/test_replan.py): a ball ahead of the youBot at speed, the
braking plan from the state to rest passes the independent check.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from mmplan import interpolant
from mmplan.arrays import Array
from mmplan.planners.extended_jacobian.functions import GeneratorFunctions
from mmplan.planners.extended_jacobian.options import RolloutOptions
from mmplan.planners.extended_jacobian.rollout import RolloutResult
from mmplan.planners.extended_jacobian.time_scaling import scale_path
from mmplan.trajectory import Status

#: Longest braking plan [s] taken (a candidate that creeps to rest is refused; a review saw
#: 11 s to 3.6e4 s among the candidates).
LONGEST = 10.0
#: A sample this close after ``elapsed`` [s] is dropped (a step of nanoseconds made the
#: scaling miss the start: a review's 31 of 31 probes at 0.9999999 of a step).
NEAR_SAMPLE = 1e-8


def brake(
    plan: RolloutResult,
    elapsed: float,
    fns: GeneratorFunctions,
    opt: RolloutOptions,
    efforts: Callable[[Array, Array, Array], Array],
) -> RolloutResult | None:
    """``plan`` (a time-scaled re-plan, ``u`` its time rate on the generator's path) from
    ``elapsed`` seconds on, brought to rest as soon as its limits allow (module docstring);
    None when they do not allow it before the plan's end. ``efforts(q, dq, ddq)``: the
    robot's actuator efforts, for the state at ``elapsed`` (between samples: the interpolant's
    q, dq and ddq interpolated linearly)."""
    t = np.asarray(plan.t, dtype=float)
    if not (np.isfinite(elapsed) and elapsed >= 0.0) or len(t) < 2:
        return None
    if "braking_deceleration" in plan.info:  # braking as hard as it may: go on
        return _rest_of(plan, min(elapsed, float(t[-1])))
    if len(t) < 3 or elapsed >= t[-1]:
        return None
    rest = _rest_of(plan, elapsed)  # the old plan from here, its own time as the path's
    tau0 = np.asarray(efforts(rest.q[0], rest.dq[0], rest.ddq[0]), dtype=float).reshape(-1)
    rest.tau[0] = tau0
    path = dataclasses.replace(
        rest, status=Status.TIMEOUT, u=np.ones(len(rest.t)), effort=None, w=None, outcome=None,
        info={},
    )  # fmt: skip

    def stop_within(m: int) -> RolloutResult | None:
        """The first m samples scaled from the robot's speed (x = 1) to rest, or None (also
        when its samples miss their motion beyond the re-timing's tolerance: a review found 15
        of 202 braking plans failing the checker's dq consistency, or when it takes longer
        than :data:`LONGEST`)."""
        part = _first(path, m)
        timed = scale_path(part, fns, opt, time_mode=True, start_rate=1.0, end_at_rest=True)
        if timed.status is Status.INFEASIBLE or timed.info.get("velocity_step"):
            return None
        if timed.info.get("step_residual_ratio", 0.0) > 1.0 or timed.t[-1] > LONGEST:
            return None
        return timed

    # stretches of 3, 4, 6, 9, ... samples up to the whole plan: the one at rest soonest (a
    # bisection for the shortest assumed that longer ones stop too: the dq-consistency test
    # refuses some in between; and the shortest stops on a knife's edge and creeps: 6.9e8 s)
    sizes = {len(path.t)} | {int(3 * 1.5**k) for k in range(40) if 3 * 1.5**k < len(path.t)}
    found = [b for b in (stop_within(m) for m in sorted(sizes)) if b is not None]
    if not found:
        return None
    best = min(found, key=lambda b: float(b.t[-1]))
    rate = np.asarray(best.u, dtype=float).copy()  # d(old time)/dt
    rate[-1] = 0.0  # at rest (the scaling's w <= 1e-6 there)
    best = dataclasses.replace(best, dq=np.vstack([best.dq[:-1], np.zeros_like(best.dq[-1:])]))
    info = {
        **best.info,
        "braking_deceleration": float(np.max(-np.diff(rate) / np.diff(best.t), initial=0.0)),
        "braking_time_s": float(best.t[-1]),
        "start_rate": float(rest.u[0]),
    }
    return dataclasses.replace(
        best,
        status=Status.TIMEOUT,
        message=f"braking along the plan it follows to rest in {best.t[-1]:.3f} s",
        u=rate * np.asarray(rest.u[: len(rate)], dtype=float),  # the generator path's rate
        s=np.ones(len(rate)),
        info=info,
    )


def _first(path: RolloutResult, m: int) -> RolloutResult:
    """The first m samples of ``path``."""
    cut = {k: getattr(path, k)[:m] for k in ("t", "q", "dq", "ddq", "tau", "u", "s", "error")}
    return dataclasses.replace(path, **cut)


def _rest_of(plan: RolloutResult, elapsed: float) -> RolloutResult:
    """A braking plan from ``elapsed`` on: its samples after it, the state there first (the
    interpolant's q, dq; ddq, tau, u, error interpolated), the time from 0."""
    t = np.asarray(plan.t, dtype=float)
    later = t > elapsed + NEAR_SAMPLE  # a sample a hair ahead is the start itself
    q0, dq0, _ = interpolant.evaluate(t, plan.q, plan.dq, np.array([elapsed]))
    if not later.any():  # braked to rest: the end, held
        dq0 = np.zeros_like(dq0)

    def rows(values: Array) -> Array:
        v = np.asarray(values, dtype=float).reshape(len(t), -1)
        first = np.array([np.interp(elapsed, t, column) for column in v.T])
        return np.vstack([first[None, :], v[later]])

    braked = float(plan.t[-1]) - elapsed
    return dataclasses.replace(
        plan, t=np.concatenate([[0.0], t[later] - elapsed]), q=np.vstack([q0, plan.q[later]]),
        dq=np.vstack([dq0, plan.dq[later]]), ddq=rows(plan.ddq), tau=rows(plan.tau),
        u=rows(plan.u).ravel(), s=np.ones(int(later.sum()) + 1), error=rows(plan.error).ravel(),
        message=f"braking along the plan it follows to rest in {braked:.3f} s",
    )  # fmt: skip
