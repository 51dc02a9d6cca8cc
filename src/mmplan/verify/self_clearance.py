"""Self-collision of a trajectory: the smallest distance between the robot's own bodies.

A robot with self-collision pairs (URDF robots, :class:`~mmplan.robot.self_collision.
SelfCollision`: sphere pairs of bodies that are not adjacent and apart in the reference pose)
is checked with exactly those pairs and their distance ``|p_i - p_j| - r_i - r_j``
(:meth:`~mmplan.robot.self_collision.SelfCollision.distances`), the sphere centres by forward
kinematics of every sample at once. Negative: two bodies overlap (a failed check).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.robot import Robot
from mmplan.robot.self_collision import SelfCollision


def self_clearance_over(robot: Robot, q: Array, t: Array) -> tuple[float | None, str]:
    """Smallest signed self-collision distance over the samples q (N, n) [m], and where
    (``"<body> vs <body> at t = ... s"``); ``(None, "")`` for a robot without pairs."""
    pairs: SelfCollision | None = getattr(robot, "self_collision", None)
    if pairs is None or not len(pairs.sphere_pairs) or not robot.collision:
        return None, ""
    N, P = q.shape[0], len(robot.collision)
    fn: ca.Function = robot.functions["collision_points"]
    pts = np.asarray(fn.map(N)(np.ascontiguousarray(q.T)), dtype=float)  # (3, N * P)
    pts = pts.T.reshape(N, P, 3)  # sample-major
    radii = robot.collision_radii
    best, where = np.inf, (0, 0)
    for k in range(N):
        gaps = pairs.distances(pts[k], radii)  # (K,)
        i = int(np.argmin(gaps))
        if gaps[i] < best:
            best, where = float(gaps[i]), (k, i)
    k, i = where
    a, b = (robot.collision[int(s)].body for s in pairs.sphere_pairs[i])
    return best, f"{a} vs {b} at t = {t[k]:.4g} s"
