r"""Base paths through a Layer of Manipulability Areas (LMA; [Nagatani] s.4.1).

The LMA is a boolean voxel array ``masks`` (L, nx, ny): ``masks[k, i, j]`` says that the base
at grid cell (i, j) keeps the manipulability of layer k's tool pose above the threshold.
Paths are given as integer cell coordinates per layer or as real cell coordinates (float
indices); the caller converts to metres and verifies the exact manipulability.

* :func:`straight_candidates` -- the paper's round-robin search (section 4.1, steps 1-5):
  every start cell of the bottom layer against every end cell of the top layer, keeping the
  straight segments whose point at layer k, :math:`a + \tfrac{k}{L-1}(b - a)` rounded to the
  nearest cell, lies in MA_k; shortest first. Vectorized over displacements
  :math:`d = b - a`: a displacement is pruned when, for some layer k, no cell pair of
  (MA_0, MA_k) is :math:`o_k(d)` apart (cross-correlation counts by FFT), then the surviving
  displacements are checked exactly, in order of length, by ANDing shifted masks.
* :func:`layered_shortest_path` -- sub-goal planning when no straight segment exists (the
  paper leaves this open): a shortest path through the voxelized LMA, one move per layer of at
  most ``max_step`` cells, cost = horizontal length (dynamic programming layer by layer).
* :func:`shortcut` -- greedy shortcutting of such a path into few straight pieces between
  sub-goals, each accepted by the caller's exact check.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import fft as sp_fft

from mmplan.arrays import Array, BoolArray

IntArray = NDArray[np.int64]

#: Exact minimum manipulability of base paths (M, L, 2) [m] -> (M,) [m^3].
ExactCheck = Callable[[Array], Array]


@dataclass(frozen=True)
class StraightCandidates:
    """Straight segments of one length, all feasible on the grid.

    Attributes:
        starts: Start cells (M, 2) (i, j) in the bottom layer.
        ends: End cells (M, 2) in the top layer.
        length_cells: Their common length in cells.
    """

    starts: IntArray
    ends: IntArray
    length_cells: float


def layer_offsets(d: IntArray, layers: int) -> IntArray:
    """Rounded cell offsets of the straight segment at each layer, (L, ..., 2).

    .. math:: o_k(d) = \\lfloor \\tfrac{k}{L-1} d + \\tfrac12 \\rfloor

    Args:
        d: Displacements (..., 2) in cells.
        layers: Number of layers L.
    """
    k = np.arange(layers).reshape((layers,) + (1,) * (np.ndim(d) - 1) + (1,))
    frac = k / max(layers - 1, 1)
    return np.floor(frac * np.asarray(d)[None] + 0.5).astype(np.int64)


def _correlation_counts(masks: BoolArray) -> NDArray[np.float64]:
    """C_k[e] = #{a in MA_0 : a + e in MA_k}, for every layer, (L, 2nx - 1, 2ny - 1).

    Index [k, e_i + nx - 1, e_j + ny - 1] holds the count for offset e.
    """
    nx, ny = masks.shape[1:]
    shape = (sp_fft.next_fast_len(2 * nx), sp_fft.next_fast_len(2 * ny))
    F0 = sp_fft.rfft2(masks[0].astype(float), shape)
    Fk = sp_fft.rfft2(masks.astype(float), shape)
    corr = sp_fft.irfft2(np.conj(F0)[None] * Fk, shape)  # corr[e] = sum_a M0[a] Mk[a + e]
    corr = np.roll(corr, (nx - 1, ny - 1), axis=(1, 2))[:, : 2 * nx - 1, : 2 * ny - 1]
    return np.asarray(corr)


def feasible_starts(masks: BoolArray, d: IntArray) -> BoolArray:
    """Start cells a of MA_0 whose segment to a + d has every layer point in the LMA, (nx, ny)."""
    L, nx, ny = masks.shape
    offsets = layer_offsets(np.asarray(d), L)  # (L, 2)
    lo = np.maximum(0, -offsets.min(axis=0))
    hi = np.array([nx, ny]) - np.maximum(0, offsets.max(axis=0))
    out = np.zeros((nx, ny), dtype=bool)
    if np.any(hi <= lo):
        return out
    window = np.ones((hi[0] - lo[0], hi[1] - lo[1]), dtype=bool)
    for k in range(L):
        oi, oj = offsets[k]
        window &= masks[k, lo[0] + oi : hi[0] + oi, lo[1] + oj : hi[1] + oj]
        if not window.any():
            return out
    out[lo[0] : hi[0], lo[1] : hi[1]] = window
    return out


def straight_candidates(masks: BoolArray) -> Iterator[StraightCandidates]:
    """Feasible straight segments grouped by length, shortest group first ([Nagatani] s.4.1).

    A vertical segment (d = 0, no base motion) comes first when it exists. Lazy: the caller
    verifies each group exactly and stops at the first one that passes.

    Args:
        masks: LMA (L, nx, ny).
    """
    if not (masks[0].any() and masks[-1].any()):
        return
    occupied = np.argwhere(masks.any(axis=0))
    lo, hi = occupied.min(axis=0), occupied.max(axis=0) + 1
    masks = masks[:, lo[0] : hi[0], lo[1] : hi[1]]  # crop to the LMA's bounding box
    L, nx, ny = masks.shape
    counts = _correlation_counts(masks) > 0.5  # (L, 2nx-1, 2ny-1)
    di, dj = np.meshgrid(np.arange(-(nx - 1), nx), np.arange(-(ny - 1), ny), indexing="ij")
    d = np.stack([di.ravel(), dj.ravel()], axis=1)  # (D, 2)
    d = d[counts[-1, d[:, 0] + nx - 1, d[:, 1] + ny - 1]]
    offsets = layer_offsets(d, L)  # (L, D, 2)
    ok = counts[np.arange(L)[:, None], offsets[..., 0] + nx - 1, offsets[..., 1] + ny - 1]
    d = d[ok.all(axis=0)]
    length2 = (d**2).sum(axis=1)
    order = np.argsort(length2, kind="stable")
    d, length2 = d[order], length2[order]
    i = 0
    while i < len(d):
        j = int(np.searchsorted(length2, length2[i], side="right"))
        starts = [np.argwhere(feasible_starts(masks, disp)) for disp in d[i:j]]
        if sum(len(c) for c in starts):
            ends = [c + disp for c, disp in zip(starts, d[i:j], strict=True)]
            yield StraightCandidates(
                np.concatenate(starts) + lo, np.concatenate(ends) + lo, float(np.sqrt(length2[i]))
            )
        i = j


def layered_shortest_path(masks: BoolArray, max_step: int) -> tuple[IntArray | None, int]:
    """Shortest base path through the voxelized LMA, one cell per layer, (L, 2).

    Dynamic programming over layers: :math:`c_{k+1}(x) = \\min_{|o| \\le m} c_k(x - o) + |o|`
    for x in MA_{k+1} (m = ``max_step`` cells, Euclidean disc), :math:`c_0 = 0` on MA_0.
    Ties are broken towards the smaller move.

    Returns:
        The path (L, 2) and -1, or None and the first layer that no such path reaches.
    """
    L, nx, ny = masks.shape
    r = np.arange(-max_step, max_step + 1)
    oi, oj = np.meshgrid(r, r, indexing="ij")
    disc = oi**2 + oj**2 <= max_step**2
    moves = np.stack([oi[disc], oj[disc]], axis=1)
    moves = moves[np.argsort(np.hypot(moves[:, 0], moves[:, 1]), kind="stable")]
    step_cost = np.hypot(moves[:, 0], moves[:, 1])
    cost = np.where(masks[0], 0.0, np.inf)
    choice = np.zeros((L, nx, ny), dtype=np.int64)
    pad = max_step
    for k in range(1, L):
        padded = np.pad(cost, pad, constant_values=np.inf)
        best = np.full((nx, ny), np.inf)
        arg = np.zeros((nx, ny), dtype=np.int64)
        for m, (mi, mj) in enumerate(moves):
            prev = padded[pad - mi : pad - mi + nx, pad - mj : pad - mj + ny] + step_cost[m]
            better = prev < best
            best[better] = prev[better]
            arg[better] = m
        cost = np.where(masks[k], best, np.inf)
        choice[k] = arg
        if not np.isfinite(cost).any():
            return None, k
    cell = np.array(np.unravel_index(int(np.argmin(cost)), (nx, ny)))
    path = np.zeros((L, 2), dtype=np.int64)
    path[-1] = cell
    for k in range(L - 1, 0, -1):
        path[k - 1] = path[k] - moves[choice[k, path[k, 0], path[k, 1]]]
    return path, -1


def interpolated(a: Array, b: Array, count: int) -> Array:
    """``count`` points from a to b inclusive (real cell coordinates), (count, 2)."""
    s = np.linspace(0.0, 1.0, count)[:, None]
    return np.asarray(a)[None] + s * (np.asarray(b) - np.asarray(a))[None]


def shortcut(path: IntArray, accept: Callable[[int, Array], bool]) -> list[int]:
    """Greedy shortcutting: indices of the layers kept as sub-goals (first and last included).

    From sub-goal layer i the next sub-goal is the farthest layer j whose straight piece
    i -> j (linear in the layer index) passes ``accept(i, points)`` (points (j - i + 1, 2) in
    real cell coordinates; the caller checks the exact manipulability there). Adjacent layers
    are always kept (they are the path's own cells, inside the LMA by construction).
    """
    L = len(path)
    keep = [0]
    i = 0
    while i < L - 1:
        nxt = i + 1
        for j in range(L - 1, i + 1, -1):
            if accept(i, interpolated(path[i].astype(float), path[j].astype(float), j - i + 1)):
                nxt = j
                break
        keep.append(nxt)
        i = nxt
    return keep


def densify(xy: Array, substeps: int) -> Array:
    """Insert ``substeps - 1`` evenly spaced points in every interval of paths (..., L, 2)
    -> (..., (L - 1) substeps + 1, 2) (piecewise linear, the original points kept)."""
    xy = np.asarray(xy, dtype=float)
    if substeps == 1:
        return xy
    f = (np.arange(substeps) / substeps)[:, None]
    a, b = xy[..., :-1, None, :], xy[..., 1:, None, :]
    inner = (a + f * (b - a)).reshape(*xy.shape[:-2], -1, 2)
    return np.concatenate([inner, xy[..., -1:, :]], axis=-2)


def blended_polyline(way_s: Array, way_xy: Array, s: Array,
                     half_width: float) -> tuple[Array, Array, Array]:
    """Positions, velocities and accelerations (each (N, 2)) at parameters ``s`` (N,) of the
    polyline through ``way_xy`` (K, 2) at ``way_s`` (K,), each interior corner replaced by a
    parabolic blend over [s_k - h, s_k + h] (h = ``half_width``; 0 keeps the corners):

    .. math:: x(s) = x_k + v_1 (s - s_k) + (v_2 - v_1) (s - s_k + h)^2 / (4 h)

    (velocity linear from v_1 to v_2; deviation from the corner at most |v_2 - v_1| h / 4).
    """
    way_s, way_xy = np.asarray(way_s, dtype=float), np.asarray(way_xy, dtype=float)
    v_seg = np.diff(way_xy, axis=0) / np.diff(way_s)[:, None]  # (K - 1, 2)
    seg = np.clip(np.searchsorted(way_s, s, side="right") - 1, 0, len(v_seg) - 1)
    xy = way_xy[seg] + (s - way_s[seg])[:, None] * v_seg[seg]
    vel = v_seg[seg].copy()
    acc = np.zeros_like(xy)
    if half_width > 0:
        for k in range(1, len(way_s) - 1):
            u = s - way_s[k]
            near = np.abs(u) < half_width
            v1, v2 = v_seg[k - 1], v_seg[k]
            e = (u[near] + half_width)[:, None]
            xy[near] = way_xy[k] + u[near, None] * v1 + (v2 - v1) * e**2 / (4 * half_width)
            vel[near] = v1 + (v2 - v1) * e / (2 * half_width)
            acc[near] = (v2 - v1) / (2 * half_width)
    return xy, vel, acc
