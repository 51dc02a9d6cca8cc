"""Shared pieces of the report figures: the rendered-figure record, PNG output, normalization.

Figures use matplotlib's object API (:class:`matplotlib.figure.Figure`), never pyplot, so no
global backend state is touched.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from mmplan.arrays import Array

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


def new_figure(width: float = 7.0, height: float = 3.6) -> tuple[Figure, Axes]:
    """A figure with one axes, grid on."""
    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    ax = fig.add_subplot()
    ax.grid(True, alpha=0.3)
    return fig, ax


def limit_line(ax: Axes, y: float, label: str | None = None) -> None:
    """Dashed red horizontal line marking a limit ([PajakPajak]'s figure style)."""
    ax.axhline(y, color=LIMIT_COLOR, linestyle="--", linewidth=1.0, label=label)


def render(fig: Figure, name: str, title: str, caption: str) -> RenderedFigure:
    """PNG of ``fig`` (no metadata, so identical input gives identical bytes)."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=DPI, metadata={"Software": None})
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
