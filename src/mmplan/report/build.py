"""Writing a report: read the plan directory, derive, draw, assemble, write.

``write_report(DIR)`` writes ``DIR/report.html`` (one self-contained file) and
``DIR/figures/<name>.png`` (the same figures as files). The work is split three ways, each
part in its own process (:mod:`.background`, forked): the figures of the plan's files alone
(:mod:`.file_figures`: the method's artifacts and the planner's history; ``mmplan report``
starts these once matplotlib is loaded, before it loads the robot models), the 3D view
(importing meshcat) with the spatial figures and the clearance, and the other time series,
drawn by this process.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from mmplan.errors import InputError
from mmplan.report.background import Background
from mmplan.report.context import ReportContext, build_context
from mmplan.report.figure_kit import RenderedFigure
from mmplan.report.figures import TIME_FIGURES, TimeFigure, clearance_figure
from mmplan.report.figures_space import platform_figure, top_view_figure
from mmplan.report.file_figures import file_figures
from mmplan.report.html import page, viewer_block
from mmplan.report.overview import overview
from mmplan.report.plan_data import read_plan_dir

Step = Callable[[str], None]


def _none(label: str) -> None:
    """No progress display."""


def first_half(ctx: ReportContext) -> list[RenderedFigure]:
    """The spatial figures and the clearance over time (drawn with the 3D view)."""
    return [top_view_figure(ctx), platform_figure(ctx), *_drawn(ctx, CHILD_SERIES)]


def second_half(ctx: ReportContext) -> list[RenderedFigure]:
    """The other time series ([PajakPajak]'s and [Pajak]'s figures)."""
    return _drawn(ctx, tuple(f for f in TIME_FIGURES if f not in CHILD_SERIES))


def _drawn(ctx: ReportContext, makers: tuple[TimeFigure, ...]) -> list[RenderedFigure]:
    return [f for f in (make(ctx) for make in makers) if f is not None]


def view_and_first_half(ctx: ReportContext, max_frames: int) -> tuple[str, list[RenderedFigure]]:
    """The 3D view's HTML block and :func:`first_half`."""
    from mmplan.report.scene3d import scene_commands  # meshcat: imported here, once

    return viewer_block(scene_commands(ctx, max_frames)), first_half(ctx)


#: Time series drawn with the 3D view and the spatial figures (about half the drawing time
#: with them; the file figures are drawn apart).
CHILD_SERIES: tuple[TimeFigure, ...] = (clearance_figure,)
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
    return order(first_half(ctx) + second_half(ctx) + file_figures(ctx.plan))


def write_report(plan_dir: str | Path, max_frames: int = 1000, step: Step | None = None,
                 parallel: bool = True,
                 files_job: Background[list[RenderedFigure]] | None = None) -> Path:
    """Write ``plan_dir/report.html`` and ``plan_dir/figures/*.png``.

    Args:
        plan_dir: A plan directory (trajectory.csv, summary.json, scenario.yaml; optionally
            history.csv, artifacts.npz), as written by ``mmplan plan``.
        max_frames: Keyframes of the 3D animation (the trajectory is decimated), 2..2000.
        step: Called with the name of each step as it starts (progress display).
        parallel: Draw parts of the report in forked child processes (Linux).
        files_job: :func:`~mmplan.report.file_figures.start_file_figures` of ``plan_dir``,
            started earlier by the caller (its result is used, or it is cancelled); None:
            started here.

    Returns:
        Path of the written report.html.

    Raises:
        InputError: the directory or one of its files is missing or malformed.
    """
    step = step or _none
    root = Path(plan_dir)
    jobs: list[Background[Any]] = [] if files_job is None else [files_job]
    try:
        step("reading the plan")
        plan = read_plan_dir(root)
        if files_job is None:
            jobs.append(Background(lambda: file_figures(plan), enabled=parallel))
        files = jobs[0]
        ctx = build_context(plan, max_samples=max_frames)
        step("drawing the figures and the 3D view")
        child = Background(lambda: view_and_first_half(ctx, max_frames), enabled=parallel)
        jobs.append(child)
        own = second_half(ctx)
        viewer, theirs = child.result()
        figures = order(theirs + own + files.result())
    finally:
        for job in jobs:
            job.cancel()
    step("writing the page")
    text = page(plan.summary, plan.scenario, overview(ctx), figures, viewer)
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
            "plan_dir", f"cannot write the report into {root}: {exc.strerror}"
        ) from None
    return out
