"""Manipulability-area data of a plan (artifacts.npz of the manipulability-area planner).

Reads and checks the arrays the planner writes (``mmplan.planners.manipulability_area.result``):
the base grid
axes, the manipulability distribution of the first and last layer, the stack of MA masks
(layers, nx, ny), the base path per layer and the threshold. The figures of [Nagatani] (Figs. 3,
4, 5, 8) are drawn from this record by :mod:`mmplan.report.figures_lma`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mmplan.arrays import Array

REQUIRED = (
    "grid_x",
    "grid_y",
    "layer_s",
    "ma_masks",
    "manipulability_first",
    "path_xy",
    "threshold",
)
OPTIONAL = (
    "manipulability_last",
    "manipulability_max_per_layer",
    "tool_positions",
    "path_s",
    "path_xy_rows",
    "path_cells",
    "path_manipulability",
    "subgoal_layers",
)


@dataclass(frozen=True)
class LmaData:
    """Manipulability-area arrays, grids indexed (x, y) (``indexing="ij"``).

    Attributes:
        xs, ys: Base grid axes [m], (nx,), (ny,).
        s: Layer parameters (L,).
        masks: MA of every layer, (L, nx, ny) boolean.
        w_first: Manipulability distribution of the first layer [m^3], (nx, ny).
        w_last: The same for the last layer, or None.
        threshold: MA threshold [m^3].
        path_xy: Base position at every layer [m], (L, 2).
        path_s, path_rows: Dense base path (parameters (N,), positions (N, 2)); the layer
            path when the plan has no dense one.
        tool: Tool tip positions per layer [m], (L, 3), or None.
        subgoals: Layer indices of the base path's sub-goals (first and last included).
    """

    xs: Array
    ys: Array
    s: Array
    masks: NDArray[np.bool_]
    w_first: Array
    w_last: Array | None
    threshold: float
    path_xy: Array
    path_s: Array
    path_rows: Array
    tool: Array | None
    subgoals: NDArray[np.intp]

    @property
    def layers(self) -> int:
        """Number of layers L."""
        return len(self.s)

    def extent(self) -> tuple[float, float, float, float]:
        """Cell-edge extent (x0, x1, y0, y1) of the grid, for ``imshow``."""
        hx = 0.5 * (self.xs[-1] - self.xs[0]) / max(len(self.xs) - 1, 1)
        hy = 0.5 * (self.ys[-1] - self.ys[0]) / max(len(self.ys) - 1, 1)
        return (
            float(self.xs[0] - hx),
            float(self.xs[-1] + hx),
            float(self.ys[0] - hy),
            float(self.ys[-1] + hy),
        )

    def bounds(
        self, margin: float = 0.05, layer: int | None = None
    ) -> tuple[float, float, float, float]:
        """Box (x0, x1, y0, y1) around the MA cells, the base path and the tool, plus a margin:
        of every layer, or of one ``layer`` only."""
        cells = self.masks.any(axis=0) if layer is None else self.masks[layer]
        ix, iy = np.nonzero(cells)
        rows = self.path_rows if layer is None else self.path_xy[layer][None]
        xs = [self.xs[ix], rows[:, 0]]
        ys = [self.ys[iy], rows[:, 1]]
        if self.tool is not None:
            tool = self.tool if layer is None else self.tool[layer][None]
            xs.append(tool[:, 0])
            ys.append(tool[:, 1])
        x, y = np.concatenate(xs), np.concatenate(ys)
        return (
            float(x.min() - margin),
            float(x.max() + margin),
            float(y.min() - margin),
            float(y.max() + margin),
        )

    def wall_line(self) -> tuple[Array, Array] | None:
        """The wall's trace in the x-y plane: a point on it and its unit normal pointing to
        the base side, or None when the tool's x-y points do not define a vertical wall.

        The task surface is the vertical plane through the tool points ([Nagatani]: a segment
        drawn on a wall); its horizontal direction is that of the tool's x-y displacement, or,
        for a vertical stroke, the one orthogonal to the direction from the tool to the MA
        cells.
        """
        if self.tool is None:
            return None
        tool_xy = self.tool[:, :2]
        ix, iy = np.nonzero(self.masks[0])
        if ix.size == 0:
            return None
        centre = np.array([self.xs[ix].mean(), self.ys[iy].mean()])
        span = tool_xy[-1] - tool_xy[0]
        if np.linalg.norm(span) > 1e-3:
            direction = span / np.linalg.norm(span)
            normal = np.array([-direction[1], direction[0]])
        else:
            to_base = centre - tool_xy[0]
            if np.linalg.norm(to_base) < 1e-6:
                return None
            normal = to_base / np.linalg.norm(to_base)
        offsets = (tool_xy - tool_xy[0]) @ normal
        if np.abs(offsets).max() > 1e-3:  # the tool's x-y points are not on one line
            return None
        if (centre - tool_xy[0]) @ normal < 0:
            normal = -normal
        return tool_xy[0].astype(float), normal.astype(float)


def _float(artifacts: Mapping[str, np.ndarray], key: str) -> Array | None:
    value = artifacts.get(key)
    return None if value is None else np.asarray(value, dtype=float)


def read_lma(artifacts: Mapping[str, np.ndarray]) -> LmaData | None:
    """The manipulability-area record, or None when the arrays are absent or inconsistent."""
    if any(key not in artifacts for key in REQUIRED):
        return None
    a = {key: np.asarray(artifacts[key]) for key in REQUIRED}
    if any(v.dtype.kind not in "fiub" for v in a.values()):
        return None
    xs, ys, s = (np.asarray(a[k], dtype=float) for k in ("grid_x", "grid_y", "layer_s"))
    masks, w_first = a["ma_masks"], np.asarray(a["manipulability_first"], dtype=float)
    path_xy, threshold = np.asarray(a["path_xy"], dtype=float), a["threshold"].ravel()
    shape = (len(xs), len(ys))
    if (
        xs.ndim != 1
        or ys.ndim != 1
        or s.ndim != 1
        or len(s) < 2
        or min(shape) < 2
        or masks.shape != (len(s), *shape)
        or w_first.shape != shape
        or path_xy.shape != (len(s), 2)
        or threshold.size != 1
    ):
        return None
    w_last = _float(artifacts, "manipulability_last")
    path_s, rows = _float(artifacts, "path_s"), _float(artifacts, "path_xy_rows")
    if path_s is None or rows is None or rows.shape != (len(path_s), 2):
        path_s, rows = s, path_xy
    tool = _float(artifacts, "tool_positions")
    subgoals = _float(artifacts, "subgoal_layers")
    picks = np.array([0, len(s) - 1]) if subgoals is None else subgoals.round().astype(np.intp)
    return LmaData(
        xs=xs,
        ys=ys,
        s=s,
        masks=masks > 0.5,
        w_first=w_first,
        w_last=w_last if w_last is not None and w_last.shape == shape else None,
        threshold=float(threshold[0]),
        path_xy=path_xy,
        path_s=path_s,
        path_rows=rows,
        tool=tool if tool is not None and tool.shape == (len(s), 3) else None,
        subgoals=picks[(picks >= 0) & (picks < len(s))],
    )
