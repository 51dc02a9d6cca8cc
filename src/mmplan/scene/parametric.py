"""Obstacles as numbers: one symbolic signed distance per shape kind, the geometry a parameter.

A compiled function that takes an obstacle's geometry as input serves every scene with the
same shape kinds and counts: a moved, resized or turned obstacle changes numbers, not the
function (the tracking planners' compiled steps, :mod:`mmplan.planners.tracking.slots`). The
kinds with an exact closed-form distance have one here; the shapes' own
``signed_distance_sym`` call the same function with their numbers, so there is one formula
per kind.

Geometry vectors, per kind:

* ``sphere``: centre (3), radius;
* ``cylinder`` (vertical): base centre (3), radius, height;
* ``box``: centre (3), half extents (3), cos and sin of the yaw.

A planner's slot adds an active flag (:mod:`mmplan.planners.tracking.slots`): a parked slot's
geometry is far away, but far is relative (a robot near it would feel it), so its terms are
switched off by the flag, not by the distance alone.

A superellipsoid (smooth model, exponents fixed per type) has no kind here: a scene with one
keeps its planner's built-in geometry.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from mmplan.scene.obstacle import excess_distance_sym, norm_sym

#: Numbers of a kind's geometry vector.
SIZES = {"sphere": 4, "cylinder": 5, "box": 8}
#: Where an unused slot's obstacle sits [m]: far beyond any influence distance.
PARKED = 1e3


def kind_of(obstacle: Any) -> str | None:
    """The kind of ``obstacle`` (None: no parametric form). Only the built-in classes have
    one: a subclass (a shape registered outside mmplan) may measure its own distance, so it
    keeps it (a review's padded sphere was planned 12 cm inside its padding)."""
    kind = type(obstacle).__dict__.get("parametric_kind")
    return kind if kind in SIZES else None


def geometry(obstacle: Any, kind: str | None = None) -> tuple[float, ...]:
    """The geometry vector of ``obstacle`` as a ``kind`` (default: its own; module
    docstring)."""
    kind = kind or kind_of(obstacle)
    if kind == "sphere":
        return (*(float(v) for v in obstacle.center), float(obstacle.radius))
    if kind == "cylinder":
        base = tuple(float(v) for v in obstacle.base_center)
        return (*base, float(obstacle.radius), float(obstacle.height))
    if kind == "box":
        half = tuple(float(v) for v in obstacle.half_extents)
        yaw = float(obstacle.yaw)
        cy, sy = float(np.cos(yaw)), float(np.sin(yaw))  # NumPy's, as the box's own
        return (*(float(v) for v in obstacle.center), *half, cy, sy)
    raise ValueError(f"no parametric form for the shape {getattr(obstacle, 'shape', obstacle)}")


def parked(kind: str) -> tuple[float, ...]:
    """The geometry of an unused slot: a small obstacle ``PARKED`` metres away."""
    far = (PARKED, PARKED, PARKED)
    if kind == "sphere":
        return (*far, 0.1)
    if kind == "cylinder":
        return (*far, 0.1, 0.1)
    return (*far, 0.1, 0.1, 0.1, 1.0, 0.0)


def distance_sym(kind: str, p: ca.SX, g: ca.SX | ca.DM) -> ca.SX:
    """Signed distance of a point p (3, 1) to the obstacle of ``kind`` with geometry g [m]
    (exact; the same geometry as the shapes' ``distance``)."""
    if kind == "sphere":
        return norm_sym(p - g[0:3]) - g[3]
    if kind == "cylinder":
        rho = norm_sym(p[:2] - g[0:2])
        axial = ca.fmax(g[2] - p[2], p[2] - (g[2] + g[4]))
        return excess_distance_sym([rho - g[3], axial])
    if kind == "box":
        d = p - g[0:3]
        cy, sy = g[6], g[7]
        local = ca.vertcat(cy * d[0] + sy * d[1], -sy * d[0] + cy * d[1], d[2])
        return excess_distance_sym([ca.fabs(local[i]) - g[3 + i] for i in range(3)])
    raise ValueError(f"no parametric form for the kind {kind!r}")


def middle_z(kind: str, g: ca.SX | ca.DM) -> ca.SX | ca.DM:
    """Height of the obstacle's middle (its smooth model's centre): where a platform centre is
    moved to be measured by its footprint (``Obstacle.horizontal_distance_sym``)."""
    if kind == "cylinder":
        return g[2] + 0.5 * g[4]
    return g[2]
