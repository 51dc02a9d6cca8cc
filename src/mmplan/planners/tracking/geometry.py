r"""Symbolic (CasADi) signed distances from points to obstacles, for the tracking planners.

The obstacle potential of paper 001 (eqs. (31)-(32)) and the virtual-impedance force
(eqs. (38)-(42)) need the distance d(q) from robot points to obstacles *inside* one compiled
control step, with gradients by automatic differentiation. The scene offers an exact NumPy
distance (for the checker) and a smooth superellipsoid model; for the shapes whose exact
signed distance has a short closed form we build that form symbolically, so the planner sees
the same geometry as the checker:

* sphere (``center``, ``radius``): :math:`d = |p - c| - r`;
* vertical cylinder (``base_center``, ``radius``, ``height``): with the radial excess
  :math:`u = \rho - r` and the axial excess :math:`v = \max(z_0 - z, z - z_1)`,
  :math:`d = \sqrt{\max(u,0)^2 + \max(v,0)^2} + \min(\max(u, v), 0)`;
* box (``center``, ``size``, ``yaw``): the same construction over the three axes of the
  box frame, :math:`e = |p'| - s/2`, :math:`d = |\max(e,0)| + \min(\max_i e_i, 0)`;
* any other shape: the radial Euclidean distance to its superellipsoid model
  (``Superellipsoid.radial_distance_sym``), smooth but only an approximation.

These are exact signed distances (negative inside), continuous everywhere and smooth except
on the medial axis and at edges, where CasADi returns one of the one-sided derivatives.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from mmplan.scene.obstacle import Obstacle

#: Guards sqrt at 0 so that gradients stay finite (distance error < 1e-9 m).
_EPS2 = 1e-18


def _norm(v: ca.SX) -> ca.SX:
    return ca.sqrt(ca.sumsqr(v) + _EPS2)


def _from_excess(excess: list[ca.SX]) -> ca.SX:
    """Signed distance of a convex region given per-axis excesses (box/cylinder SDF)."""
    outside = _norm(ca.vertcat(*[ca.fmax(e, 0) for e in excess]))
    inside = excess[0]
    for e in excess[1:]:
        inside = ca.fmax(inside, e)
    return outside + ca.fmin(inside, 0)


def _vec(obstacle: Obstacle, name: str) -> NDArray[np.float64]:
    """Field ``name`` of a shape (scenario key, e.g. ``center``) as a float array."""
    return np.asarray(getattr(obstacle, name), dtype=np.float64)


def _num(obstacle: Obstacle, name: str, default: float | None = None) -> float:
    """Scalar field ``name`` of a shape (e.g. ``radius``)."""
    return float(getattr(obstacle, name) if default is None else getattr(obstacle, name, default))


def signed_distance_sym(obstacle: Obstacle, p: ca.SX) -> ca.SX:
    """Signed distance from the point ``p`` (3,) (symbolic) to ``obstacle`` [m], negative inside.

    Args:
        obstacle: A scene obstacle (sphere, cylinder and box exactly, others via their
            superellipsoid model).
        p: Symbolic point (3, 1).

    Returns:
        Scalar expression d(p).
    """
    shape = obstacle.shape
    if shape == "sphere":
        return _norm(p - ca.DM(_vec(obstacle, "center"))) - _num(obstacle, "radius")
    if shape == "cylinder":
        base = _vec(obstacle, "base_center")
        radius, height = _num(obstacle, "radius"), _num(obstacle, "height")
        rho = _norm(p[:2] - ca.DM(base[:2]))
        axial = ca.fmax(base[2] - p[2], p[2] - (base[2] + height))
        return _from_excess([rho - radius, axial])
    if shape == "box":
        center = _vec(obstacle, "center")
        half = _vec(obstacle, "size") / 2.0
        yaw = _num(obstacle, "yaw", 0.0)
        cy, sy = np.cos(yaw), np.sin(yaw)
        d = p - ca.DM(center)
        local = ca.vertcat(cy * d[0] + sy * d[1], -sy * d[0] + cy * d[1], d[2])
        return _from_excess([ca.fabs(local[i]) - half[i] for i in range(3)])
    model = obstacle.superellipsoid()
    return model.radial_distance_sym(p)


def horizontal_distance_sym(obstacle: Obstacle, p: ca.SX) -> ca.SX:
    """Distance in the horizontal plane from ``p`` (3,) to ``obstacle`` [m].

    The point is moved to the height of the obstacle's middle before measuring, so a
    platform centre (at floor level) sees a post, cylinder or box by its footprint, as the
    planar virtual-impedance model of 001 section 3 assumes.
    """
    shape = obstacle.shape
    if shape == "cylinder":
        zc = _vec(obstacle, "base_center")[2] + _num(obstacle, "height") / 2
    elif shape in ("sphere", "box"):
        zc = _vec(obstacle, "center")[2]
    else:
        zc = float(np.asarray(obstacle.superellipsoid().center, dtype=np.float64)[2])
    return signed_distance_sym(obstacle, ca.vertcat(p[0], p[1], zc))
