"""Console output of the ``mmplan`` command: the progress bar and the metric listings."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn

import mmplan

PROGRESS_DELAY_S = 1.0

out = Console(highlight=False, soft_wrap=True)
err = Console(stderr=True, highlight=False, soft_wrap=True)


def _fmt(value: Any, unit: str = "", digits: int = 4) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}g}{unit}"
    return f"{value}{unit}"


class ProgressBar:
    """Progress callback that shows a rich bar once planning has run for a second."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.start = time.perf_counter()
        self.progress: Progress | None = None
        self.task: Any = None

    def __call__(self, fraction: float) -> None:
        if not self.enabled:
            return
        if self.progress is None:
            if time.perf_counter() - self.start < PROGRESS_DELAY_S:
                return
            self.progress = Progress(TextColumn("planning"), BarColumn(), TaskProgressColumn(),
                                     TimeElapsedColumn(), console=err, transient=True)
            self.progress.start()
            self.task = self.progress.add_task("plan", total=1.0)
        self.progress.update(self.task, completed=min(max(float(fraction), 0.0), 1.0))

    def close(self) -> None:
        if self.progress is not None:
            self.progress.stop()


def print_plan(result: mmplan.PlanResult, summary: dict[str, Any], written: Path) -> None:
    """Status line and the checker's key metrics (as written to summary.json)."""
    out.print(f"status: {result.status.value}" + (f" ({result.message})" if result.message else ""),
              markup=False)
    rows = [("T(1 cm)", _fmt(summary.get("duration_1cm_s"), " s")),
            ("T(1 mm)", _fmt(summary.get("duration_1mm_s"), " s")),
            ("final error", _fmt(summary.get("final_error_m"), " m")),
            ("min clearance", _fmt(summary.get("min_clearance_m"), " m")),
            ("compute time", _fmt(summary.get("compute_time_s"), " s", 3))]
    for label, value in rows:
        out.print(f"{label + ':':15s}{value}", markup=False)
    out.print(f"written to {written}", markup=False)


def print_check(report: mmplan.CheckReport) -> None:
    """The checker's metrics, one per line."""
    rows: list[tuple[str, Callable[[], str]]] = [
        ("status (claimed)", lambda: _fmt(report.status)),
        ("samples", lambda: str(report.samples)),
        ("T(tolerance)", lambda: _fmt(report.duration_s, " s")),
        ("T(1 cm)", lambda: _fmt(report.duration_1cm_s, " s")),
        ("T(1 mm)", lambda: _fmt(report.duration_1mm_s, " s")),
        ("final error", lambda: _fmt(report.final_error_m, " m")),
        ("min clearance", lambda: _fmt(report.min_clearance_m, " m")),
        ("joint limit violation", lambda: _fmt(report.max_joint_limit_violation)),
        ("torque violation", lambda: _fmt(report.max_torque_violation)
         + (f" ({report.torque_source} efforts)" if report.torque_source else "")),
        ("tau vs model", lambda: _fmt(report.tau_model_deviation)),
        ("pfaffian residual", lambda: _fmt(report.max_pfaffian_residual)),
        ("dq residual", lambda: _fmt(report.dq_residual, " /s")),
        ("ddq residual", lambda: _fmt(report.ddq_residual, " /s")),
        ("ee vs FK", lambda: _fmt(report.ee_deviation_m, " m")),
        ("manipulability", lambda: f"start {_fmt(report.manipulability_start)}, end "
                                   f"{_fmt(report.manipulability_end)}, min "
                                   f"{_fmt(report.manipulability_min)}"),
    ]
    for label, value in rows:
        out.print(f"{label + ':':23s}{value()}", markup=False)
