r"""Barr superellipsoid: the smooth obstacle model every planner uses (docs/conventions.md).

With centre c, semi-axes (a1, a2, a3), exponents (e1, e2) (e1 the vertical one) and yaw psi,
p' = R_z(psi)^T (p - c) and ([PajakPajak] and [Pajak], Table 1)

.. math::  F(p) = \left(|x'/a_1|^{2/e_2} + |y'/a_2|^{2/e_2}\right)^{e_2/e_1} + |z'/a_3|^{2/e_1},

surface F = 1, inside F < 1. F is positively homogeneous of degree 2/e1 in p', so
p' F^{-e1/2} lies on the surface along the ray from the centre and the planner's radial
distance (docs/extended_jacobian.md, pitfalls) is

.. math::  C(p) = |p'| \left(1 - F(p)^{-e_1/2}\right).

Every obstacle gives its model by :meth:`mmplan.scene.obstacle.Obstacle.superellipsoid`; the
scenario shape ``superellipsoid`` (:class:`mmplan.scene.superellipsoid.Superellipsoid`) is an
obstacle whose distances delegate to this model. This module depends on no obstacle class.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from mmplan.errors import InputError
from mmplan.scene import _gauge
from mmplan.scene.fields import (
    Array,
    Vec3,
    as_float,
    influence_value,
    positive,
    to_local,
    vector,
)

_SMOOTH_FLOOR = 1e-150  # value of each smoothed |t|^(2/e) term at t = 0 (see implicit_sym)


def power_sym(x: ca.SX, a: float) -> ca.SX:
    """x^a for x > 0 with a constant exponent, by multiplications where a is a small integer
    or half-integer (x^10 = ((x^2)^2 x)^2, x^-0.5 = 1/sqrt(x)), else by ``pow``.

    Same value to rounding; the derivatives CasADi forms are then products too. Measured on
    the generator of youbot3r-obstacles (exponents 0.1 and 1, so powers 10, 1 and -0.5):
    see :mod:`mmplan.planners.extended_jacobian.generator`.
    """
    twice = 2.0 * a
    if abs(twice - round(twice)) > 1e-12 or abs(a) > 32:
        return x**a
    k = round(twice)
    half = k % 2 != 0
    m = abs(k) // 2
    out: ca.SX | None = None
    base = x
    while m:
        if m & 1:
            out = base if out is None else out * base
        m >>= 1
        if m:
            base = base * base
    if half:
        root = ca.sqrt(x)
        out = root if out is None else out * root
    if out is None:  # a = 0
        return 0 * x + 1
    return 1.0 / out if k < 0 else out


def _exponent(value: Any, field: str) -> float:
    out = as_float(value, field)
    if not 0.0 < out <= 2.0:
        raise InputError(field, f"expected an exponent in (0, 2] (convex shapes), got {value!r}")
    return out


@dataclass(frozen=True)
class SuperellipsoidModel:
    """Barr superellipsoid model of an obstacle (a value: no registry name, no scenario form).

    Attributes:
        center: Centre c (3,) [m].
        semi_axes: (a1, a2, a3) [m], along the local x', y', z' axes.
        exponents: (e1, e2): e1 shapes the vertical profile, e2 the horizontal cross-section;
            each in (0, 2] (1 = ellipsoid, -> 0 box-like, 2 octahedron-like).
        yaw: Rotation about the vertical axis [rad].
        influence: Planner neighbourhood [m] or None (planner default).
    """

    center: Vec3
    semi_axes: Vec3
    exponents: tuple[float, float]
    yaw: float = 0.0
    influence: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", vector(self.center, "center"))
        object.__setattr__(self, "semi_axes", vector(self.semi_axes, "semi_axes", 3, positive))
        object.__setattr__(self, "exponents", vector(self.exponents, "exponents", 2, _exponent))
        object.__setattr__(self, "yaw", as_float(self.yaw, "yaw"))
        object.__setattr__(self, "influence", influence_value(self.influence))

    # ----------------------------------------------------------------- numeric (NumPy)

    def local(self, points: ArrayLike) -> Array:
        """Local coordinates p' = R_z(yaw)^T (p - c) of world points (P, 3)."""
        return to_local(points, self.center, self.yaw)

    def implicit(self, points: ArrayLike) -> Array:
        """Inside-outside function F (P,) with exact |.| (F = 1 on the surface, < 1 inside)."""
        u = np.abs(self.local(points)) / np.asarray(self.semi_axes)
        e1, e2 = self.exponents
        with np.errstate(over="ignore", under="ignore"):
            return np.asarray(
                (u[:, 0] ** (2 / e2) + u[:, 1] ** (2 / e2)) ** (e2 / e1) + u[:, 2] ** (2 / e1),
                dtype=float,
            )

    def gauge(self, points: ArrayLike) -> Array:
        """Gauge G = F^(e1/2) (P,), homogeneous of degree 1, evaluated without overflow."""
        u = np.abs(self.local(points)) / np.asarray(self.semi_axes)
        e1, e2 = self.exponents
        return _gauge.gauge(u, 2.0 / e2, 2.0 / e1)

    def radial_distance(self, points: ArrayLike) -> Array:
        """Radial distance C = |p'| (1 - F^(-e1/2)) = |p'| (1 - 1/G) (P,) [m].

        The distance from p to the surface along the ray from the centre; negative inside.
        At the centre itself it is set to -min(a) (the limit along the shortest semi-axis).
        """
        local = self.local(points)
        norm = np.linalg.norm(local, axis=1)
        g = _gauge.gauge(
            np.abs(local) / np.asarray(self.semi_axes),
            2.0 / self.exponents[1],
            2.0 / self.exponents[0],
        )
        at_centre = g <= 0.0
        out = norm - norm / np.where(at_centre, 1.0, g)
        return np.where(at_centre, -min(self.semi_axes), out)

    def distance(self, points: ArrayLike) -> Array:
        """Exact signed Euclidean distance to the surface (P,) [m], negative inside.

        Nearest point of a dense surface sample (k-d tree), then Newton on the closest-point
        conditions (plus a pattern-search polish for exponents > 1); details, accuracy and
        cost in :mod:`mmplan.scene._gauge`. Within 1e-6 m of an independent brute-force
        reference in the tests (typically 1e-11 m).
        """
        e1, e2 = self.exponents
        return _gauge.signed_distance(self.local(points), self.semi_axes, e1, e2)

    # ------------------------------------------------------------ symbolic (CasADi)

    def local_sym(self, p: ca.SX) -> ca.SX:
        """Local coordinates R_z(yaw)^T (p - c) of a symbolic point p (3, 1)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        d = p - ca.DM(self.center)
        return ca.vertcat(c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2])

    def implicit_sym(self, p: ca.SX) -> ca.SX:
        r"""Smooth symbolic F(p) for a point p (3, 1) (works for SX and MX).

        |t|^(2/e) is replaced by (t^2 + eps^2)^(1/e) (t scaled by the semi-axis) with
        eps = 1e-150^(e/2), so every term is >= 1e-150 (no underflow to 0, where the outer
        power would give inf * 0 = NaN in derivatives) and the first derivatives are finite
        everywhere, on the coordinate planes and the vertical axis included. The change of F
        is 1e-150 at t = 0 and relatively eps^2 / (e t^2) elsewhere (eps <= 10^-7.5 for
        e >= 0.1, 1e-75 for e = 1): negligible.
        """
        e1, e2 = self.exponents
        loc = self.local_sym(p)
        u = [loc[i] / self.semi_axes[i] for i in range(3)]

        def term(t: ca.SX, e: float) -> ca.SX:
            eps = _SMOOTH_FLOOR ** (e / 2.0)
            return power_sym(t**2 + eps**2, 1.0 / e)

        return power_sym(term(u[0], e2) + term(u[1], e2), e2 / e1) + term(u[2], e1)

    def radial_distance_sym(self, p: ca.SX) -> ca.SX:
        """Symbolic radial distance C = |p'| (1 - F^(-e1/2)) of a point p (3, 1).

        Finite derivatives everywhere except at the centre (|p'| = 0).
        """
        loc = self.local_sym(p)
        norm = ca.sqrt(ca.sumsqr(loc))
        return norm * (1.0 - power_sym(self.implicit_sym(p), -self.exponents[0] / 2.0))

    def signed_distance_sym(self, p: ca.SX) -> ca.SX:
        """The radial distance :meth:`radial_distance_sym`: smooth, but only an approximation
        of the Euclidean distance d (same sign and zero set, |C| >= |d|).
        """
        return self.radial_distance_sym(p)

    # --------------------------------------------------------------------- variants

    def enlarged(self, eps: float) -> SuperellipsoidModel:
        """Semi-axes grown by ``eps`` [m] (docs/conventions.md); same centre, exponents, yaw."""
        eps = as_float(eps, "eps")
        return SuperellipsoidModel(
            self.center,
            tuple(a + eps for a in self.semi_axes),  # type: ignore[arg-type]
            self.exponents,
            self.yaw,
            self.influence,
        )
