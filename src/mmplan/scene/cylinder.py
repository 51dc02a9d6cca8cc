"""Vertical cylinder obstacle (finite, flat caps): closed-form signed distance.

Its planner model is the superellipsoid with exponents (e1, e2) = (0.1, 1.0): a round
horizontal cross-section and a nearly flat top and bottom ([PajakPajak] Table 1).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from mmplan.scene import parametric
from mmplan.scene.fields import (
    Array,
    Vec3,
    as_float,
    influence_value,
    points_array,
    positive,
    vector,
)
from mmplan.scene.obstacle import (
    Obstacle,
    Solid,
    register_shape,
)
from mmplan.scene.smooth_model import SuperellipsoidModel

CYLINDER_EXPONENTS = (0.1, 1.0)  # (vertical e1, horizontal e2) of the planner model


@register_shape
@dataclass(frozen=True)
class Cylinder(Obstacle):
    """Cylinder with a vertical axis, standing on ``base_center``.

    Attributes:
        base_center: Centre of the bottom cap (3,) [m].
        radius: Radius [m], > 0.
        height: Height [m], > 0 (the top cap is at base_center z + height).
        influence: Planner neighbourhood [m] or None (planner default).
    """

    shape: ClassVar[str] = "cylinder"
    #: Its parametric form (:mod:`mmplan.scene.parametric`); not inherited by subclasses.
    parametric_kind: ClassVar[str] = "cylinder"
    base_center: Vec3
    radius: float
    height: float
    influence: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "base_center", vector(self.base_center, "base_center"))
        object.__setattr__(self, "radius", positive(self.radius, "radius"))
        object.__setattr__(self, "height", positive(self.height, "height"))
        object.__setattr__(self, "influence", influence_value(self.influence))

    @property
    def center(self) -> Vec3:
        """Centre of the solid (3,) [m] (half way up the axis)."""
        x, y, z = self.base_center
        return (x, y, z + 0.5 * self.height)

    def distance(self, points: ArrayLike) -> Array:
        """Exact signed distance (P,) [m].

        With radial excess d_r = |p_xy - c_xy| - r and axial excess d_z = |z - c_z| - h/2:
        outside |(max(d_r, 0), max(d_z, 0))|, inside max(d_r, d_z) (< 0).
        """
        p = points_array(points) - np.asarray(self.center)
        d_r = np.hypot(p[:, 0], p[:, 1]) - self.radius
        d_z = np.abs(p[:, 2]) - 0.5 * self.height
        outside = np.hypot(np.maximum(d_r, 0.0), np.maximum(d_z, 0.0))
        return np.asarray(outside + np.minimum(np.maximum(d_r, d_z), 0.0), dtype=float)

    def signed_distance_sym(self, p: ca.SX) -> ca.SX:
        """Symbolic exact signed distance of a point p (3, 1) [m] (same form as ``distance``).

        Radial excess u = |p_xy - c_xy| - r and axial excess v = max(z_0 - z, z - z_1)
        (z_0, z_1 the caps): d = |(max(u, 0), max(v, 0))| + min(max(u, v), 0).
        """
        return parametric.distance_sym("cylinder", p, ca.DM(parametric.geometry(self, "cylinder")))

    def enlarged(self, eps: float) -> Cylinder:
        """Radius and half height grown by ``eps`` [m] (centre kept)."""
        eps = as_float(eps, "eps")
        x, y, z = self.base_center
        return Cylinder((x, y, z - eps), self.radius + eps, self.height + 2 * eps, self.influence)

    def solid(self) -> Solid:
        """A vertical cylinder primitive, centred at mid-height."""
        return Solid("cylinder", (self.radius, self.height), self.center)

    def superellipsoid(self) -> SuperellipsoidModel:
        """Model: semi-axes (r, r, h/2) about the centre, exponents (0.1, 1.0)."""
        r = self.radius
        return SuperellipsoidModel(
            self.center, (r, r, 0.5 * self.height), CYLINDER_EXPONENTS, 0.0, self.influence
        )
