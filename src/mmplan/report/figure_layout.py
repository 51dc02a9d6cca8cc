"""Margins for figures of stacked panels, measured once (a fast stand-in for matplotlib's
constrained layout).

Constrained layout re-measures every text of a figure several times and was 40 % of the
report's drawing time. The report's time series are panels stacked in one column with their
legends to the right, so their layout needs only a few measurements: how far each panel's
tick labels and axis labels reach left and below, its title above, its legend to the right.
:func:`stack_layout` measures those once with the figure's renderer and places the panels.
Figures with colorbars or 3D axes keep constrained layout.
"""

from __future__ import annotations

from typing import Any

from matplotlib.axes import Axes
from matplotlib.axis import Axis, XAxis
from matplotlib.backend_bases import RendererBase
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.text import Text
from matplotlib.transforms import Bbox

PAD = 6.0  # px around the figure and between panels


def _size(text: Text, renderer: RendererBase) -> tuple[float, float]:
    if not text.get_visible() or not text.get_text():
        return 0.0, 0.0
    box = text.get_window_extent(renderer)
    return float(box.width), float(box.height)


def _ticks_reach(axis: Axis, renderer: RendererBase) -> float:
    """How far the tick labels (and the offset text) reach beyond the spine [px], without the
    axis label."""
    box = _tick_labels_box(axis, renderer)
    ax = axis.axes
    if box is None:
        return 0.0
    if isinstance(axis, XAxis):
        return max(0.0, float(ax.bbox.y0 - box.y0))
    return max(0.0, float(ax.bbox.x0 - box.x0))


def _tick_labels_box(axis: Axis, renderer: RendererBase) -> Bbox | None:
    """What ``axis.get_tightbbox`` measures without the axis label, by the steps it takes
    itself minus the placing of the label: that step measures every tick label a second
    time (a quarter of a report's layout time). Falls back on ``get_tightbbox`` with the
    label hidden where matplotlib's internals differ."""
    steps: Any = axis  # matplotlib's own (private) steps of get_tightbbox
    try:
        ticks = steps._update_ticks()
        first, second = steps._get_ticklabel_bboxes(ticks, renderer)
        steps._update_offset_text_position(first, second)
        axis.offsetText.set_text(steps.major.formatter.get_offset())
    except (AttributeError, TypeError):  # pragma: no cover - other matplotlib versions
        label = axis.label
        visible = label.get_visible()
        label.set_visible(False)
        try:
            return axis.get_tightbbox(renderer)
        finally:
            label.set_visible(visible)
    boxes = [*first, *second]
    if axis.offsetText.get_visible():
        boxes.append(axis.offsetText.get_window_extent(renderer))
    boxes = [b for b in boxes if b._is_finite()]
    return Bbox.union(boxes) if boxes else None


def _margins(ax: Axes, renderer: RendererBase) -> tuple[float, float, float, float]:
    """(left, bottom, top, right) decorations of one panel [px]."""
    left = _ticks_reach(ax.yaxis, renderer) + _size(ax.yaxis.label, renderer)[0] + 4
    bottom = _ticks_reach(ax.xaxis, renderer) + _size(ax.xaxis.label, renderer)[1] + 4
    top = _size(ax.title, renderer)[1] + 4
    legend = ax.get_legend()
    right = float(legend.get_window_extent(renderer).width) + 12 if legend is not None else 0.0
    return left, bottom, top, right


def stack_layout(fig: Figure) -> None:
    """Place the figure's visible panels in one column, top to bottom in their current order,
    with room for their tick labels, axis labels, titles and right-hand legends."""
    axes = sorted((ax for ax in fig.axes if ax.get_visible()),
                  key=lambda a: -a.get_position().y1)
    if not axes:
        return
    renderer = FigureCanvasAgg(fig).get_renderer()
    width, height = float(fig.bbox.width), float(fig.bbox.height)
    margins = [_margins(ax, renderer) for ax in axes]
    left = max(m[0] for m in margins) + PAD
    right = max(m[3] for m in margins) + PAD
    decorations = sum(m[1] + m[2] for m in margins) + PAD * (len(axes) + 1)
    panel = max((height - decorations) / len(axes), 20.0)
    y = height - PAD
    for ax, (_, bottom, top, _) in zip(axes, margins, strict=True):
        y -= top + panel
        ax.set_position((left / width, y / height, max(width - left - right, 20.0) / width,
                         panel / height))
        y -= bottom + PAD
