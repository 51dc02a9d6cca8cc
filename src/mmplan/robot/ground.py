r"""Which collision spheres the floor applies to, and their clearance above it.

The floor z = h (``Scene.ground``) is an obstacle for every body whose height can change with
the arm: arm links, a torso, a hand. A body moved by the platform coordinates alone keeps its
height under any motion of the platform: the chassis and anything rigid to it (planar x, y,
heading), a steered axle (turning about a vertical axis), and the wheels, which touch the floor
by design (a wheel's collision spheres spin with the wheel angle, so their height does depend
on q, but not on the arm: TIAGo's wheel spheres reach 1.9 to 5.1 cm below z = 0 in every
pose). Their floor clearance is not the plan's to keep, and those spheres are left out.

The rule is read from the model itself: sphere i is kept when the z of its centre depends on
an arm coordinate (``casadi.depends_on`` on the symbolic collision points). A link turning
about a vertical axis (a youBot's first joint) has a z that depends on no coordinate and is
left out too.

Floor clearance of a kept sphere i with centre :math:`p_i(q)` and radius :math:`r_i`:

.. math:: c_i(q) = p_{i,z}(q) - r_i - h \quad [m]

(negative: the sphere penetrates the floor).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.compile.disk_memo import remember
from mmplan.robot.robot import Robot


def ground_sphere_indices(robot: Robot) -> tuple[int, ...]:
    """Indices (into ``robot.collision``) of the spheres whose height depends on an arm
    coordinate (module doc): the spheres the floor applies to. Read off the symbolic model
    once per model and kept on disk (:func:`mmplan.compile.disk_memo.remember`): a run with
    the robot's compiled functions on disk then never builds the model (42 ms for youbot-3r)."""
    cached = robot._shared.get("ground_spheres")
    if cached is None:

        def compute() -> tuple[int, ...]:
            s = robot.symbols
            points = s.collision_points  # (3, P)
            arm = ca.vertcat(*[s.q[i] for i in robot.arm_indices]) if robot.arm_indices else None
            return tuple(
                i for i in range(len(robot.collision))
                if arm is not None and ca.depends_on(points[2, i], arm)
            )  # fmt: skip

        def decode(data: object) -> tuple[int, ...]:
            P = len(robot.collision)
            if not isinstance(data, list) or not all(
                type(i) is int and 0 <= i < P for i in data
            ) or data != sorted(set(data)):
                raise ValueError("not increasing sphere indices of this robot")
            return tuple(data)

        cached = remember(robot, __file__, "ground_spheres", 0, compute, list, decode)
        robot._shared["ground_spheres"] = cached
    return tuple(cached)


def floor_clearance_sym(robot: Robot, ground: float) -> ca.SX:
    """Symbolic clearances c_i(q) = z_i - r_i - h of the ground spheres, (G, 1) SX in
    ``robot.symbols.q`` (empty when the robot has none)."""
    idx = ground_sphere_indices(robot)
    if not idx:
        return ca.SX(0, 1)
    z = ca.vertcat(*[robot.symbols.collision_points[2, i] for i in idx])
    radii = np.asarray(robot.collision_radii, dtype=float)[list(idx)]
    return z - ca.DM(radii + float(ground))


def floor_clearances(robot: Robot, q: Array, ground: float) -> Array:
    """Clearances c_i(q_k) of the ground spheres at configurations ``q`` (N, n), (N, G) [m]."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    idx = ground_sphere_indices(robot)
    N = q.shape[0]
    if not idx or N == 0:
        return np.zeros((N, len(idx)))
    natives = robot.compiled()
    if natives is not None:  # the same heights from the compiled collision points, same bits
        radii = np.asarray(robot.collision_radii, dtype=float)[list(idx)]
        z = natives.many("collision_points", q)[:, [3 * i + 2 for i in idx]]  # (N, G)
        return np.asarray(z - radii - float(ground), dtype=float)
    fn = robot._shared.get("floor_clearance_fn")
    if fn is None:  # c_i(q) at h = 0: only the ground spheres' heights, one small function
        fn = ca.Function("floor_clearance", [robot.symbols.q], [floor_clearance_sym(robot, 0.0)])
        robot._shared["floor_clearance_fn"] = fn
    c = np.asarray(fn.map(N)(np.ascontiguousarray(q.T)), dtype=float)  # (G, N)
    return np.asarray(c.T - float(ground), dtype=float)


__all__ = ["floor_clearance_sym", "floor_clearances", "ground_sphere_indices"]
