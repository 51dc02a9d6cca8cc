"""The figures drawn from a plan directory's files alone (no robot, scene or task model).

The method's artifacts (artifacts.npz: the vibration spectrum, the manipulability-area
figures, generic arrays) and the planner's history (history.csv) need only NumPy, matplotlib
and the files, so a report draws them in a child process forked as soon as matplotlib is
loaded (:func:`start_file_figures`, see :mod:`mmplan.report.build`). Importing this module
loads neither matplotlib nor the models.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from mmplan.report.background import Background
from mmplan.report.plan_data import PlanData, read_plan_dir

if TYPE_CHECKING:  # matplotlib: loaded by start_file_figures, not on import
    from mmplan.report.figure_kit import RenderedFigure


def file_figures(plan: PlanData) -> list[RenderedFigure]:
    """The method's figures from artifacts.npz, then the planner's history (when present)."""
    from mmplan.report.figures_method import artifact_figures, history_figure

    history = history_figure(plan.history, plan.t)
    return artifact_figures(plan.artifacts) + ([history] if history is not None else [])


def _read_and_draw(plan_dir: Path) -> list[RenderedFigure]:
    from mmplan.report import quiet_numerics

    with quiet_numerics():
        return file_figures(read_plan_dir(plan_dir))


def start_file_figures(plan_dir: str | Path, enabled: bool = True
                       ) -> Background[list[RenderedFigure]]:
    """:func:`file_figures` of ``plan_dir``, drawn in a child process forked once matplotlib
    is loaded (``enabled=False`` or no fork: drawn when the result is asked for). The caller
    asks for the result (:meth:`Background.result`) or cancels it (:meth:`Background.cancel`).
    """
    import mmplan.report.figures_method  # noqa: F401  (matplotlib: loaded once, before the fork)

    root = Path(plan_dir)
    return Background(lambda: _read_and_draw(root), enabled=enabled)
