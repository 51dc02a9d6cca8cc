r"""Floor clearance of a trajectory: the ground spheres above the floor z = h.

The floor (``Scene.ground``, scenario key ``ground``) is an obstacle for the collision spheres
whose height depends on the arm (:func:`~mmplan.robot.ground.ground_sphere_indices`). The
clearance of sphere i at configuration q is :math:`c_i(q) = p_{i,z}(q) - r_i - h`; the plan
passes when :math:`\min c_i \ge` ``FLOOR_TOL`` (0 m: touching is allowed, penetrating is not)
over every sample **and** over the motion between samples: the cubic Hermite interpolant
through :math:`(t_k, q_k, \dot q_k)` (:mod:`mmplan.interpolant`, the trajectory's meaning
between samples) at ``FLOOR_SUBSAMPLES`` interior points of every step.
"""

from __future__ import annotations

import numpy as np

from mmplan.arrays import Array
from mmplan.interpolant import evaluate
from mmplan.robot.ground import floor_clearances, ground_sphere_indices
from mmplan.robot.robot import Robot

#: Smallest floor clearance a plan may have [m].
FLOOR_TOL = 0.0
#: Interior points of every step at which the interpolated motion is checked too.
FLOOR_SUBSAMPLES = 3


def floor_clearance_over(robot: Robot, ground: float | None, t: Array, q: Array,
                         dq: Array) -> tuple[float | None, str]:
    """Smallest floor clearance [m] over the samples and the interpolated motion, and where.

    Args:
        robot: The robot (its ground spheres).
        ground: Floor height h [m]; None: no floor.
        t, q, dq: Sample times (N,), configurations and velocities (N, n).

    Returns:
        (clearance, where); (None, "") without a floor or without ground spheres.
    """
    idx = ground_sphere_indices(robot)
    if ground is None or not idx or len(t) == 0:
        return None, ""
    gaps = floor_clearances(robot, q, ground)  # (N, G)
    k, g = (int(i) for i in np.unravel_index(int(np.argmin(gaps)), gaps.shape))
    best, where = float(gaps[k, g]), f"at t = {t[k]:.4g} s"
    steps = np.diff(t)
    if len(t) >= 2 and np.all(np.isfinite(t)) and np.all(steps > 0):
        s = np.arange(1, FLOOR_SUBSAMPLES + 1) / (FLOOR_SUBSAMPLES + 1)
        times = (t[:-1, None] + steps[:, None] * s[None, :]).ravel()  # (M,) step-major
        q_between = evaluate(t, q, dq, times)[0]
        between = floor_clearances(robot, q_between, ground)  # (M, G)
        m, gm = (int(i) for i in np.unravel_index(int(np.argmin(between)), between.shape))
        if between[m, gm] < best:
            step = m // FLOOR_SUBSAMPLES
            best, g = float(between[m, gm]), gm
            where = (f"at t = {times[m]:.4g} s (between samples {step} and {step + 1}, "
                     "on the interpolated motion)")
    i = idx[g]
    return best, f"robot point {i} (on {robot.collision[i].body}) {where}, floor z = {ground:g} m"


__all__ = ["FLOOR_SUBSAMPLES", "FLOOR_TOL", "floor_clearance_over"]
