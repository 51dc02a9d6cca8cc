"""Surface points of URDF collision geometry (primitives and meshes), in the geometry's frame.

Meshes (loaded by Pinocchio through coal, scale applied) give their vertices plus samples on
their edges and inside their wide triangles at ``spacing``; boxes, cylinders, capsules, cones
and ellipsoids are sampled on their surface at ``spacing``. A sphere primitive is kept as it
is (an exact collision sphere).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError


def _circle(radius: float, spacing: float) -> Array:
    """Points on a circle of ``radius`` in the xy plane, (k, 3)."""
    k = max(8, math.ceil(2 * math.pi * radius / spacing))
    a = np.linspace(0.0, 2 * math.pi, k, endpoint=False)
    return np.stack([radius * np.cos(a), radius * np.sin(a), np.zeros(k)], axis=1)


def _disc(radius: float, z: float, spacing: float) -> Array:
    """Concentric circles filling a disc of ``radius`` at height z (rim included), (k, 3)."""
    rings = max(1, math.ceil(radius / spacing))
    out = [np.array([[0.0, 0.0, z]])]
    for i in range(1, rings + 1):
        ring = _circle(radius * i / rings, spacing)
        ring[:, 2] = z
        out.append(ring)
    return np.concatenate(out)


def _lathe(profile: list[tuple[float, float]], spacing: float) -> Array:
    """Surface of revolution about z through the (radius, z) profile points, (k, 3)."""
    out = []
    for r, z in profile:
        ring = _circle(r, spacing) if r > 0 else np.zeros((1, 3))
        ring[:, 2] = z
        out.append(ring)
    return np.concatenate(out)


def _segment_profile(r0: float, z0: float, r1: float, z1: float, spacing: float) -> list:
    k = max(1, math.ceil(math.hypot(r1 - r0, z1 - z0) / spacing))
    return [(r0 + (r1 - r0) * t, z0 + (z1 - z0) * t) for t in np.linspace(0, 1, k + 1)]


def box_points(half: Array, spacing: float) -> Array:
    """Grid points on the surface of a box with half edges ``half`` (3,), (k, 3)."""
    axes = [np.linspace(-h, h, max(2, math.ceil(2 * h / spacing) + 1)) for h in half]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    P = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    on = np.zeros(P.shape[0], dtype=bool)
    for i, h in enumerate(half):
        on |= np.isclose(np.abs(P[:, i]), h)
    return P[on]


def _sphere_surface(radii: Array, spacing: float) -> Array:
    """Fibonacci points on an ellipsoid with semi-axes ``radii`` (3,)."""
    r = float(max(radii))
    k = max(32, math.ceil(4 * math.pi * r * r / spacing**2))
    i = np.arange(k) + 0.5
    z = 1 - 2 * i / k
    phi = math.pi * (1 + 5**0.5) * i
    rho = np.sqrt(1 - z * z)
    return np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=1) * radii


def triangle_samples(vertices: Array, triangles: Array, spacing: float) -> Array:
    """Points on the mesh's edges at ``spacing`` and inside its large triangles.

    Every edge longer than ``spacing`` is sampled; a triangle also gets a barycentric grid
    inside when it is wide (twice its area over its perimeter above ``spacing``): thin
    triangles are covered by their edges.
    """
    if triangles.shape[0] == 0:
        return np.zeros((0, 3))
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]],
                                    triangles[:, [2, 0]]]), axis=1)
    edges = np.unique(edges, axis=0)
    p, q = vertices[edges[:, 0]], vertices[edges[:, 1]]
    steps = np.ceil(np.linalg.norm(q - p, axis=1) / spacing).astype(int)
    out = []
    for m in np.unique(steps[steps > 1]):
        sel = steps == m
        t = np.arange(1, m)[None, :, None] / m
        out.append((p[sel, None, :] + t * (q[sel] - p[sel])[:, None, :]).reshape(-1, 3))
    a, b, c = (vertices[triangles[:, i]] for i in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    sides = [np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
             np.linalg.norm(a - c, axis=1)]
    wide = 2 * area / np.maximum(np.sum(sides, axis=0), 1e-300) > spacing / 2
    grid = np.where(wide, np.ceil(np.max(sides, axis=0) / spacing), 0).astype(int)
    for m in np.unique(grid[grid > 2]):
        sel = grid == m
        u, v = np.meshgrid(np.arange(1, m), np.arange(1, m), indexing="ij")
        keep = (u + v) < m
        u, v = u[keep] / m, v[keep] / m
        pts = (a[sel, None, :] + u[None, :, None] * (b[sel] - a[sel])[:, None, :]
               + v[None, :, None] * (c[sel] - a[sel])[:, None, :])
        out.append(pts.reshape(-1, 3))
    return np.concatenate(out) if out else np.zeros((0, 3))


def mesh_vertices_and_triangles(geometry: Any) -> tuple[Array, Array]:
    """Vertices (k, 3) and triangles (t, 3) of a coal mesh (BVH model or convex)."""
    if hasattr(geometry, "vertices"):
        vertices = np.asarray(geometry.vertices(), dtype=float).reshape(-1, 3)
        tri = [geometry.tri_indices(i) for i in range(geometry.num_tris)]
    else:
        vertices = np.asarray(geometry.points(), dtype=float).reshape(-1, 3)
        tri = []
    triangles = np.array([[t[0], t[1], t[2]] for t in tri], dtype=int).reshape(-1, 3)
    return vertices, triangles


def surface_points(geometry: Any, spacing: float, name: str) -> tuple[Array, list]:
    """Surface points (k, 3) of a coal geometry, and exact spheres [(centre, radius)].

    Raises:
        InputError: a geometry type that cannot be sampled (halfspace, plane, height field).
    """
    kind = type(geometry).__name__
    if kind == "Sphere":
        return np.zeros((0, 3)), [(np.zeros(3), float(geometry.radius))]
    if kind == "Box":
        return box_points(np.asarray(geometry.halfSide, float), spacing), []
    if kind == "Cylinder":
        r, h = float(geometry.radius), float(geometry.halfLength)
        side = _lathe(_segment_profile(r, -h, r, h, spacing), spacing)
        return np.concatenate([side, _disc(r, -h, spacing), _disc(r, h, spacing)]), []
    if kind == "Cone":
        r, h = float(geometry.radius), float(geometry.halfLength)
        side = _lathe(_segment_profile(r, -h, 0.0, h, spacing), spacing)
        return np.concatenate([side, _disc(r, -h, spacing)]), []
    if kind == "Capsule":
        r, h = float(geometry.radius), float(geometry.halfLength)
        side = _lathe(_segment_profile(r, -h, r, h, spacing), spacing)
        cap = _sphere_surface(np.full(3, r), spacing)
        ends = np.concatenate([cap[cap[:, 2] >= 0] + [0, 0, h], cap[cap[:, 2] <= 0] - [0, 0, h]])
        return np.concatenate([side, ends]), []
    if kind == "Ellipsoid":
        return _sphere_surface(np.asarray(geometry.radii, float), spacing), []
    if hasattr(geometry, "vertices") or hasattr(geometry, "points"):
        vertices, triangles = mesh_vertices_and_triangles(geometry)
        return np.concatenate([vertices, triangle_samples(vertices, triangles, spacing)]), []
    raise InputError("robot.urdf", f"collision geometry {name!r} of type {kind} cannot be "
                     "covered by spheres")
