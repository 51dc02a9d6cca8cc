"""Shared pieces of the report figures: the rendered-figure record, PNG output, normalization.

Figures use matplotlib's object API (:class:`matplotlib.figure.Figure`), never pyplot, so no
global backend state is touched.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, NullLocator
from PIL import Image

from mmplan.arrays import Array
from mmplan.report.figure_layout import stack_layout

LIMIT_COLOR = "tab:red"
DPI = 110


@dataclass(frozen=True)
class RenderedFigure:
    """A figure as the report embeds it.

    Attributes:
        name: File stem (``figures/<name>.png``), unique within a report.
        title: Heading shown above the figure.
        caption: One or two sentences saying what is drawn (and the paper figure it mirrors).
        png: PNG bytes.
    """

    name: str
    title: str
    caption: str
    png: bytes


def new_figure(width: float = 7.0, height: float = 3.6, constrained: bool = False
               ) -> tuple[Figure, Axes]:
    """A figure with one axes, grid on; laid out by :func:`stack_layout` when rendered, or by
    matplotlib's constrained layout (for colorbars)."""
    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained" if constrained else None)
    ax = fig.add_subplot()
    ax.grid(True, alpha=0.3)
    return fig, ax


def log_y(ax: Axes) -> None:
    """Logarithmic y axis labelled in plain numbers (0.001, 1e-05), without minor ticks:
    mathtext powers of ten and nine minor ticks a decade were half of such a figure's
    drawing time."""
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    ax.yaxis.set_minor_locator(NullLocator())


def legend_outside(ax: Axes, **kwargs: object) -> None:
    """The axes' legend to the right of the plotting area, never over the data."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=8,
                  frameon=False, **kwargs)


#: Units of names ending in these suffixes (history.csv, artifacts.npz columns).
SUFFIX_UNITS = {"_m": "m", "_s": "s", "_hz": "Hz", "_rad": "rad", "_mps": "m/s",
                "_radps": "rad/s", "_mps2": "m/s^2", "_nm": "N m", "_n": "N"}


def unit_of(name: str, default: str = "-") -> str:
    """The unit a column name states by its suffix (``clearance_m`` -> m), else ``default``
    (``-``: dimensionless, or as stored)."""
    lower = name.lower()
    for suffix, unit in SUFFIX_UNITS.items():
        if lower.endswith(suffix):
            return unit
    return default


def axis_label(name: str, unit: str) -> str:
    """``name [unit]``."""
    return f"{name} [{unit}]"


def limit_line(ax: Axes, y: float, label: str | None = None) -> None:
    """Dashed red horizontal line marking a limit ([PajakPajak]'s figure style)."""
    ax.axhline(y, color=LIMIT_COLOR, linestyle="--", linewidth=1.0, label=label)


def render(fig: Figure, name: str, title: str, caption: str) -> RenderedFigure:
    """PNG of ``fig`` at its own dpi (no metadata, so identical input gives identical bytes);
    a figure without a layout engine is laid out by :func:`stack_layout` first. Stored as RGB
    when opaque (the report's white figures: a quarter less to compress), else as RGBA. Light
    compression: the report is written often and read from disk."""
    if fig.get_layout_engine() is None:
        stack_layout(fig)
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    image = Image.frombuffer("RGBA", canvas.get_width_height(), canvas.buffer_rgba(), "raw",
                             "RGBA", 0, 1)
    if image.getchannel("A").getextrema() == (255, 255):  # opaque
        image = image.convert("RGB")
    buffer = io.BytesIO()
    image.save(buffer, format="png", compress_level=3)
    return RenderedFigure(name, title, caption, buffer.getvalue())


def mean_normalized(values: Array, lower: Array, upper: Array) -> tuple[Array, Array]:
    """Mean normalization to [-0.5, 0.5] as in [PajakPajak] Figs. 4, 6, 7.

    Each column is mapped by x' = (x - (lo + hi)/2) / (hi - lo) so that its limits land on
    -0.5 and +0.5. Where a limit is infinite (or lo == hi) the column's own range stands in
    for [lo, hi].

    Args:
        values: (N, k).
        lower, upper: Limits (k,).

    Returns:
        The normalized values (N, k) and a boolean mask (k,) of columns normalized by limits.
    """
    lo = np.asarray(lower, dtype=float).copy()
    hi = np.asarray(upper, dtype=float).copy()
    by_limits = np.isfinite(lo) & np.isfinite(hi) & (hi > lo)
    data_lo, data_hi = np.nanmin(values, axis=0), np.nanmax(values, axis=0)
    lo = np.where(by_limits, lo, data_lo)
    hi = np.where(by_limits, hi, data_hi)
    span = np.where(hi > lo, hi - lo, 1.0)
    return (values - 0.5 * (lo + hi)) / span, by_limits
