"""Which collision spheres the floor applies to.

The floor z = h (``Scene.ground``) is an obstacle for every body whose height can change with
the configuration: arm links, a torso, a hand. A body rigid to the platform (the chassis, the
wheels, which touch the floor by design) keeps the same height under any planar motion, so
its floor clearance is a constant of the robot, not of the plan; those spheres are left out.
The rule is read from the model itself: sphere i is kept when the z of its centre depends on
the configuration q (``casadi.depends_on``).
"""

from __future__ import annotations

import casadi as ca

from mmplan.robot.robot import Robot


def ground_sphere_indices(robot: Robot) -> tuple[int, ...]:
    """Indices (into ``robot.collision``) of the spheres whose height depends on q."""
    cached = robot._shared.get("ground_spheres")
    if cached is None:
        s = robot.symbols
        points = s.collision_points  # (3, P)
        cached = tuple(i for i in range(len(robot.collision)) if ca.depends_on(points[2, i], s.q))
        robot._shared["ground_spheres"] = cached
    return tuple(cached)
