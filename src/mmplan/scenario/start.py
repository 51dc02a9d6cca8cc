"""A scenario's start configuration q0: a list in the robot's order, or a mapping by name.

``start: [0, 0, 0, ...]`` lists every coordinate in the robot's order (``mmplan robots``);
``start: {x: 1.0, theta: 0.5, arm_1_joint: 0.2}`` names some of them, and the others take
their **defaults**: 0 for the platform coordinates (x, y, heading, wheel angles, a car's
steering angle), and for an arm joint 0, or the limit nearest 0 when 0 is outside its range
(the reference pose in which a URDF robot's self-collision pairs were chosen). Unknown names
are errors that list the robot's coordinates. :func:`check_start_pose` then checks the start
against the joint limits, the robot's self-collision pairs, the floor (``ground``) and the
obstacles.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.robot import Robot
from mmplan.robot.ground import floor_clearances, ground_sphere_indices
from mmplan.robot.self_collision import SelfCollision
from mmplan.scene import Scene


def default_start(robot: Robot) -> Array:
    """q0 with every coordinate at its default (see the module doc), (n,)."""
    q = np.zeros(robot.n)
    lim = robot.limits
    for j, i in enumerate(robot.arm_indices):
        q[i] = float(np.clip(0.0, lim.joint_min[j], lim.joint_max[j]))
    return q


def resolve_start(values: Sequence[float] | Mapping[str, float], robot: Robot) -> Array:
    """q0 (n,) from a scenario's ``start`` (a list in q order, or a mapping name -> value).

    Raises:
        InputError: a list of the wrong length, or an unknown coordinate name.
    """
    if isinstance(values, Mapping):
        q = default_start(robot)
        for name, value in values.items():
            if name not in robot.coordinates:
                raise InputError(f"start.{name}", f"unknown coordinate {name!r} of "
                                 f"{robot.name}; valid: {', '.join(robot.coordinates)}")
            q[robot.coordinates.index(name)] = float(value)
        return q
    if len(values) != robot.n:
        names = ", ".join(robot.coordinates[:3]) + (", ..." if robot.n > 3 else "")
        raise InputError("start", f"expected {robot.n} values ({names}), got {len(values)}; "
                         "or give a mapping {name: value}")
    return np.asarray(values, dtype=float)


def check_start_pose(robot: Robot, scene: Scene, start: Array, *, by_name: bool = False) -> None:
    """Start inside the joint limits, free of self-collision (the robot's sphere pairs), above
    the floor (the ground spheres, :mod:`mmplan.robot.ground`) and collision-free (original
    obstacles, exact distance); ``by_name``: the start was given as
    a mapping (errors name ``start.<coordinate>``).

    Raises:
        InputError: naming the coordinate, the two bodies, or the robot point and obstacle.
    """
    lim = robot.limits
    for j, i in enumerate(robot.arm_indices):
        lo, hi = lim.joint_min[j], lim.joint_max[j]
        if not lo <= start[i] <= hi:
            key = f"start.{robot.coordinates[i]}" if by_name else f"start[{i}]"
            raise InputError(key, f"{robot.coordinates[i]} = {start[i]:g} outside the "
                             f"joint limits [{lo:g}, {hi:g}]")
    if not robot.collision:
        return
    points = robot.collision_points(start)  # (P, 3)
    pairs: SelfCollision | None = getattr(robot, "self_collision", None)
    if pairs is not None and len(pairs.sphere_pairs):
        gaps = pairs.distances(points, robot.collision_radii)  # (K,)
        k = int(np.argmin(gaps))
        if gaps[k] < 0:
            a, b = (robot.collision[int(i)].body for i in pairs.sphere_pairs[k])
            raise InputError("start", f"in self-collision: {a} and {b} overlap by "
                             f"{-gaps[k]:.4g} m (their collision spheres)")
    if scene.ground is not None:
        _check_floor(robot, scene.ground, start)
    if not scene.obstacles:
        return
    gap = scene.distances(points) - robot.collision_radii[:, None]  # (P, n_obs)
    p, o = np.unravel_index(int(np.argmin(gap)), gap.shape)
    if gap[p, o] < 0:
        x, y, z = points[p]
        raise InputError("start", f"in collision: robot point {p} (on {robot.collision[p].body}, "
                         f"at ({x:.3f}, {y:.3f}, {z:.3f})) is {-gap[p, o]:.6g} m inside "
                         f"obstacles[{o}]")


def _check_floor(robot: Robot, ground: float, start: Array) -> None:
    """The start's ground spheres (:mod:`mmplan.robot.ground`) above the floor z = ground."""
    gaps = floor_clearances(robot, start[None, :], ground)[0]  # (G,)
    if gaps.size and gaps.min() < 0:
        k = int(np.argmin(gaps))
        i = ground_sphere_indices(robot)[k]
        raise InputError("start", f"in collision with the floor: robot point {i} (on "
                         f"{robot.collision[i].body}) is {-gaps[k]:.6g} m below the floor "
                         f"z = {ground:g} (lower it or remove it with the scenario key ground)")


__all__ = ["check_start_pose", "default_start", "resolve_start"]
