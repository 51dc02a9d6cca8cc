"""Box obstacle (yawed about the vertical axis): closed-form signed distance.

Its planner model is the superellipsoid with exponents (0.1, 0.1) and the half edge lengths
as semi-axes.
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
    positive,
    to_local,
    vector,
)
from mmplan.scene.obstacle import Obstacle, Solid, register_shape
from mmplan.scene.smooth_model import SuperellipsoidModel

BOX_EXPONENTS = (0.1, 0.1)  # planner model exponents (e1, e2)


@register_shape
@dataclass(frozen=True)
class Box(Obstacle):
    """Box with full edge lengths ``size`` about ``center``, rotated by ``yaw`` about z.

    Attributes:
        center: Centre (3,) [m].
        size: Full edge lengths along the local x', y', z' axes (3,) [m], each > 0.
        yaw: Rotation about the vertical axis [rad].
        influence: Planner neighbourhood [m] or None (planner default).
    """

    shape: ClassVar[str] = "box"
    #: Its parametric form (:mod:`mmplan.scene.parametric`); not inherited by subclasses.
    parametric_kind: ClassVar[str] = "box"
    center: Vec3
    size: Vec3
    yaw: float = 0.0
    influence: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", vector(self.center, "center"))
        object.__setattr__(self, "size", vector(self.size, "size", 3, positive))
        object.__setattr__(self, "yaw", as_float(self.yaw, "yaw"))
        object.__setattr__(self, "influence", influence_value(self.influence))

    @property
    def half_extents(self) -> Vec3:
        """Half edge lengths (3,) [m]."""
        sx, sy, sz = self.size
        return (0.5 * sx, 0.5 * sy, 0.5 * sz)

    def distance(self, points: ArrayLike) -> Array:
        """Exact signed distance (P,) [m].

        With excess d = |p'| - half (componentwise, local frame): outside |max(d, 0)|,
        inside max_i d_i (< 0).
        """
        d = np.abs(to_local(points, self.center, self.yaw)) - np.asarray(self.half_extents)
        outside = np.linalg.norm(np.maximum(d, 0.0), axis=1)
        return np.asarray(outside + np.minimum(d.max(axis=1), 0.0), dtype=float)

    def signed_distance_sym(self, p: ca.SX) -> ca.SX:
        """Symbolic exact signed distance of a point p (3, 1) [m] (same form as ``distance``).

        Excess e = |p'| - half (local frame, componentwise): d = |max(e, 0)| + min(max_i e_i, 0).
        """
        return parametric.distance_sym("box", p, ca.DM(parametric.geometry(self, "box")))

    def enlarged(self, eps: float) -> Box:
        """Each half edge grown by ``eps`` [m] (a larger box, corners stay sharp)."""
        eps = as_float(eps, "eps")
        size = tuple(s + 2 * eps for s in self.size)
        return Box(self.center, size, self.yaw, self.influence)  # type: ignore[arg-type]

    def solid(self) -> Solid:
        """A yawed box primitive (full edge lengths)."""
        return Solid("box", tuple(float(v) for v in self.size), self.center, self.yaw)

    def superellipsoid(self) -> SuperellipsoidModel:
        """Model: semi-axes = half extents, exponents (0.1, 0.1), same centre and yaw."""
        return SuperellipsoidModel(
            self.center, self.half_extents, BOX_EXPONENTS, self.yaw, self.influence
        )
