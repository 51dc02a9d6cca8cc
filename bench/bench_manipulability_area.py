"""Manipulability-area planner ([Nagatani]): vectorized pipeline vs per-cell Python loops.

Two stages of the ``wall-segment`` problem (docs/manipulability_area.md: 31 layers x 22,100
cells), each timed both ways in this run:

1. LMA construction: the manipulability distribution of every layer. Vectorized:
   :func:`mmplan.planners.manipulability_area.grid.layer_stack` (one batched IK call a layer).
   Baselines,
   Python loops over layers and cells: (a) the library's IK + w called on one cell at a time
   (the straightforward per-cell implementation; run on ``--loop-layers`` layers, compared
   per cell), (b) a hand-written scalar closed-form IK with ``math`` functions (the same
   branch as :mod:`mmplan.robot.library.base_6dof_ik`, early exit on unreachable cells: the
   strongest
   pure-Python baseline), on all layers.
2. Straight-segment search ([Nagatani] section 4.1, round robin). Vectorized:
   :func:`mmplan.planners.manipulability_area.path.straight_candidates` (FFT pruning of
   displacements,
   shifted-mask ANDs). Baselines: (a) a loop over start cells of the bottom layer, NumPy over
   the end cells and layers (must return the same shortest length and pairs); (b) the plain
   per-pair Python loop (every start x end pair, layer by layer), timed on
   ``--pair-starts`` start cells and scaled to all pairs (printed as an estimate).

3. The whole planner on ``wall-segment`` (``compute_time_s`` of the result).

Run: ``python bench/bench_manipulability_area.py [--layers N] [--loop-layers M]``.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from numpy.typing import NDArray

from mmplan.arrays import Array
from mmplan.planners.manipulability_area import grid as lma_grid
from mmplan.planners.manipulability_area import path as lma_path
from mmplan.planners.manipulability_area.planner import (
    ManipulabilityArea,
    ManipulabilityAreaSettings,
)
from mmplan.problem import Problem
from mmplan.robot.library import base_6dof_ik as puma_ik
from mmplan.robot.library import get_robot
from mmplan.robot.library.base_6dof_ik import PumaGeometry
from mmplan.scene import Scene
from mmplan.task import DrawSegment

WALL = DrawSegment((0.0, 0.0, 0.32), (0.0, 0.60, 0.62), (1.0, 0.0, 0.0))


def scalar_w(g: PumaGeometry, x: float, y: float, heading: float, p: Array, R: Array) -> float:
    """w at one base position: scalar IK (shoulder +, Corke elbow 'u') + closed-form w; 0 if
    unreachable. The wrist angles do not change w except through |s5|."""
    a2, a3, d3, d4 = g.a[1], g.a[2], g.d[2], g.d[3]
    c, s = math.cos(heading), math.sin(heading)
    zx, zy, zz = R[0][2], R[1][2], R[2][2]
    rx, ry, rz = p[0] - x, p[1] - y, p[2] - g.shoulder_height
    ax, ay = c * rx + s * ry, -s * rx + c * ry  # tool tip in the arm frame
    tx, ty = c * zx + s * zy, -s * zx + c * zy  # tool axis in the arm frame
    wx, wy, wz = ax - g.tool * tx, ay - g.tool * ty, rz - g.tool * zz
    rho2 = wx * wx + wy * wy - d3 * d3
    if rho2 < 0:
        return 0.0
    r = math.sqrt(rho2)
    D = math.hypot(r, wz)
    cb = (a2 * a2 + D * D - a3 * a3 - d4 * d4) / (2 * a2 * D) if D > 0 else 2.0
    if abs(cb) > 1:
        return 0.0
    q1 = math.atan2(wy, wx) - math.atan2(-d3, r)
    q2 = math.atan2(wz, r) - math.acos(cb)
    q23 = math.atan2(wz - a2 * math.sin(q2), r - a2 * math.cos(q2)) - math.atan2(d4, a3)
    q3 = q23 - q2
    c1, s1, c23, s23 = math.cos(q1), math.sin(q1), math.cos(q23), math.sin(q23)
    a_x = c1 * c23 * tx + s1 * c23 * ty + s23 * zz  # tool axis in frame 3
    a_y = -s1 * tx + c1 * ty
    s5 = math.hypot(a_x, a_y)
    elbow = d4 * math.cos(q3) + a3 * math.sin(q3)
    return a2 * s5 * abs(elbow) * abs(r)


def loop_stack(g: PumaGeometry, grid: lma_grid.Grid, poses: lma_grid.ToolPoses) -> Array:
    w = np.zeros((len(poses.s), *grid.shape))
    R = poses.rotation.tolist()
    for k in range(len(poses.s)):
        p = poses.positions[k].tolist()
        for i, x in enumerate(grid.xs.tolist()):
            for j, y in enumerate(grid.ys.tolist()):
                w[k, i, j] = scalar_w(g, x, y, poses.heading, p, R)
    return w


def loop_library(g: PumaGeometry, grid: lma_grid.Grid, poses: lma_grid.ToolPoses,
                 layers: int) -> Array:
    w = np.zeros((layers, *grid.shape))
    branch = lma_grid.Branch()
    for k in range(layers):
        for i, x in enumerate(grid.xs):
            for j, y in enumerate(grid.ys):
                q, ok = lma_grid.configurations(g, poses, k, np.array([[x, y]]), branch)
                w[k, i, j] = puma_ik.manipulability(g, q)[0] if ok[0] else 0.0
    return w


def loop_straight(masks: NDArray[np.bool_]) -> tuple[float, int]:
    """Round robin: for each start cell, all end cells and layers at once (NumPy)."""
    L = masks.shape[0]
    ends = np.argwhere(masks[-1])
    k = (np.arange(L) / (L - 1))[:, None, None]
    best, count = np.inf, 0
    for a in np.argwhere(masks[0]):
        cells = np.floor(a[None, None] + k * (ends - a)[None] + 0.5).astype(int)
        ok = masks[np.arange(L)[:, None], cells[..., 0], cells[..., 1]].all(axis=0)
        if ok.any():
            lengths = np.hypot(*(ends[ok] - a).T)
            m = float(lengths.min())
            if m < best - 1e-12:
                best, count = m, 0
            count += int(np.sum(np.abs(lengths - best) < 1e-12))
    return best, count


def pair_loop(masks: NDArray[np.bool_], starts: int) -> tuple[float, int]:
    """Per-pair round robin on the first ``starts`` start cells: (seconds, pairs checked)."""
    L = masks.shape[0]
    lists = masks.tolist()
    ends = [tuple(e) for e in np.argwhere(masks[-1]).tolist()]
    t0 = time.perf_counter()
    pairs = 0
    for a0, a1 in np.argwhere(masks[0])[:starts].tolist():
        for b0, b1 in ends:
            pairs += 1
            for k in range(L):
                f = k / (L - 1)
                if not lists[k][math.floor(a0 + f * (b0 - a0) + 0.5)][
                        math.floor(a1 + f * (b1 - a1) + 0.5)]:
                    break
    return time.perf_counter() - t0, pairs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--layers", type=int, default=31, help="layers (the example has 31)")
    parser.add_argument("--loop-layers", type=int, default=2,
                        help="layers for the per-cell library loop (slow)")
    parser.add_argument("--pair-starts", type=int, default=50,
                        help="start cells for the per-pair search loop (slow)")
    args = parser.parse_args()
    settings = ManipulabilityAreaSettings.model_validate({"layers": args.layers})
    g = PumaGeometry.base_6dof()
    grid = lma_grid.Grid.from_bounds(settings.x_range, settings.y_range, settings.resolution)
    poses = lma_grid.tool_poses(WALL, settings.layers)
    cells = len(poses.s) * grid.shape[0] * grid.shape[1]
    print(f"wall-segment: {len(poses.s)} layers x {grid.shape[0] * grid.shape[1]} cells")

    t0 = time.perf_counter()
    stack = lma_grid.layer_stack(g, grid, poses, lma_grid.Branch())
    t_vec = time.perf_counter() - t0
    us_vec = 1e6 * t_vec / cells
    print(f"LMA construction  vectorized {t_vec:7.3f} s ({us_vec:.3f} us/cell)")
    m = min(args.loop_layers, len(poses.s))
    t0 = time.perf_counter()
    w_lib = loop_library(g, grid, poses, m)
    t_lib = time.perf_counter() - t0
    us_lib = 1e6 * t_lib / (m * grid.shape[0] * grid.shape[1])
    print(f"  (a) per-cell loop, library IK ({m} layers) {t_lib:7.3f} s ({us_lib:.1f} us/cell)"
          f"   speed-up {us_lib / us_vec:7.1f}x   max |w diff| "
          f"{np.abs(w_lib - stack.w[:m]).max():.2e}")
    t0 = time.perf_counter()
    w_loop = loop_stack(g, grid, poses)
    t_loop = time.perf_counter() - t0
    print(f"  (b) per-cell loop, scalar math IK (all layers) {t_loop:7.3f} s "
          f"({1e6 * t_loop / cells:.2f} us/cell)   speed-up {t_loop / t_vec:6.1f}x   "
          f"max |w diff| {np.abs(w_loop - stack.w).max():.2e}")

    masks = stack.areas(settings.threshold_ratio * float(stack.w.max()))
    t0 = time.perf_counter()
    best_loop, n_loop = loop_straight(masks)
    t_loop = time.perf_counter() - t0
    t0 = time.perf_counter()
    first = next(iter(lma_path.straight_candidates(masks)), None)
    t_vec = time.perf_counter() - t0
    best_vec = first.length_cells if first is not None else np.inf
    n_vec = len(first.starts) if first is not None else 0
    print(f"straight search   vectorized {t_vec:7.3f} s")
    print(f"  (a) per-start loop {t_loop:7.3f} s   speed-up {t_loop / t_vec:6.1f}x   shortest "
          f"{best_loop * settings.resolution:.4f} m ({n_loop} pairs) vs "
          f"{best_vec * settings.resolution:.4f} m ({n_vec} pairs)")
    t_pairs, pairs = pair_loop(masks, args.pair_starts)
    all_pairs = int(masks[0].sum()) * int(masks[-1].sum())
    estimate = t_pairs / pairs * all_pairs
    print(f"  (b) per-pair loop {t_pairs:7.3f} s for {pairs} pairs ({1e6 * t_pairs / pairs:.2f} "
          f"us/pair); all {all_pairs} pairs ~ {estimate:.1f} s   speed-up ~ "
          f"{estimate / t_vec:6.0f}x")

    robot = get_robot("base-6dof")
    result = ManipulabilityArea().plan(Problem(robot, Scene(), WALL, np.zeros(robot.n),
                                               settings))
    print(f"planner           {result.status.value}: {result.message}; compute_time_s "
          f"{result.compute_time_s:.3f} s")


if __name__ == "__main__":
    main()
