"""Figures of the manipulability-area planner ([Nagatani], Figs. 3, 4, 5 and 8).

* ``lma_distribution``: the manipulability distribution of the first layer as a surface over
  the base position (x, y), with the threshold plane ([Nagatani] Fig. 3);
* ``lma_ring``: the manipulability area of the first and the last layer from above, a filled
  ring, with the task point and the wall ([Nagatani] Fig. 4);
* ``lma_layers_3d``: the layered manipulability areas, every layer's MA boundary at its task
  parameter s, with the chosen base path through the layers and its sub-goals, from two
  viewpoints ([Nagatani] Figs. 5, 8);
* ``lma_top_view``: every MA overlaid from above (cells coloured by the number of layers whose
  MA holds them) with the base path.

Manipulability is shown in 10^-3 m^3 (docs/manipulability_area.md gives w in m^3).
"""

from __future__ import annotations

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import ListedColormap, Normalize
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d import Axes3D
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from mmplan.report.figure_kit import DPI, RenderedFigure, render
from mmplan.report.figures_lma_layers import draw_wall, layers_figure, panel_width, top_view_figure
from mmplan.report.lma_data import Array, LmaData

W_SCALE = 1e3
W_LABEL = r"manipulability $w$ [$10^{-3}$ m$^3$]"
MAX_SURFACE_CELLS = 90
PATH_STYLE = {"color": "black", "lw": 2.5}


def _grid(data: LmaData) -> tuple[Array, Array]:
    return np.meshgrid(data.xs, data.ys, indexing="ij")


def _crop(data: LmaData, margin: float) -> tuple[slice, slice]:
    x0, x1, y0, y1 = data.bounds(margin)
    ix = np.flatnonzero((data.xs >= x0) & (data.xs <= x1))
    iy = np.flatnonzero((data.ys >= y0) & (data.ys <= y1))
    return slice(ix[0], ix[-1] + 1), slice(iy[0], iy[-1] + 1)


def _quads(X: Array, Y: Array, Z: Array) -> Array:
    """Cells of a grid surface as quadrilaterals (n, 4, 3)."""
    corners = [
        (slice(None, -1), slice(None, -1)),
        (slice(1, None), slice(None, -1)),
        (slice(1, None), slice(1, None)),
        (slice(None, -1), slice(1, None)),
    ]
    return np.stack([np.stack([X[c], Y[c], Z[c]], axis=-1) for c in corners], axis=2).reshape(
        -1, 4, 3
    )


def _block_max(X: Array, Y: Array, W: Array, block: int) -> tuple[Array, Array, Array]:
    """Coarser grid for drawing: block centres and the largest w of each block x block cell
    group (keeps thin ridges of the distribution that plain striding would skip)."""
    if block == 1:
        return X, Y, W
    nx, ny = (n // block * block for n in W.shape)

    def blocks(a: Array) -> Array:
        return a[:nx, :ny].reshape(nx // block, block, ny // block, block)

    return blocks(X).mean(axis=(1, 3)), blocks(Y).mean(axis=(1, 3)), blocks(W).max(axis=(1, 3))


def _surface_with_plane(
    ax: Axes3D, X: Array, Y: Array, W: Array, level: float, norm: Normalize
) -> None:
    """The surface W(X, Y) and the plane z = level where the surface lies below it, as one
    polygon collection so that mplot3d depth-sorts them together (painter's algorithm)."""
    cmap = mpl.colormaps["viridis"]
    surface = _quads(X, Y, W)
    colours = cmap(norm(surface[:, :, 2].mean(axis=1)))
    below = _quads(X, Y, np.full_like(W, level))[(_quads(X, Y, W)[:, :, 2] < level).all(axis=1)]
    plane = np.array(mpl.colors.to_rgba("tab:red", 0.35))
    polys = np.concatenate([surface, below])
    faces = np.concatenate([colours, np.tile(plane, (len(below), 1))])
    ax.add_collection3d(Poly3DCollection(list(polys), facecolors=faces, linewidths=0.0))


def distribution_figure(data: LmaData) -> RenderedFigure:
    """[Nagatani] Fig. 3: w of the first layer over the base position, with the threshold plane."""
    fig = Figure(figsize=(7.6, 5.8), dpi=DPI, layout="constrained")
    ax: Axes3D = fig.add_subplot(projection="3d")
    sx, sy = _crop(data, 0.1)
    X, Y = (g[sx, sy] for g in _grid(data))
    W = data.w_first[sx, sy] * W_SCALE
    block = max(1, int(np.ceil(max(W.shape) / MAX_SURFACE_CELLS)))
    X, Y, W = _block_max(X, Y, W, block)
    level = data.threshold * W_SCALE
    norm = Normalize(0.0, float(W.max()))
    _surface_with_plane(ax, X, Y, W, level, norm)
    if data.tool is not None:
        ax.scatter(
            *data.tool[0, :2],
            0.0,
            marker="*",
            s=120,
            color="tab:red",
            edgecolors="black",
            depthshade=False,
            label="task point (tool), layer 0",
        )
    ax.plot([], [], color="tab:red", alpha=0.5, lw=6, label=f"threshold {level:.3f}")
    fig.legend(loc="outside lower center", ncols=2, fontsize=8)
    ax.set_xlim(float(X.min()), float(X.max()))
    ax.set_ylim(float(Y.min()), float(Y.max()))
    ax.set_zlim(0.0, float(W.max()) * 1.05)
    ax.set_xlabel("base x [m]")
    ax.set_ylabel("base y [m]")
    ax.set_zlabel(W_LABEL, fontsize=8)
    ax.view_init(elev=30, azim=-130)
    bar = fig.colorbar(mpl.cm.ScalarMappable(norm, "viridis"), ax=ax, shrink=0.6, pad=0.08)
    bar.set_label(W_LABEL)
    bar.ax.axhline(level, color="tab:red", lw=2)
    ax.set_title(
        f"Manipulability distribution over the base position, layer 0 (s = {data.s[0]:.2f})",
        fontsize=10,
    )
    return render(
        fig,
        "lma_distribution",
        "Manipulability distribution ([Nagatani] Fig. 3)",
        f"w of the arm for the first tool pose as a function of the base position; red plane: "
        f"the threshold {data.threshold:.4g} m^3 (max of w over the layer "
        f"{data.w_first.max():.4g} m^3). Bases where the surface rises above the plane form "
        "the manipulability area; w = 0 where the pose is out of reach"
        + (f" (drawn on {block} x {block} cell blocks, their largest w)." if block > 1 else "."),
    )


def _ring_panel(
    ax: Axes,
    data: LmaData,
    layer: int,
    w: Array | None,
    norm: Normalize,
    box: tuple[float, float, float, float],
) -> mpl.cm.ScalarMappable:
    mask = data.masks[layer]
    extent = data.extent()
    values = np.zeros_like(mask, dtype=float) if w is None else w * W_SCALE
    reachable = np.ma.masked_where(~((values > 0) & ~mask), np.ones_like(values))
    ax.imshow(
        reachable.T,
        origin="lower",
        extent=extent,
        cmap=ListedColormap(["0.88"]),
        interpolation="nearest",
    )
    inside = np.ma.masked_where(~mask, values if w is not None else np.ones_like(values))
    image = ax.imshow(
        inside.T, origin="lower", extent=extent, cmap="viridis", norm=norm, interpolation="nearest"
    )
    ax.contour(data.xs, data.ys, mask.T.astype(float), levels=[0.5], colors="black", linewidths=1.0)
    draw_wall(ax, data, box)
    if data.tool is not None:
        ax.plot(
            *data.tool[layer, :2],
            marker="*",
            ms=14,
            color="tab:red",
            mec="black",
            ls="none",
            label="task point (tool)",
        )
    ax.plot(
        *data.path_xy[layer],
        marker="o",
        ms=7,
        color="white",
        mec="black",
        ls="none",
        label="planned base",
    )
    ax.set_xlim(box[0], box[1])
    ax.set_ylim(box[2], box[3])
    ax.set_aspect("equal")
    ax.set_xlabel("base x [m]")
    ax.set_ylabel("base y [m]")
    ax.set_title(f"layer {layer} (s = {data.s[layer]:.2f}): {int(mask.sum())} cells", fontsize=9)
    ax.grid(True, alpha=0.3)
    return image


def ring_figure(data: LmaData) -> RenderedFigure:
    """[Nagatani] Fig. 4: the MA of the first and the last layer from above, filled with w."""
    layers = [0, data.layers - 1]
    ws = [data.w_first, data.w_last]
    boxes = [data.bounds(0.08, layer) for layer in layers]
    top = max(float(np.nanmax(w)) for w in ws if w is not None) * W_SCALE
    norm = Normalize(data.threshold * W_SCALE, top)
    widths = [min(max(panel_width(box, 4.2), 2.5), 6.0) for box in boxes]
    fig = Figure(figsize=(sum(widths) + 2.4, 5.4), dpi=DPI, layout="constrained")
    axes = fig.subplots(1, 2, width_ratios=widths)
    for ax, layer, w, box in zip(axes, layers, ws, boxes, strict=True):
        image = _ring_panel(ax, data, layer, w, norm, box)
    fig.legend(
        *axes[0].get_legend_handles_labels(), loc="outside lower center", ncols=3, fontsize=8
    )
    bar = fig.colorbar(image, ax=list(axes), shrink=0.8)
    bar.set_label(W_LABEL + " inside the MA")
    fig.suptitle(
        "Manipulability area (coloured) seen from above; grey: reachable, w below the threshold",
        fontsize=10,
    )
    return render(
        fig,
        "lma_ring",
        "Manipulability area of the first and last layer ([Nagatani] Fig. 4)",
        f"Bases whose w reaches the threshold {data.threshold:.4g} m^3 (coloured by w), the "
        "tool's task point (star), the wall (hatched) and the planned base position (circle).",
    )


def lma_figures(data: LmaData) -> list[RenderedFigure]:
    """The four manipulability-area figures, in report order."""
    return [
        distribution_figure(data),
        ring_figure(data),
        layers_figure(data),
        top_view_figure(data),
    ]
