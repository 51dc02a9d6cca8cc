"""Writing a report: read the plan directory, derive, draw, assemble, write.

``write_report(DIR)`` writes ``DIR/report.html`` (one self-contained file) and
``DIR/figures/<name>.png`` (the same figures as files). The work is spread over four processes
(:mod:`.background`, forked), so that loading the libraries overlaps as well as drawing:

* the models' process, forked first (before matplotlib is loaded): loads the robot and scene
  models, derives (:mod:`.context`), sends the figures' data (:mod:`.figure_data`) and the
  summary, then builds the 3D view (meshcat) and runs what the caller adds (``mmplan report``:
  the plan's check);
* this process meanwhile loads matplotlib, then forks the figures of the plan's files alone
  (:mod:`.file_figures`: the method's artifacts and the planner's history) and, once the
  figures' data arrive, the spatial figures with the clearance; it draws the other time series
  itself. It never loads the models.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from mmplan.errors import InputError
from mmplan.report.background import Background, Staged
from mmplan.report.plan_data import PlanData, check_plan_dir, read_plan_dir

if TYPE_CHECKING:  # the models and matplotlib: loaded where they are used
    from mmplan.report.context import ReportContext
    from mmplan.report.figure_data import FigureData
    from mmplan.report.figure_kit import RenderedFigure
    from mmplan.report.figures import TimeFigure
    from mmplan.report.summary_rows import Overview

Step = Callable[[str], None]
T = TypeVar("T")


def _none(label: str) -> None:
    """No progress display."""


def _nothing() -> None:
    """No further work in the models' process."""


def first_half(data: FigureData) -> list[RenderedFigure]:
    """The spatial figures and the clearance over time (drawn in a child process)."""
    from mmplan.report.figures import clearance_figure
    from mmplan.report.figures_space import platform_figure, top_view_figure

    return [top_view_figure(data), platform_figure(data), *_drawn(data, (clearance_figure,))]


def second_half(data: FigureData) -> list[RenderedFigure]:
    """The other time series ([PajakPajak]'s and [Pajak]'s figures)."""
    from mmplan.report.figures import TIME_FIGURES, clearance_figure

    return _drawn(data, tuple(f for f in TIME_FIGURES if f is not clearance_figure))


def _drawn(data: FigureData, makers: tuple[TimeFigure, ...]) -> list[RenderedFigure]:
    return [f for f in (make(data) for make in makers) if f is not None]


TIME_SERIES = ("clearance", "joints", "manipulability", "torques_wheels", "torques_arm",
               "virtual_control", "extra_columns", "task_error")


def order(figures: list[RenderedFigure]) -> list[RenderedFigure]:
    """Report order: the top view, the time series (in :data:`TIME_SERIES` order), the
    platform, the planner's history, the method's figures (stable within each group)."""
    rank = {"top_view": 0.0, "platform": 2.0, "history": 2.5}
    rank.update({name: 1.0 + i / 100 for i, name in enumerate(TIME_SERIES)})
    return sorted(figures, key=lambda f: rank.get(f.name, 3.0))


def collect_figures(ctx: ReportContext) -> list[RenderedFigure]:
    """Every figure the plan has data for, in report order (drawn in this process)."""
    from mmplan.report.figure_data import figure_data
    from mmplan.report.file_figures import file_figures

    data = figure_data(ctx)
    return order(first_half(data) + second_half(data) + file_figures(ctx.plan))


def model_stages(root: Path, max_frames: int, also: Callable[[], T]) -> Iterator[Any]:
    """The models' process: (figure data, summary), then the 3D view's HTML block, then
    ``also()``."""
    from mmplan.report.context import build_context
    from mmplan.report.figure_data import figure_data
    from mmplan.report.overview import overview

    ctx = build_context(read_plan_dir(root), max_samples=max_frames)
    yield figure_data(ctx), overview(ctx)
    from mmplan.report.html import viewer_block
    from mmplan.report.scene3d import scene_commands  # meshcat: imported here, once

    yield viewer_block(scene_commands(ctx, max_frames))
    yield also()


def write_report(plan_dir: str | Path, max_frames: int = 1000, step: Step | None = None,
                 parallel: bool = True) -> Path:
    """Write ``plan_dir/report.html`` and ``plan_dir/figures/*.png``.

    Args:
        plan_dir: A plan directory (trajectory.csv, summary.json, scenario.yaml; optionally
            history.csv, artifacts.npz), as written by ``mmplan plan``.
        max_frames: Keyframes of the 3D animation (the trajectory is decimated), 2..2000.
        step: Called with the name of each step as it starts (progress display).
        parallel: Draw parts of the report in forked child processes (Linux).

    Returns:
        Path of the written report.html.

    Raises:
        InputError: the directory or one of its files is missing or malformed.
    """
    return write_report_and(plan_dir, _nothing, max_frames, step, parallel)[0]


def write_report_and(plan_dir: str | Path, also: Callable[[], T], max_frames: int = 1000,
                     step: Step | None = None, parallel: bool = True,
                     also_step: str = "") -> tuple[Path, T]:
    """:func:`write_report`, and ``also()`` run in the process that loads the models, after
    the 3D view (``mmplan report``: the plan's check); its result is returned with the
    report's path (``also`` must return something picklable). ``also_step``: the progress
    step shown while waiting for it once the report is written."""
    step = step or _none
    root = check_plan_dir(plan_dir)  # a missing file is named at once, before any import
    step("reading the plan")
    jobs: list[Background[Any] | Staged[Any]] = []
    try:
        models: Staged[Any] = Staged(lambda: model_stages(root, max_frames, also),
                                     enabled=parallel)
        jobs.append(models)
        from mmplan.report.file_figures import start_file_figures  # matplotlib: 0.5 s

        files = start_file_figures(root, enabled=parallel)
        jobs.append(files)
        data, view = models.next()
        step("drawing the figures and the 3D view")
        child = Background(lambda: first_half(data), enabled=parallel)
        jobs.append(child)
        own = second_half(data)
        figures = order(child.result() + own + files.result())
        viewer = models.next()
        step("writing the page")
        out = _write(root, data.plan, view, figures, viewer)
        if also_step:
            step(also_step)
        return out, models.next()
    finally:
        for job in jobs:
            job.cancel()


def _write(root: Path, plan: PlanData, view: Overview, figures: list[RenderedFigure],
           viewer: str) -> Path:
    """Write the page and the figures' files; the page's path."""
    from mmplan.report.html import page

    text = page(plan.summary, plan.scenario, view, figures, viewer)
    folder = root / "figures"
    try:
        folder.mkdir(exist_ok=True)
        current = {f"{fig.name}.png" for fig in figures}
        for stale in folder.glob("*.png"):  # figures of an earlier report of this plan
            if stale.name not in current:
                stale.unlink()
        for fig in figures:
            (folder / f"{fig.name}.png").write_bytes(fig.png)
        out = root / "report.html"
        out.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise InputError(
            str(root), f"cannot write the report here: {exc.strerror}"
        ) from None
    return out
