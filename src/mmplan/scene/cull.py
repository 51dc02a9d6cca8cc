"""Culling: the obstacles of a scene that can matter to a plan, and those a plan came near.

A planner's model grows with the number of obstacles (a term, a parameter slot and a distance
per obstacle), so obstacles far from anything the robot can reach are left out before the
model is built (:meth:`mmplan.planners.base.Planner.plan`), and the plan is then verified
against the obstacles left out (:func:`near_points`). Both use only each shape's exact
distance, which is 1-Lipschitz: |d(x) - d(y)| <= |x - y|.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from mmplan.scene.fields import Array, points_array
from mmplan.scene.obstacle import Obstacle


def path_samples(path: ArrayLike, spacing: float) -> Array:
    """Points along the polyline ``path`` (K, 3) [m], at most ``spacing`` apart, (M, 3)."""
    p = points_array(path)
    if len(p) < 2:
        return p
    out = [p[:1]]
    for a, b in itertools.pairwise(p):
        steps = max(1, math.ceil(float(np.linalg.norm(b - a)) / spacing))
        s = np.linspace(0.0, 1.0, steps + 1)[1:, None]
        out.append(a + s * (b - a))
    return np.vstack(out)


def near_path(obstacles: Sequence[Obstacle], path: ArrayLike, radius: float) -> tuple[int, ...]:
    """Indices of the obstacles whose surface comes within ``radius`` [m] of the polyline
    ``path`` (K, 3); a few a little farther may be kept (never one nearer left out).

    The polyline is sampled at spacing h = radius / 4: a point of the polyline is within
    h / 2 of a sample, so an obstacle within ``radius`` of the polyline is within
    ``radius + h / 2`` of a sample.
    """
    if not obstacles:
        return ()
    h = max(radius, 1e-3) / 4.0
    samples = path_samples(path, h)
    return tuple(i for i, o in enumerate(obstacles)
                 if float(np.min(o.distance(samples))) <= radius + h / 2.0)


def near_points(obstacles: Sequence[Obstacle], points: ArrayLike, radii: ArrayLike,
                reach: Sequence[float]) -> tuple[int, ...]:
    """Indices of the obstacles that come within ``reach[i]`` [m] of a sphere (centres
    ``points`` (P, 3), ``radii`` (P,)): gap = distance - radius <= reach.

    Obstacles beyond a bounding sphere of all the spheres are skipped after one distance.
    """
    p = points_array(points)
    r = np.asarray(radii, dtype=float).reshape(-1)
    if not obstacles or p.shape[0] == 0:
        return ()
    centre = p.mean(axis=0)
    bound = float(np.max(np.linalg.norm(p - centre, axis=1) + r))
    out = []
    for i, o in enumerate(obstacles):
        if float(o.distance(centre[None, :])[0]) - bound > reach[i]:
            continue  # every sphere is farther than reach[i] from this obstacle
        if float(np.min(o.distance(p) - r)) <= reach[i]:
            out.append(i)
    return tuple(out)
