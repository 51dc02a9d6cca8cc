"""Writing a report: read the plan directory, derive, draw, assemble, write.

``write_report(DIR)`` writes ``DIR/report.html`` (one self-contained file) and
``DIR/figures/<name>.png`` (the same figures as files).
"""

from __future__ import annotations

from pathlib import Path

from mmplan.errors import InputError
from mmplan.report.animation import scene_data, scene_json, viewer_script
from mmplan.report.context import ReportContext, build_context
from mmplan.report.figure_kit import RenderedFigure
from mmplan.report.figures import time_figures
from mmplan.report.figures_method import artifact_figures, history_figure
from mmplan.report.figures_space import platform_figure, top_view_figure
from mmplan.report.html import page, viewer_block
from mmplan.report.plan_data import read_plan_dir


def collect_figures(ctx: ReportContext) -> list[RenderedFigure]:
    """Every figure the plan has data for, in report order."""
    figures = [top_view_figure(ctx), *time_figures(ctx), platform_figure(ctx)]
    history = history_figure(ctx.plan.history)
    if history is not None:
        figures.append(history)
    figures += artifact_figures(ctx.plan.artifacts)
    return figures


def write_report(plan_dir: str | Path, max_frames: int = 1000) -> Path:
    """Write ``plan_dir/report.html`` and ``plan_dir/figures/*.png``.

    Args:
        plan_dir: A plan directory (trajectory.csv, summary.json, scenario.yaml; optionally
            history.csv, artifacts.npz), as written by ``mmplan plan``.
        max_frames: Frames of the 3D animation (the trajectory is decimated), 2..2000.

    Returns:
        Path of the written report.html.

    Raises:
        InputError: the directory or one of its files is missing or malformed.
    """
    root = Path(plan_dir)
    plan = read_plan_dir(root)
    ctx = build_context(plan, max_samples=max_frames)
    figures = collect_figures(ctx)
    viewer = viewer_block(scene_json(scene_data(ctx, max_frames)), viewer_script())
    text = page(plan.summary, plan.scenario, figures, viewer)
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


def render_report_cli(plan_dir: str | Path) -> Path:
    """``mmplan report DIR``: write the report and print where it is (one line)."""
    import click

    out = write_report(plan_dir)
    figures = len(list((Path(plan_dir) / "figures").glob("*.png")))
    click.echo(
        f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB, {figures} figures in "
        f"{out.parent / 'figures'})"
    )
    return out
