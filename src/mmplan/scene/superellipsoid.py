"""Superellipsoid obstacle: the scenario shape ``superellipsoid`` (docs/conventions.md).

The Barr superellipsoid given directly by its model parameters. Its planner model
(:meth:`Superellipsoid.superellipsoid`) is the
:class:`~mmplan.scene.smooth_model.SuperellipsoidModel` with the same fields, and every
distance of the shape (exact, radial, symbolic) delegates to that model, where the math lives
(formulas: :mod:`mmplan.scene.smooth_model`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import cached_property
from typing import ClassVar

import casadi as ca
from numpy.typing import ArrayLike

from mmplan.scene.fields import Array, Vec3
from mmplan.scene.obstacle import Obstacle, register_shape
from mmplan.scene.smooth_model import SuperellipsoidModel


@register_shape
@dataclass(frozen=True)
class Superellipsoid(Obstacle):
    """Barr superellipsoid obstacle; validated, and measured, by its model.

    Attributes:
        center: Centre c (3,) [m].
        semi_axes: (a1, a2, a3) [m], along the local x', y', z' axes.
        exponents: (e1, e2): e1 shapes the vertical profile, e2 the horizontal cross-section;
            each in (0, 2] (1 = ellipsoid, -> 0 box-like, 2 octahedron-like).
        yaw: Rotation about the vertical axis [rad].
        influence: Planner neighbourhood [m] or None (planner default).
    """

    shape: ClassVar[str] = "superellipsoid"
    center: Vec3
    semi_axes: Vec3
    exponents: tuple[float, float]
    yaw: float = 0.0
    influence: float | None = None

    def __post_init__(self) -> None:
        model = SuperellipsoidModel(
            self.center, self.semi_axes, self.exponents, self.yaw, self.influence
        )
        for f in dataclasses.fields(model):  # the model's validated values
            object.__setattr__(self, f.name, getattr(model, f.name))

    @cached_property
    def _model(self) -> SuperellipsoidModel:
        return SuperellipsoidModel(
            self.center, self.semi_axes, self.exponents, self.yaw, self.influence
        )

    def superellipsoid(self) -> SuperellipsoidModel:
        """The model with the same fields (the shape is already smooth)."""
        return self._model

    def enlarged(self, eps: float) -> Superellipsoid:
        """Semi-axes grown by ``eps`` [m] (docs/conventions.md); same centre, exponents, yaw."""
        m = self._model.enlarged(eps)
        return Superellipsoid(m.center, m.semi_axes, m.exponents, m.yaw, m.influence)

    # ------------------------------------------------- numeric (NumPy), by the model

    def local(self, points: ArrayLike) -> Array:
        """Local coordinates p' (P, 3): :meth:`SuperellipsoidModel.local`."""
        return self._model.local(points)

    def implicit(self, points: ArrayLike) -> Array:
        """Inside-outside function F (P,): :meth:`SuperellipsoidModel.implicit`."""
        return self._model.implicit(points)

    def gauge(self, points: ArrayLike) -> Array:
        """Gauge G = F^(e1/2) (P,): :meth:`SuperellipsoidModel.gauge`."""
        return self._model.gauge(points)

    def radial_distance(self, points: ArrayLike) -> Array:
        """Radial distance C (P,) [m]: :meth:`SuperellipsoidModel.radial_distance`."""
        return self._model.radial_distance(points)

    def distance(self, points: ArrayLike) -> Array:
        """Exact signed distance (P,) [m]: :meth:`SuperellipsoidModel.distance`."""
        return self._model.distance(points)

    # ---------------------------------------------- symbolic (CasADi), by the model

    def local_sym(self, p: ca.SX) -> ca.SX:
        """Local coordinates of a symbolic point: :meth:`SuperellipsoidModel.local_sym`."""
        return self._model.local_sym(p)

    def implicit_sym(self, p: ca.SX) -> ca.SX:
        """Smooth symbolic F(p): :meth:`SuperellipsoidModel.implicit_sym`."""
        return self._model.implicit_sym(p)

    def radial_distance_sym(self, p: ca.SX) -> ca.SX:
        """Symbolic radial distance C: :meth:`SuperellipsoidModel.radial_distance_sym`."""
        return self._model.radial_distance_sym(p)

    def signed_distance_sym(self, p: ca.SX) -> ca.SX:
        """The radial distance :meth:`radial_distance_sym`: smooth, but only an approximation
        of the Euclidean distance d (same sign and zero set, |C| >= |d|).
        """
        return self._model.signed_distance_sym(p)
