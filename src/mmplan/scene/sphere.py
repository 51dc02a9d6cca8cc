"""Sphere obstacle: closed-form signed distance; superellipsoid model with exponents (1, 1)."""

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
from mmplan.scene.obstacle import Obstacle, Solid, register_shape
from mmplan.scene.smooth_model import SuperellipsoidModel


@register_shape
@dataclass(frozen=True)
class Sphere(Obstacle):
    """Sphere of ``radius`` [m] about ``center`` (3,) [m].

    Attributes:
        center: Centre (3,) [m].
        radius: Radius [m], > 0.
        influence: Planner neighbourhood [m] or None (planner default).
    """

    shape: ClassVar[str] = "sphere"
    #: Its parametric form (:mod:`mmplan.scene.parametric`); not inherited by subclasses.
    parametric_kind: ClassVar[str] = "sphere"
    center: Vec3
    radius: float
    influence: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", vector(self.center, "center"))
        object.__setattr__(self, "radius", positive(self.radius, "radius"))
        object.__setattr__(self, "influence", influence_value(self.influence))

    def distance(self, points: ArrayLike) -> Array:
        """Signed distance |p - c| - r (P,) [m] (exact)."""
        return np.asarray(
            np.linalg.norm(points_array(points) - np.asarray(self.center), axis=1) - self.radius,
            dtype=float,
        )

    def signed_distance_sym(self, p: ca.SX) -> ca.SX:
        """Symbolic signed distance |p - c| - r of a point p (3, 1) [m] (exact)."""
        return parametric.distance_sym("sphere", p, ca.DM(parametric.geometry(self, "sphere")))

    def enlarged(self, eps: float) -> Sphere:
        """Radius grown by ``eps`` [m]."""
        return Sphere(self.center, self.radius + as_float(eps, "eps"), self.influence)

    def solid(self) -> Solid:
        """A sphere primitive."""
        return Solid("sphere", (self.radius,), self.center)

    def superellipsoid(self) -> SuperellipsoidModel:
        """Exact model: semi-axes (r, r, r), exponents (1, 1)."""
        r = self.radius
        return SuperellipsoidModel(self.center, (r, r, r), (1.0, 1.0), 0.0, self.influence)
