"""Writing a report: read the plan directory, derive, draw, assemble, write.

``write_report(DIR)`` writes ``DIR/report.html`` (one self-contained file) and
``DIR/figures/<name>.png`` (the same figures as files). The work is split in two halves of
about equal time: a forked child process (:mod:`.background`) builds the 3D view (importing
meshcat) and draws the spatial and method figures while this process draws the time series.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from mmplan.errors import InputError
from mmplan.report.background import Background
from mmplan.report.context import ReportContext, build_context
from mmplan.report.figure_kit import RenderedFigure
from mmplan.report.figures import time_figures
from mmplan.report.figures_method import artifact_figures, history_figure
from mmplan.report.figures_space import platform_figure, top_view_figure
from mmplan.report.html import page, viewer_block
from mmplan.report.overview import overview
from mmplan.report.plan_data import read_plan_dir

Step = Callable[[str], None]


def _none(label: str) -> None:
    """No progress display."""


def first_half(ctx: ReportContext) -> list[RenderedFigure]:
    """The spatial figures and the method's artifacts (grids, spectra)."""
    return [top_view_figure(ctx), platform_figure(ctx), *artifact_figures(ctx.plan.artifacts)]


def second_half(ctx: ReportContext) -> list[RenderedFigure]:
    """The time series ([PajakPajak]'s and [Pajak]'s figures) and the planner's history."""
    history = history_figure(ctx.plan.history, ctx.plan.t)
    return time_figures(ctx) + ([history] if history is not None else [])


def view_and_first_half(ctx: ReportContext, max_frames: int) -> tuple[str, list[RenderedFigure]]:
    """The 3D view's HTML block and :func:`first_half`."""
    from mmplan.report.scene3d import scene_commands  # meshcat: imported here, once

    return viewer_block(scene_commands(ctx, max_frames)), first_half(ctx)


def order(figures: list[RenderedFigure]) -> list[RenderedFigure]:
    """Report order: the top view, the time series, the platform, the planner's history, the
    method's figures (stable within each group)."""
    rank = {"top_view": 0.0, "platform": 2.0, "history": 2.5}
    return sorted(figures, key=lambda f: rank.get(f.name, 1.0 if f.name in TIME_SERIES else 3.0))


TIME_SERIES = ("clearance", "joints", "manipulability", "torques_wheels", "torques_arm",
               "virtual_control", "extra_columns", "task_error")


def collect_figures(ctx: ReportContext) -> list[RenderedFigure]:
    """Every figure the plan has data for, in report order (drawn in this process)."""
    return order(first_half(ctx) + second_half(ctx))


def write_report(plan_dir: str | Path, max_frames: int = 1000, step: Step | None = None,
                 parallel: bool = True) -> Path:
    """Write ``plan_dir/report.html`` and ``plan_dir/figures/*.png``.

    Args:
        plan_dir: A plan directory (trajectory.csv, summary.json, scenario.yaml; optionally
            history.csv, artifacts.npz), as written by ``mmplan plan``.
        max_frames: Keyframes of the 3D animation (the trajectory is decimated), 2..2000.
        step: Called with the name of each step as it starts (progress display).
        parallel: Draw half the figures in a forked child process (Linux).

    Returns:
        Path of the written report.html.

    Raises:
        InputError: the directory or one of its files is missing or malformed.
    """
    step = step or _none
    root = Path(plan_dir)
    step("reading the plan")
    plan = read_plan_dir(root)
    ctx = build_context(plan, max_samples=max_frames)
    step("drawing the figures and the 3D view")
    child = Background(lambda: view_and_first_half(ctx, max_frames), enabled=parallel)
    try:
        own = second_half(ctx)
        viewer, theirs = child.result()
    finally:
        child.cancel()
    figures = order(theirs + own)
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
