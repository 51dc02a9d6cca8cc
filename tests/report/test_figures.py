"""Every report figure: each axis carries a unit, legends stay outside the plotting area,
captions cite the papers by their keys; the layout helpers and the forked drawing."""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from tests.report.plans import make_plan_dir

KEYS = ("[PajakPajak]", "[Pajak]", "[AbdessemedDjebrani]", "[JaniakTchon]", "[Nagatani]")
MODULES = ("figures", "figures_space", "figures_method", "figures_vibration")


@pytest.fixture(scope="module")
def drawn(tmp_path_factory: pytest.TempPathFactory) -> list[tuple[Any, Figure]]:
    """(rendered figure, its matplotlib Figure) for every figure of the hand-made plan, with a
    vibration spectrum and a path-tracking history added."""
    import importlib

    from mmplan.report import build
    from mmplan.report.context import build_context
    from mmplan.report.figure_kit import render
    from mmplan.report.plan_data import read_plan_dir

    folder = make_plan_dir(tmp_path_factory.mktemp("figures") / "plan")
    with np.load(folder / "artifacts.npz") as npz:
        arrays = {k: npz[k] for k in npz.files}
    freq = np.linspace(0.0, 50.0, 101)
    arrays.update(vibration_freq_hz=freq, vibration_amplitude=np.exp(-((freq - 15) ** 2)) + 1e-3,
                  vibration_time_s=np.linspace(0, 2, 50), vibration_acceleration_norm=np.ones(50))
    np.savez(folder / "artifacts.npz", **arrays)
    captured: list[tuple[Any, Figure]] = []

    def keep(fig: Figure, name: str, title: str, caption: str) -> Any:
        out = render(fig, name, title, caption)
        captured.append((out, fig))
        return out

    patch = pytest.MonkeyPatch()
    for name in MODULES:
        patch.setattr(importlib.import_module(f"mmplan.report.{name}"), "render", keep)
    try:
        build.collect_figures(build_context(read_plan_dir(folder)))
    finally:
        patch.undo()
    return captured


def _panels(fig: Figure) -> list[Axes]:
    return [ax for ax in fig.axes if ax.get_visible() and ax.get_label() != "<colorbar>"]


def test_every_axis_has_a_unit(drawn: list[tuple[Any, Figure]]) -> None:
    assert len(drawn) >= 12
    unit = re.compile(r"\[[^\]]+\]$")
    for rendered, fig in drawn:
        panels = _panels(fig)
        assert panels[-1].get_xlabel(), rendered.name  # panels above may share its x axis
        for ax in panels:
            assert unit.search(ax.get_ylabel()), (rendered.name, ax.get_ylabel())
            assert not ax.get_xlabel() or unit.search(ax.get_xlabel()), (rendered.name,
                                                                        ax.get_xlabel())


def test_legends_stay_outside_the_data(drawn: list[tuple[Any, Figure]]) -> None:
    for rendered, fig in drawn:
        renderer = FigureCanvasAgg(fig).get_renderer()
        for ax in _panels(fig):
            legend = ax.get_legend()
            if legend is None:
                continue
            box, area = legend.get_window_extent(renderer), ax.get_window_extent(renderer)
            overlap = box.x0 < area.x1 - 1 and box.x1 > area.x0 + 1 \
                and box.y0 < area.y1 - 1 and box.y1 > area.y0 + 1
            assert not overlap, rendered.name
            assert box.x1 <= fig.bbox.width + 1 and box.y0 >= -1, rendered.name  # on the page


def test_captions_cite_the_papers(drawn: list[tuple[Any, Figure]]) -> None:
    for rendered, _ in drawn:
        if rendered.name.startswith("artifact_"):
            continue  # generic drawings of unknown arrays
        text = rendered.title + rendered.caption
        assert any(key in text for key in KEYS), rendered.name


def test_stack_layout_leaves_room_for_labels_and_legend() -> None:
    from mmplan.report.figure_kit import legend_outside
    from mmplan.report.figure_layout import stack_layout

    fig = Figure(figsize=(6, 4), dpi=100)
    axes = fig.subplots(2, 1)
    for ax in axes:
        ax.plot([0, 1e4], [0, -1e-5], label="a rather long legend entry")
        ax.set_xlabel("time t [s]")
        ax.set_ylabel("value [m]")
        ax.set_title("panel")
        legend_outside(ax)
    stack_layout(fig)
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    boxes = [ax.get_tightbbox(renderer) for ax in axes]
    for box in boxes:  # everything on the page
        assert box.x0 >= 0 and box.y0 >= 0 and box.x1 <= 600 and box.y1 <= 400
    assert boxes[1].y1 <= boxes[0].y0 + 1  # the panels' decorations do not overlap


def test_tick_label_measure_is_matplotlibs_tight_box_without_the_label() -> None:
    """The layout's shortcut through matplotlib's steps measures what ``get_tightbbox``
    measures with the axis label hidden: tick labels and offset texts (here ``1e4`` and
    ``1e-5`` offsets), on both axes of panels with and without a legend and a log axis."""
    from mmplan.report.figure_kit import legend_outside, log_y
    from mmplan.report.figure_layout import _tick_labels_box

    fig = Figure(figsize=(6, 5), dpi=110)
    axes = fig.subplots(3, 1)
    axes[0].plot([1e4, 1e4 + 1e-3], [1e-5, 1.00001e-5], label="offsets on both axes")
    axes[1].plot([0.0, 3.0], [1e-6, 10.0])
    log_y(axes[1])
    axes[2].plot([-2.0, 2.0], [0.5, -0.5], label="plain")
    for ax in axes:
        ax.set_xlabel("a long x label [s]")
        ax.set_ylabel("y [m]")
        legend_outside(ax)
    renderer = FigureCanvasAgg(fig).get_renderer()
    for ax in axes:
        for axis in (ax.xaxis, ax.yaxis):
            fast = _tick_labels_box(axis, renderer)
            axis.label.set_visible(False)
            reference = axis.get_tightbbox(renderer)
            axis.label.set_visible(True)
            assert fast is not None and reference is not None
            assert np.allclose(fast.extents, reference.extents, atol=1e-9), axis.axis_name
    assert axes[0].yaxis.offsetText.get_text() and axes[0].xaxis.offsetText.get_text()


def test_background_job_returns_the_childs_result_or_runs_here() -> None:
    from mmplan.report.background import Background, can_fork

    parent = os.getpid()
    job = Background(lambda: (os.getpid(), np.arange(3)))
    pid, values = job.result()
    assert values.tolist() == [0, 1, 2]
    assert (pid != parent) == can_fork()  # drawn in a child where fork is available

    def fails() -> int:
        if os.getpid() != parent:
            raise RuntimeError("only in the child")
        return 7

    assert Background(fails).result() == 7  # the child failed: run again here
    with pytest.raises(ZeroDivisionError):
        Background(lambda: 1 // 0).result()  # fails here too: the error surfaces
    Background(lambda: 1, enabled=True).cancel()  # no zombie, no error


def test_staged_job_sends_each_stage_or_runs_here() -> None:
    from mmplan.report.background import Staged, can_fork

    parent = os.getpid()

    def stages() -> Any:
        yield os.getpid()
        yield np.arange(3)

    job = Staged(stages)
    assert (job.next() != parent) == can_fork()  # computed in a child where fork is available
    assert job.next().tolist() == [0, 1, 2]
    job.cancel()
    here = Staged(stages, enabled=False)
    assert here.next() == parent and here.next().tolist() == [0, 1, 2]

    def fails_later() -> Any:
        yield "first"
        if os.getpid() != parent:
            raise RuntimeError("only in the child")
        yield "second"

    job = Staged(fails_later)
    assert [job.next(), job.next()] == ["first", "second"]  # re-run here, "first" skipped
    job.cancel()
    job = Staged(lambda: iter([1 // 0]))
    with pytest.raises(ZeroDivisionError):
        job.next()  # fails here too: the error surfaces
    Staged(stages).cancel()  # no zombie, no error


def test_history_axis_is_time_or_iteration(tmp_path: Path) -> None:
    from mmplan.report.figures_method import history_figure

    t = np.linspace(0.0, 2.0, 5)
    assert history_figure({"error": np.ones(5)}, t) is not None
    rows = {"iteration": np.arange(4.0), "error_norm": np.array([1.0, 0.1, 0.01, 0.001])}
    figure = history_figure(rows)
    assert figure is not None and "[JaniakTchon]" in figure.caption
