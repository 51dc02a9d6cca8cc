"""Input checks of the endogenous planner ([JaniakTchon]) that can be made before planning.

Everything here raises :class:`~mmplan.errors.InputError` naming the offending field:
start of the wrong size, obstacles (the method has no obstacle model), basis lengths that do
not match the platform controls, a ``lambda0`` of the wrong length, bounds on unknown
coordinates, empty bounds, a bound already violated at the start, and a goal height outside
the arm's vertical reach (the platform is planar, so k_z depends on the arm joints only; the
reach is the range of k_z over the arm joint limits).
"""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING

import numpy as np
from scipy.stats import qmc

from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.planners.endogenous.model import ResolvedBound
from mmplan.problem import Problem
from mmplan.robot.robot import Robot, Symbols
from mmplan.task import ReachPoint

if TYPE_CHECKING:
    from mmplan.planners.endogenous.settings import EndogenousSettings


#: Finite stand-in for infinite arm joint limits when sampling the vertical reach.
_WIDE = 10.0
_SAMPLES, _GRADIENT_STEPS, _STEP = 128, 60, 0.25
_REACH: dict[int, tuple[weakref.ref[Symbols], dict[bytes, tuple[float, float]]]] = {}


def check_problem(
    problem: Problem, settings: EndogenousSettings
) -> tuple[list[ResolvedBound], Array]:
    """Validate ``problem`` for the endogenous planner; return the bounds and lambda0.

    Raises:
        InputError: bad start, obstacles, basis, lambda0, bounds or an unreachable goal.
    """
    robot = problem.robot
    start = np.asarray(problem.start, float)
    if start.shape != (robot.n,) or not np.all(np.isfinite(start)):
        raise InputError("start", f"expected {robot.n} finite values {robot.coordinates}")
    if problem.scene.obstacles:
        raise InputError(
            "obstacles",
            "the endogenous planner ([JaniakTchon]) has no obstacle model; "
            "remove the obstacles or choose another method",
        )
    n_u = len(robot.platform.actuators)
    if len(settings.basis_terms) != n_u:
        raise InputError(
            "planner.basis_terms",
            f"expected {n_u} counts (one per platform control "
            f"{robot.platform.actuators}), got {len(settings.basis_terms)}",
        )
    for i, terms in enumerate(settings.basis_terms):
        if terms < 1:
            raise InputError(f"planner.basis_terms[{i}]", f"expected >= 1 term, got {terms}")
    n_lam = sum(settings.basis_terms)
    lam0 = np.zeros(n_lam) if settings.lambda0 is None else np.asarray(settings.lambda0, float)
    if lam0.shape != (n_lam,) or not np.all(np.isfinite(lam0)):
        raise InputError(
            "planner.lambda0",
            f"expected {n_lam} finite values (sum of basis_terms "
            f"{list(settings.basis_terms)}), got {len(lam0)}",
        )
    bounds = []
    for i, b in enumerate(settings.bounds):
        key = f"planner.bounds[{i}]"
        if b.coordinate not in robot.coordinates:
            raise InputError(
                f"{key}.coordinate",
                f"unknown coordinate {b.coordinate!r}; choose one of {list(robot.coordinates)}",
            )
        if not b.min < b.max:
            raise InputError(key, f"min {b.min} must be < max {b.max}")
        earlier = [j for j, o in enumerate(settings.bounds[:i]) if o.coordinate == b.coordinate]
        if earlier:
            raise InputError(f"{key}.coordinate", f"duplicate: {b.coordinate!r} is already "
                             f"bounded by planner.bounds[{earlier[0]}]")
        k = robot.index(b.coordinate)
        if not b.min < start[k] < b.max:
            raise InputError(
                key,
                f"violated at the start: {b.coordinate} = {start[k]:.6g} is not "
                f"inside ({b.min:.6g}, {b.max:.6g})",
            )
        bounds.append(ResolvedBound(k, b.min, b.max))
    task = problem.task
    if isinstance(task, ReachPoint):
        low, high = vertical_reach(robot, start)
        z = task.position[2]
        if not low - task.tolerance <= z <= high + task.tolerance:
            raise InputError(
                "goal.position",
                f"unreachable: height {z:.4g} m is outside the arm's "
                f"vertical reach [{low:.4g}, {high:.4g}] m within its joint limits",
            )
    return bounds, lam0


def vertical_reach(robot: Robot, start: Array) -> tuple[float, float]:
    """Range [min, max] of the end-effector height over the arm joint limits [m].

    Deterministic Halton samples of the joint box (infinite limits replaced by +-10), each
    refined by projected gradient steps on k_z (exact Jacobian row), all samples at once.
    The platform is planar, so the range does not depend on the platform part of ``start``;
    it is memoized per robot model and limits.
    """
    symbols = robot.symbols
    owner, memo = _REACH.get(id(symbols), (None, {}))
    if owner is None or owner() is not symbols:  # new model (or a recycled id)
        memo = {}
        _REACH[id(symbols)] = (weakref.ref(symbols), memo)
    key = np.concatenate([robot.limits.joint_min, robot.limits.joint_max]).tobytes()
    if key not in memo:
        memo[key] = _vertical_reach(robot, start)
    return memo[key]


def _vertical_reach(robot: Robot, start: Array) -> tuple[float, float]:
    lo = np.clip(robot.limits.joint_min, -_WIDE, _WIDE)
    hi = np.clip(robot.limits.joint_max, -_WIDE, _WIDE)
    n_x, n_p = len(lo), robot.n_platform
    samples = lo + (hi - lo) * qmc.Halton(d=max(n_x, 1), scramble=False).random(_SAMPLES)[:, :n_x]
    q = np.repeat(start[None, :], _SAMPLES, axis=0)
    height = robot.functions["ee_position"].map(_SAMPLES)
    jacobian = robot.functions["jacobian"].map(_SAMPLES)
    ends = []
    for sign in (1.0, -1.0):
        x = samples.copy()
        for _ in range(_GRADIENT_STEPS):
            q[:, n_p:] = x
            grad = np.asarray(jacobian(q.T), float)[2].reshape(_SAMPLES, robot.n)[:, n_p:]
            x = np.clip(x + sign * _STEP * grad, lo, hi)
        q[:, n_p:] = x
        z = np.asarray(height(q.T), float)[2]
        ends.append(float(z.max() if sign > 0 else z.min()))
    return ends[1], ends[0]
