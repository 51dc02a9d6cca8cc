"""Drawable geometry: obstacle outlines and meshes, tubes along paths.

Obstacles are drawn in their true shapes (a box as a box, a cylinder as a cylinder); only a
superellipsoid needs a mesh (:func:`superellipsoid_mesh`, Barr's parametric surface) and a
top-view outline. The planners' influence neighbourhoods are the superellipsoid models
enlarged by the margin and the influence: their outlines come from :func:`top_outline`, which
finds the surface along rays from the centre by bisection (every model is star-shaped about
its centre and gives ``implicit(points)``, F < 1 inside, F = 1 on the surface).
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


def _yawed(xy: Array, center: Array, yaw: float) -> Array:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.asarray(xy @ np.array([[c, s], [-s, c]]) + center[:2], dtype=float)


def footprint(obstacle: Any, count: int = 96) -> Array:
    """The obstacle's outline seen from above in its true shape (k, 2), closed.

    A box is its (yawed) rectangle, a cylinder or a sphere its circle; any other shape the
    widest horizontal section of its superellipsoid model.
    """
    a = np.linspace(0.0, 2.0 * np.pi, count)
    circle = np.column_stack([np.cos(a), np.sin(a)])
    solid = obstacle.solid()
    centre = np.asarray(solid.center, dtype=float)
    if solid.kind == "box":
        hx, hy = 0.5 * solid.size[0], 0.5 * solid.size[1]
        corners = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy], [-hx, -hy]])
        return _yawed(corners, centre, solid.yaw)
    if solid.kind in ("cylinder", "sphere"):
        return np.asarray(centre[:2] + solid.size[0] * circle, dtype=float)
    return top_outline(obstacle.superellipsoid(), count)


def _signed_power(x: Array, e: float) -> Array:
    return np.asarray(np.sign(x) * np.abs(x) ** e, dtype=float)


def superellipsoid_mesh(model: Any, meridians: int = 48, parallels: int = 24
                        ) -> tuple[Array, np.ndarray]:
    """Triangle mesh of a Barr superellipsoid from its parametric form.

    .. math:: x' = a_1 C(\\eta)^{e_1} C(\\omega)^{e_2},\\ y' = a_2 C(\\eta)^{e_1} S(\\omega)^{e_2},
              \\ z' = a_3 S(\\eta)^{e_1}

    with C(.)^e = sgn(cos .) |cos .|^e, S likewise, eta in [-pi/2, pi/2], omega in [-pi, pi),
    then yawed and moved to the centre (F = 1 at every vertex, docs/conventions.md).

    Returns:
        Vertices (V, 3) [m] and faces (F, 3) (vertex indices, counter-clockwise outside).
    """
    a1, a2, a3 = (float(v) for v in model.semi_axes)
    e1, e2 = (float(v) for v in model.exponents)
    eta = np.linspace(-np.pi / 2, np.pi / 2, parallels + 1)[:, None]
    omega = np.linspace(-np.pi, np.pi, meridians, endpoint=False)[None, :]
    ce, se = _signed_power(np.cos(eta), e1), _signed_power(np.sin(eta), e1)
    x = a1 * ce * _signed_power(np.cos(omega), e2)
    y = a2 * ce * _signed_power(np.sin(omega), e2)
    z = a3 * se * np.ones_like(omega)
    local = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    c, s = np.cos(float(model.yaw)), np.sin(float(model.yaw))
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    vertices = local @ R.T + _center(model)
    i, j = np.meshgrid(np.arange(parallels), np.arange(meridians), indexing="ij")
    a = i * meridians + j
    b = i * meridians + (j + 1) % meridians
    faces = np.concatenate([np.column_stack([a.ravel(), b.ravel(), (b + meridians).ravel()]),
                            np.column_stack([a.ravel(), (b + meridians).ravel(),
                                             (a + meridians).ravel()])])
    return np.asarray(vertices, dtype=float), faces.astype(np.uint32)


def tube_mesh(points: Array, radius: float, sides: int = 8) -> tuple[Array, np.ndarray]:
    """A tube of ``radius`` [m] along a polyline (K, 3): vertices (K' sides, 3) and faces.

    Consecutive points closer than 1e-6 m are merged; rings are oriented by parallel transport
    of a normal along the path, so the tube does not twist.
    """
    p = np.asarray(points, dtype=float)
    if len(p) > 1:
        keep = np.concatenate([[True], np.linalg.norm(np.diff(p, axis=0), axis=1) > 1e-6])
        p = p[keep]
    if len(p) < 2:
        p = np.vstack([p[:1], p[:1] + [0.0, 0.0, 1e-4]])
    tangent = np.gradient(p, axis=0)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)
    helper = np.array([0.0, 0.0, 1.0]) if abs(tangent[0, 2]) < 0.9 else np.array([1.0, 0, 0])
    normal = np.cross(tangent[0], helper)
    normal /= np.linalg.norm(normal)
    normals = np.empty_like(p)
    for k in range(len(p)):  # parallel transport: remove the tangential part, renormalize
        normal = normal - tangent[k] * float(normal @ tangent[k])
        norm = float(np.linalg.norm(normal))
        if norm < 1e-9:
            normal = np.cross(tangent[k], helper if abs(tangent[k] @ helper) < 0.9 else [0, 1, 0])
            norm = float(np.linalg.norm(normal))
        normal = normal / norm
        normals[k] = normal
    binormals = np.cross(tangent, normals)
    angles = np.linspace(0.0, 2.0 * np.pi, sides, endpoint=False)
    ring = np.cos(angles)[None, :, None] * normals[:, None, :] + \
        np.sin(angles)[None, :, None] * binormals[:, None, :]
    vertices = (p[:, None, :] + radius * ring).reshape(-1, 3)
    ring_index, j = np.meshgrid(np.arange(len(p) - 1), np.arange(sides), indexing="ij")
    a = ring_index * sides + j
    b = ring_index * sides + (j + 1) % sides
    faces = np.concatenate([np.column_stack([a.ravel(), b.ravel(), (b + sides).ravel()]),
                            np.column_stack([a.ravel(), (b + sides).ravel(),
                                             (a + sides).ravel()])])
    return np.asarray(vertices, dtype=float), faces.astype(np.uint32)
