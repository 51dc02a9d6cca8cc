"""Spheres that cover a body's surface: the collision model of a body from its geometry.

A body is a union of convex pieces (the primitives and collision meshes of a URDF link, with
what is fixed to it), each given by surface points in the body frame. :func:`fit_spheres`
covers all the points with few spheres that stick out of the body by about ``tolerance``:

1. depth(c): the distance from a point c to the boundary of the body, estimated as the largest
   depth of c inside a piece's convex hull (a point inside several pieces is at least that deep
   inside their union);
2. candidate centres on a grid of spacing ``tolerance / 2`` in each piece's principal frame
   (a line for a rod, a plane for a plate), each with radius ``depth(c) + tolerance``, so that
   it sticks out of the body by at most ``tolerance``; plus every surface point as a centre
   with radius ``tolerance``, so that everything can be covered;
3. greedy set cover: the candidate covering most still uncovered points (on a voxel grid of
   spacing ``tolerance / 2``) is taken until every point is covered or ``max_spheres`` are used;
4. every input point is assigned to the chosen sphere it is deepest in and that sphere's
   radius grows to reach it, so **every input point lies inside the union** (to rounding).
   A point lies within a voxel diagonal (sqrt(3) tolerance / 2) of a covered one, so a sphere
   sticks out by at most about 1.87 ``tolerance`` (unless the budget ran out).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np
from scipy import sparse
from scipy.spatial import ConvexHull, QhullError, cKDTree

from mmplan.arrays import Array


class _Depth:
    """Depth of points inside the union of convex pieces (max over the pieces' hull depths)."""

    def __init__(self, pieces: Sequence[Array], voxel: float) -> None:
        self.hulls = []
        for P in pieces:
            try:  # the hull of a voxel subset lies inside the piece's: depths err low (safe)
                hull = ConvexHull(_voxel_representatives(P, voxel), qhull_options="QJ")
            except (QhullError, ValueError):  # fewer than 4 points
                continue
            eq = np.unique(np.round(hull.equations, 9), axis=0)  # n . x + d <= 0 inside
            self.hulls.append((P.min(axis=0), P.max(axis=0), eq[:, :3], eq[:, 3]))

    def __call__(self, C: Array) -> Array:
        """Depth (k,) of the points C (k, 3); 0 outside every piece."""
        depth = np.zeros(C.shape[0])
        for lo, hi, normals, offsets in self.hulls:
            inside = np.flatnonzero(np.all((lo <= C) & (hi >= C), axis=1))
            if inside.size:
                d = -(C[inside] @ normals.T + offsets).max(axis=1)
                depth[inside] = np.maximum(depth[inside], d)
        return depth


def _piece_grid(P: Array, step: float) -> Array:
    """Grid points of spacing ``step`` over a piece's extent in its principal frame (k, 3)."""
    mean = P.mean(axis=0)
    X = P - mean
    _, _, Vt = np.linalg.svd(X, full_matrices=False)
    axes = np.zeros((3, 3))
    axes[: Vt.shape[0]] = Vt
    proj = X @ axes.T
    lo, hi = proj.min(axis=0), proj.max(axis=0)
    ticks = []
    for a, b in zip(lo, hi, strict=True):
        n = int(np.floor((b - a) / step))
        ticks.append((a + b) / 2 + step * (np.arange(n + 1) - n / 2) if n > 0 else [(a + b) / 2])
    U, V, W = np.meshgrid(*ticks, indexing="ij")
    return np.stack([U.ravel(), V.ravel(), W.ravel()], axis=1) @ axes + mean


def _voxel_representatives(P: Array, voxel: float) -> Array:
    """One point per occupied voxel (the first), (k, 3)."""
    keys = np.floor(P / voxel).astype(np.int64)
    keys -= keys.min(axis=0)
    span = keys.max(axis=0) + 1
    flat = (keys[:, 0] * span[1] + keys[:, 1]) * span[2] + keys[:, 2]
    _, first = np.unique(flat, return_index=True)
    return P[np.sort(first)]


def fit_spheres(
    pieces: Sequence[Array], tolerance: float, max_spheres: int = 32
) -> list[tuple[Array, float]]:
    """Spheres (centre (3,), radius) whose union contains every point of every piece.

    Args:
        pieces: Surface points (k_i, 3) of each convex piece of one body [m].
        tolerance: Accepted protrusion of a sphere out of the body [m].
        max_spheres: Most spheres returned.
    """
    pieces = [np.asarray(P, dtype=float).reshape(-1, 3) for P in pieces]
    pieces = [P for P in pieces if P.shape[0]]
    if not pieces:
        return []
    points = np.concatenate(pieces)
    depth = _Depth(pieces, tolerance / 4)
    grid = np.concatenate([_piece_grid(P, tolerance / 2) for P in pieces])
    grid = grid[depth(grid) > 0]
    targets = _voxel_representatives(points, tolerance / 2)
    tree = cKDTree(targets)
    radii = depth(grid) + tolerance
    hits = tree.query_ball_point(grid, radii)
    reached = np.zeros(targets.shape[0], dtype=bool)
    for h in hits:
        reached[h] = True
    # surface points no inner candidate reaches (sharp corners): a sphere of radius tolerance
    lonely = targets[~reached]
    centers = np.concatenate([grid, lonely])
    radii = np.concatenate([radii, np.full(lonely.shape[0], tolerance)])
    hits = [*hits, *tree.query_ball_point(lonely, tolerance)] if lonely.shape[0] else list(hits)
    sizes = np.fromiter((len(h) for h in hits), dtype=np.int64, count=len(hits))
    rows = np.repeat(np.arange(len(hits)), sizes)
    cols = np.fromiter(itertools.chain.from_iterable(hits), dtype=np.int64, count=int(sizes.sum()))
    cover = sparse.csr_matrix((np.ones(rows.size, dtype=np.int32), (rows, cols)),
                              shape=(len(hits), targets.shape[0]))
    by_target = cover.tocsc()
    counts = np.asarray(cover.sum(axis=1)).ravel()
    uncovered = np.ones(targets.shape[0], dtype=bool)
    chosen: list[int] = []
    while uncovered.any() and len(chosen) < max_spheres:
        best = int(np.argmax(counts))
        row = cover.indices[cover.indptr[best] : cover.indptr[best + 1]]
        newly = row[uncovered[row]]
        uncovered[newly] = False
        counts -= np.asarray(by_target[:, newly].sum(axis=1)).ravel()
        chosen.append(best)

    C, R = centers[chosen], radii[chosen].copy()
    # every input point into the sphere it is deepest in; grow that sphere to reach it
    gap = np.linalg.norm(points[:, None, :] - C[None, :, :], axis=2) - R[None, :]  # (N, S)
    owner = np.argmin(gap, axis=1)
    need = gap[np.arange(points.shape[0]), owner]
    for k in range(len(chosen)):
        mine = need[owner == k]
        if mine.size and mine.max() > 0:
            R[k] += float(mine.max())
    return [(C[k], float(R[k])) for k in range(len(chosen))]
