"""Method-specific figures from history.csv and artifacts.npz.

* history.csv: every column against ``iteration`` (e.g. the endogenous method's error norm,
  [JaniakTchon]), log scale when positive and spanning decades;
* artifacts.npz of the manipulability-area planner ([Nagatani]): the distribution surface, the
  MA ring, the layered MAs in 3D with the base path and their top view
  (:mod:`mmplan.report.figures_lma`); a tip-vibration spectrum ([Pajak],
  :mod:`mmplan.report.figures_vibration`);
* any other arrays, drawn generically by name and shape: 1-D arrays against an axis of the
  same length whose name contains ``freq`` (spectra) or ``time``; 2-D grids as images (axes
  from 1-D arrays whose names contain ``x`` / ``y`` and match the grid's shape), 3-D stacks as
  a few layers, point lists (K, 2) or (K, 3) as paths drawn over the grids.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from mmplan.report.figure_kit import (
    DPI,
    RenderedFigure,
    axis_label,
    legend_outside,
    log_y,
    new_figure,
    render,
    unit_of,
)
from mmplan.report.figures_lma import lma_figures
from mmplan.report.figures_vibration import VIBRATION_KEYS, vibration_figure
from mmplan.report.lma_data import OPTIONAL, REQUIRED, read_lma

Array = np.ndarray
MAX_PANELS = 6


def _positive_decades(values: Array) -> bool:
    finite = values[np.isfinite(values)]
    return bool(finite.size and (finite > 0).all() and finite.max() > 100 * finite.min())


#: Units of planners' history.csv columns (names without a unit suffix).
HISTORY_UNITS = {"error": "m", "task_error": "m", "error_norm": "-", "perturbation_scale": "-",
                 "min_singular_value": "-", "sigma_bound": "-"}
#: What each method's history is, with its paper.
HISTORY_SOURCES = {
    "iteration": "per iteration of the endogenous method's Jacobian iteration ([JaniakTchon] "
                 "eq. (20)): error norm, task error, smallest singular value",
    "t": "per time step of the tracking rollout ([AbdessemedDjebrani] s.2, s.3)",
    "samples": "per trajectory sample of the extended-Jacobian generator ([PajakPajak] eq. "
               "(19)): task error and the obstacle perturbation's scale",
}


def history_figure(history: Mapping[str, Array], t: Array | None = None
                   ) -> RenderedFigure | None:
    """Per-iteration or per-step series of history.csv, one panel per column.

    The x axis is the ``iteration`` column, the ``t`` column, or (a history with one row
    per trajectory sample and neither) the trajectory's time ``t``.
    """
    if not history:
        return None
    x_name = next((k for k in ("iteration", "t") if k in history), None)
    series = {k: v for k, v in history.items() if k != x_name}
    if not series:
        return None
    first = np.asarray(next(iter(series.values())))
    if x_name is not None:
        x, source = np.asarray(history[x_name], dtype=float), HISTORY_SOURCES[x_name]
        x_label = "iteration [-]" if x_name == "iteration" else "t [s]"
    elif t is not None and len(t) == len(first):
        x, x_label, source = np.asarray(t, float), "t [s]", HISTORY_SOURCES["samples"]
    else:
        x, x_label, source = np.arange(len(first), dtype=float), "row [-]", "per row"
    names = list(series)[:MAX_PANELS]
    fig = Figure(figsize=(7.0, 1.9 * len(names) + 0.6), dpi=DPI, layout=None)
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    for ax, name in zip(axes, names, strict=True):
        y = np.asarray(series[name], dtype=float)
        ax.plot(x[: len(y)], y, marker="." if len(y) < 60 else None)
        if _positive_decades(y):
            log_y(ax)
        ax.set_ylabel(axis_label(name, HISTORY_UNITS.get(name, unit_of(name))))
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel(x_label)
    last = {n: float(series[n][-1]) for n in names}
    text = ", ".join(f"{n} = {v:.3g}" for n, v in last.items())
    title = "Convergence per iteration" if x_name == "iteration" else "Planner series over time"
    return render(fig, "history", title, f"Columns of history.csv, {source}; last: {text}.")


def _is_path(a: Array) -> bool:
    if a.ndim != 2 or a.shape[0] < 2:
        return False
    return a.shape[1] == 2 or (a.shape[1] == 3 and a.shape[0] != 3)


def _axis_letter(name: str) -> str:
    """``x`` for names like ``x``, ``grid_x``, ``xs``; else the last token."""
    token = name.lower().split("_")[-1]
    return token[:-1] if token in ("xs", "ys") else token


def _axis_for(artifacts: Mapping[str, Array], length: int, letter: str) -> Array | None:
    for name, a in artifacts.items():
        if a.ndim == 1 and len(a) == length and _axis_letter(name) == letter:
            return np.asarray(a, dtype=float)
    return None


def _grid_axes(
    grid: Array, artifacts: Mapping[str, Array]
) -> tuple[Array, Array | None, Array | None]:
    """The grid as an image (rows = y) and its x / y axes when artifacts hold them.

    A grid (ny, nx) is used as is; a grid (nx, ny) (``indexing="ij"``) is transposed when
    only that orientation matches the axes' lengths.
    """
    rows, cols = grid.shape
    gx, gy = _axis_for(artifacts, cols, "x"), _axis_for(artifacts, rows, "y")
    if gx is None or gy is None:
        tx, ty = _axis_for(artifacts, rows, "x"), _axis_for(artifacts, cols, "y")
        if tx is not None and ty is not None:
            return grid.T, tx, ty
    return grid, gx, gy


def _inside(path: Array, extent: tuple[float, float, float, float]) -> bool:
    x0, x1 = sorted(extent[:2])
    y0, y1 = sorted(extent[2:])
    ok = (path[:, 0] >= x0) & (path[:, 0] <= x1) & (path[:, 1] >= y0) & (path[:, 1] <= y1)
    return bool(ok.mean() >= 0.8)


def _draw_grid(
    ax: Axes, grid: Array, artifacts: Mapping[str, Array], paths: dict[str, Array],
    name: str = "value",
) -> None:
    image_data, gx, gy = _grid_axes(grid, artifacts)
    extent = None
    if gx is not None and gy is not None:  # cell centres -> cell edges
        hx = 0.5 * (gx[-1] - gx[0]) / max(len(gx) - 1, 1)
        hy = 0.5 * (gy[-1] - gy[0]) / max(len(gy) - 1, 1)
        extent = (float(gx[0] - hx), float(gx[-1] + hx), float(gy[0] - hy), float(gy[-1] + hy))
    image = ax.imshow(image_data, origin="lower", extent=extent, aspect="auto", cmap="viridis")
    bar = ax.figure.colorbar(image, ax=ax, shrink=0.8)
    bar.set_label(axis_label(name, unit_of(name)))
    if extent is None:
        ax.set_xlabel("column [-]")
        ax.set_ylabel("row [-]")
        return
    drawn = False
    for name, path in paths.items():
        if _inside(path, extent):
            ax.plot(path[:, 0], path[:, 1], color="white", lw=2.5)
            ax.plot(path[:, 0], path[:, 1], color="black", lw=1.0, label=name)
            drawn = True
    if drawn:
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), frameon=False,
                  ncols=3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def artifact_figures(artifacts: Mapping[str, Array]) -> list[RenderedFigure]:
    """The method's figures: the manipulability-area figures ([Nagatani]) and the vibration
    spectrum ([Pajak]) when artifacts.npz holds their data, the generic drawing for everything
    else."""
    arrays = {k: np.asarray(v) for k, v in artifacts.items() if np.asarray(v).dtype.kind in "fiub"}
    out: list[RenderedFigure] = []
    lma = read_lma(arrays)
    if lma is not None:
        out += lma_figures(lma)
        arrays = {k: v for k, v in arrays.items() if k not in REQUIRED + OPTIONAL}
    spectrum = vibration_figure(arrays)
    if spectrum is not None:
        out.append(spectrum)
        arrays = {k: v for k, v in arrays.items() if k not in VIBRATION_KEYS}
    return out + generic_figures(arrays)


def generic_figures(arrays: Mapping[str, Array]) -> list[RenderedFigure]:
    """One figure per grid, stack and spectrum, plus leftover 1-D series."""
    paths = {k: v.astype(float) for k, v in arrays.items() if _is_path(v)}
    out: list[RenderedFigure] = []
    used: set[str] = set(paths)
    for name, a in arrays.items():
        if a.ndim == 2 and name not in paths and min(a.shape) > 1:
            fig, ax = new_figure(width=6.4, height=4.8, constrained=True)
            _draw_grid(ax, a.astype(float), arrays, paths, name)
            ax.set_title(name)
            out.append(
                render(
                    fig,
                    f"artifact_{name}",
                    f"{name} (artifacts.npz)",
                    f"Grid {a.shape}, min {np.nanmin(a):.4g}, max {np.nanmax(a):.4g}; "
                    "paths drawn over it.",
                )
            )
            used.add(name)
        elif a.ndim == 3 and min(a.shape) > 1:
            layers = np.unique(
                np.linspace(0, a.shape[0] - 1, min(4, a.shape[0])).round().astype(int)
            )
            fig = Figure(figsize=(7.0, 5.6), dpi=DPI, layout="constrained")
            axes = fig.subplots(2, 2, squeeze=False).ravel()
            for ax, layer in zip(axes, layers, strict=False):
                _draw_grid(ax, a[layer].astype(float), arrays, paths, name)
                ax.set_title(f"{name}[{layer}]", fontsize=9)
            for ax in axes[len(layers) :]:
                ax.set_visible(False)
            out.append(
                render(
                    fig,
                    f"artifact_{name}",
                    f"{name} (artifacts.npz)",
                    f"Stack {a.shape}: layers {', '.join(map(str, layers))}.",
                )
            )
            used.add(name)
    grids = set(used) - set(paths)
    out += _series_figures(arrays, used)
    for name, path in paths.items() if not grids else ():
        fig, ax = new_figure(width=5.5, height=5.0)
        ax.plot(path[:, 0], path[:, 1], marker=".")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        out.append(
            render(
                fig,
                f"artifact_{name}",
                f"{name} (artifacts.npz)",
                f"Path of {len(path)} points (x, y).",
            )
        )
    return out


def _series_figures(arrays: Mapping[str, Array], used: set[str]) -> list[RenderedFigure]:
    ones = {k: v.astype(float) for k, v in arrays.items() if v.ndim == 1 and k not in used}
    axes_names = [k for k in ones if "freq" in k.lower() or "time" in k.lower() or k == "t"]
    out: list[RenderedFigure] = []
    for axis_name in axes_names:
        x = ones[axis_name]
        ys = {k: v for k, v in ones.items() if len(v) == len(x) and k not in axes_names}
        if not ys:
            continue
        fig, ax = new_figure()
        for name, y in list(ys.items())[:8]:
            ax.plot(x, y, label=name, lw=1.0)
        if all(_positive_decades(y) for y in ys.values()):
            log_y(ax)
        default = "Hz" if "freq" in axis_name.lower() else "s"
        ax.set_xlabel(axis_label(axis_name, unit_of(axis_name, default)))
        ax.set_ylabel(axis_label("value", ", ".join(sorted({unit_of(k) for k in ys}))))
        legend_outside(ax)
        spectral = "freq" in axis_name.lower()
        title = "Spectrum" if spectral else "Series"
        out.append(
            render(
                fig,
                f"artifact_{axis_name}",
                f"{title} (artifacts.npz)",
                f"{', '.join(ys)} against {axis_name}"
                + (" ([Pajak] Fig. 9: tip-acceleration spectrum)." if spectral else "."),
            )
        )
        used.update(ys)
        used.add(axis_name)
    rest = {k: v for k, v in ones.items() if k not in used and len(v) > 1}
    grid_axes = {k for k in rest if _axis_letter(k) in ("x", "y")}
    rest = {k: v for k, v in rest.items() if k not in grid_axes}
    if rest:
        fig, ax = new_figure()
        for name, y in list(rest.items())[:8]:
            ax.plot(np.arange(len(y)), y, label=name)
        ax.set_xlabel("index [-]")
        ax.set_ylabel(axis_label("value", ", ".join(sorted({unit_of(k) for k in rest}))))
        legend_outside(ax)
        out.append(
            render(
                fig,
                "artifact_series",
                "Other arrays (artifacts.npz)",
                f"{', '.join(rest)} against their index.",
            )
        )
    return out
