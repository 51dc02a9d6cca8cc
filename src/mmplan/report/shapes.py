"""Drawable outlines of obstacles, sampled from their superellipsoid models.

Every obstacle offers a superellipsoid (docs/conventions.md) with an inside-outside function F
(F < 1 inside, F = 1 on the surface). A superellipsoid is star-shaped about its centre, so
the surface point along a ray from the centre is found by bisection on F along the ray; this
needs nothing but ``implicit(points)`` and ``center``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mmplan.arrays import Array

_BISECTIONS = 48


def _center(model: Any) -> Array:
    return np.asarray(model.center, dtype=float).reshape(3)


def surface_along_rays(model: Any, directions: Array) -> Array:
    """Surface points of ``model`` along rays from its centre (R, 3).

    Args:
        model: SuperellipsoidModel with ``center`` and ``implicit(points (P, 3)) -> (P,)``.
        directions: Ray directions (R, 3), not necessarily unit.

    Returns:
        Points c + s_i d_i with F = 1 (to 2^-48 of the bracket), (R, 3).
    """
    c = _center(model)
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    hi = np.full(len(d), 1e-3)
    for _ in range(60):  # grow the bracket until every ray is outside
        outside = np.asarray(model.implicit(c + hi[:, None] * d)) > 1.0
        if outside.all():
            break
        hi = np.where(outside, hi, 2.0 * hi)
    lo = np.zeros(len(d))
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        inside = np.asarray(model.implicit(c + mid[:, None] * d)) <= 1.0
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    return np.asarray(c + (0.5 * (lo + hi))[:, None] * d, dtype=float)


def top_outline(model: Any, count: int = 96) -> Array:
    """Horizontal cross-section through the centre (the widest for a superellipsoid), (count, 2).

    Closed polygon: the last point repeats the first.
    """
    a = np.linspace(0.0, 2.0 * np.pi, count)
    dirs = np.column_stack([np.cos(a), np.sin(a), np.zeros_like(a)])
    return surface_along_rays(model, dirs)[:, :2]


def wireframe(model: Any, meridians: int = 12, parallels: int = 7, steps: int = 24) -> list[Array]:
    """Polylines (each (k, 3)) of meridians and parallels of the surface, for the 3D view."""
    lines: list[Array] = []
    elevation = np.linspace(-np.pi / 2, np.pi / 2, steps + 1)
    for azimuth in np.linspace(0.0, 2.0 * np.pi, meridians, endpoint=False):
        dirs = np.column_stack(
            [
                np.cos(elevation) * np.cos(azimuth),
                np.cos(elevation) * np.sin(azimuth),
                np.sin(elevation),
            ]
        )
        lines.append(surface_along_rays(model, dirs))
    azimuths = np.linspace(0.0, 2.0 * np.pi, 2 * steps + 1)
    for el in np.linspace(-np.pi / 2, np.pi / 2, parallels + 2)[1:-1]:
        dirs = np.column_stack(
            [
                np.cos(el) * np.cos(azimuths),
                np.cos(el) * np.sin(azimuths),
                np.full_like(azimuths, np.sin(el)),
            ]
        )
        lines.append(surface_along_rays(model, dirs))
    return lines
