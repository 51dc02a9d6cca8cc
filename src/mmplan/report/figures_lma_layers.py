"""Layered manipulability areas ([Nagatani], Figs. 5 and 8) and their top view.

* ``lma_layers_3d``: every layer's MA boundary at its task parameter s, with the chosen base
  path through the layers and its sub-goals, from two viewpoints ([Nagatani] Figs. 5, 8);
* ``lma_top_view``: every MA overlaid from above (cells coloured by the number of layers whose
  MA holds them), the first and last layer's MA, the wall, the tool's stroke and the base path.
"""

from __future__ import annotations

from typing import Any

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import ListedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d import Axes3D

from mmplan.report.figure_kit import DPI, RenderedFigure, render
from mmplan.report.lma_data import LmaData

PATH_STYLE: dict[str, Any] = {"color": "black", "lw": 2.5}
MARKER: dict[str, Any] = {"color": "white", "mec": "black", "ls": "none"}


def draw_wall(ax: Axes, data: LmaData, box: tuple[float, float, float, float]) -> None:
    """The wall's trace with hatching on the side away from the base."""
    line = data.wall_line()
    if line is None:
        return
    point, normal = line
    direction = np.array([-normal[1], normal[0]])
    reach = 2.0 * max(box[1] - box[0], box[3] - box[2])
    ends = np.array([point - reach * direction, point + reach * direction])
    behind = np.array([ends[1], ends[0], ends[0] - 0.04 * normal, ends[1] - 0.04 * normal])
    ax.fill(behind[:, 0], behind[:, 1], facecolor="0.85", edgecolor="0.3", hatch="///", lw=0)
    ax.plot(ends[:, 0], ends[:, 1], color="0.2", lw=2, label="wall")


def panel_width(box: tuple[float, float, float, float], height: float) -> float:
    """Width [in] of an equal-aspect panel of the given height showing ``box``."""
    return height * (box[1] - box[0]) / max(box[3] - box[2], 1e-9)


def _path_3d(ax: Axes3D, data: LmaData) -> None:
    ax.plot(
        data.path_rows[:, 0],
        data.path_rows[:, 1],
        data.path_s,
        zorder=10,
        label="base path",
        **PATH_STYLE,
    )
    ends = data.subgoals[[0, -1]] if data.subgoals.size else np.array([0, data.layers - 1])
    inner = [k for k in data.subgoals if k not in ends]
    for k, marker, label in ((ends[0], "o", "start"), (ends[-1], "s", "goal")):
        ax.scatter(
            *data.path_xy[k],
            data.s[k],
            marker=marker,
            s=45,
            color="white",
            edgecolors="black",
            depthshade=False,
            zorder=11,
            label=label,
        )
    if inner:
        idx = np.asarray(inner, dtype=int)
        ax.scatter(
            data.path_xy[idx, 0],
            data.path_xy[idx, 1],
            data.s[idx],
            marker="D",
            s=40,
            color="tab:orange",
            edgecolors="black",
            depthshade=False,
            zorder=11,
            label="sub-goals",
        )
    if data.tool is not None:
        ax.plot(
            data.tool[:, 0],
            data.tool[:, 1],
            data.s,
            color="tab:red",
            lw=2,
            ls="--",
            label="tool (task)",
        )


def layers_figure(data: LmaData) -> RenderedFigure:
    """[Nagatani] Figs. 5 and 8: the MA boundaries stacked along s with the base path, two views."""
    fig = Figure(figsize=(11.0, 5.4), dpi=DPI, layout="constrained")
    cmap = mpl.colormaps["viridis"]
    norm = Normalize(float(data.s[0]), float(data.s[-1]))
    box = data.bounds(0.05)
    for index, (elev, azim) in enumerate(((24.0, -120.0), (12.0, -20.0))):
        ax: Axes3D = fig.add_subplot(1, 2, index + 1, projection="3d")
        for k in range(data.layers):
            if not data.masks[k].any():
                continue
            ends = k in (0, data.layers - 1)
            ax.contour(
                data.xs,
                data.ys,
                data.masks[k].T.astype(float),
                levels=[0.5],
                offset=float(data.s[k]),
                colors=[cmap(norm(data.s[k]))],
                linewidths=2.0 if ends else 0.8,
                alpha=1.0 if ends else 0.7,
            )
        _path_3d(ax, data)
        ax.set_xlim(box[0], box[1])
        ax.set_ylim(box[2], box[3])
        ax.set_zlim(float(data.s[0]), float(data.s[-1]))
        ax.set_xlabel("base x [m]")
        ax.set_ylabel("base y [m]")
        ax.set_zlabel("task parameter s")
        ax.view_init(elev=elev, azim=azim)
        ax.set_box_aspect(None, zoom=0.88)
    handles = fig.axes[0].get_legend_handles_labels()
    fig.legend(*handles, loc="outside lower center", ncols=len(handles[0]), fontsize=8)
    bar = fig.colorbar(mpl.cm.ScalarMappable(norm, cmap), ax=fig.axes, shrink=0.6)
    bar.set_label("layer's task parameter s (MA boundary colour)")
    kind = "straight" if data.subgoals.size <= 2 else f"{data.subgoals.size - 2} sub-goals"
    fig.suptitle(
        f"Layered manipulability areas: {data.layers} layers, base path ({kind})", fontsize=10
    )
    return render(
        fig,
        "lma_layers_3d",
        "Layered manipulability areas with the base path ([Nagatani] Figs. 5, 8)",
        "Boundary of every layer's MA at its task parameter s (thick: first and last layer), "
        f"the planned base path through the layers (black; {kind}"
        + (
            f" at layers {', '.join(str(int(k)) for k in data.subgoals[1:-1])}"
            if kind != "straight"
            else ""
        )
        + ") with its start and goal, and the tool's path on the task (red, dashed); two "
        "viewpoints.",
    )


def top_view_figure(data: LmaData) -> RenderedFigure:
    """All MAs from above: cells coloured by how many layers' MAs hold them, with the path."""
    box = data.bounds(0.05)
    counts = data.masks.sum(axis=0).astype(float)
    width = min(max(panel_width(box, 5.6), 3.0), 8.0)
    fig = Figure(figsize=(max(width + 2.2, 5.0), 6.8), dpi=DPI, layout="constrained")
    ax = fig.add_subplot()
    shown = np.ma.masked_where(counts == 0, counts)
    most = int(counts.max())
    blues = ListedColormap(mpl.colormaps["Blues"](np.linspace(0.15, 1.0, max(most, 1))))
    image = ax.imshow(
        shown.T,
        origin="lower",
        extent=data.extent(),
        interpolation="nearest",
        cmap=blues,
        norm=Normalize(0.5, most + 0.5),
    )
    every = data.masks.all(axis=0)
    if every.any():
        ax.contour(
            data.xs,
            data.ys,
            every.T.astype(float),
            levels=[0.5],
            colors="tab:green",
            linewidths=1.8,
        )
        ax.plot([], [], color="tab:green", lw=1.8, label="in every layer's MA")
    cmap, norm = mpl.colormaps["viridis"], Normalize(float(data.s[0]), float(data.s[-1]))
    for k, name in ((0, "first"), (data.layers - 1, "last")):
        if data.masks[k].any():
            ax.contour(
                data.xs,
                data.ys,
                data.masks[k].T.astype(float),
                levels=[0.5],
                colors=[cmap(norm(data.s[k]))],
                linewidths=1.6,
            )
            ax.plot([], [], color=cmap(norm(data.s[k])), lw=1.6, label=f"MA of the {name} layer")
    draw_wall(ax, data, box)
    if data.tool is not None:
        ax.plot(data.tool[:, 0], data.tool[:, 1], color="tab:red", lw=3, label="tool (task)")
    ax.plot(data.path_rows[:, 0], data.path_rows[:, 1], label="base path", **PATH_STYLE)
    ax.plot(*data.path_xy[0], marker="o", ms=8, label="start", **MARKER)
    ax.plot(*data.path_xy[-1], marker="s", ms=8, label="goal", **MARKER)
    inner = [k for k in data.subgoals if k not in (0, data.layers - 1)]
    if inner:
        ax.plot(
            *data.path_xy[np.asarray(inner, dtype=int)].T,
            marker="D",
            ms=7,
            color="tab:orange",
            mec="black",
            ls="none",
            label="sub-goals",
        )
    ax.set_xlim(box[0], box[1])
    ax.set_ylim(box[2], box[3])
    ax.set_aspect("equal")
    ax.set_xlabel("base x [m]")
    ax.set_ylabel("base y [m]")
    ax.grid(True, alpha=0.3)
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncols=2, fontsize=8)
    bar = fig.colorbar(image, ax=ax, shrink=0.8)
    bar.set_label(f"layers whose MA holds the cell (of {data.layers})")
    bar.ax.yaxis.set_major_locator(MaxNLocator(nbins=min(most, 8), integer=True))
    length = float(np.linalg.norm(np.diff(data.path_rows, axis=0), axis=1).sum())
    ax.set_title(f"All {data.layers} MAs from above\nbase path {length:.3f} m", fontsize=10)
    return render(
        fig,
        "lma_top_view",
        "Manipulability areas of all layers with the base path",
        f"Cells coloured by the number of layers whose MA contains them; green: the cells in "
        f"all {data.layers} MAs; black: the planned base path ({length:.3f} m in x-y).",
    )
