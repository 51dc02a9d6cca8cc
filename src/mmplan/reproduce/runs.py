"""One reproduction run: what to plan (:class:`RunSpec`) and what it produced (:class:`RunOutcome`).

Shared by :mod:`mmplan.reproduce.run` (which plans) and :mod:`mmplan.reproduce.table` (which
writes the tables); it imports neither.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class RunSpec:
    """One run: a built-in scenario, or a variant of one (``base`` set)."""

    name: str
    paper: str
    base: str | None = None
    planner: dict[str, Any] | None = None
    note: str = ""
    scenario: dict[str, Any] | None = None  # top-level keys replaced (a variant's ``ground``)


@dataclass(frozen=True)
class RunOutcome:
    """What one run produced.

    Attributes:
        spec: The run.
        directory: Its plan directory (may not exist when planning raised).
        status: Planner status (reached, stalled, ...) or ``"error"`` when planning raised.
        message: Planner message or the error.
        wall_time_s: Load + plan + write (without the report).
        report: report.html when written.
        report_error: Why the report is missing (None when written or not asked for).
    """

    spec: RunSpec
    directory: Path
    status: str
    message: str
    wall_time_s: float
    report: Path | None = None
    report_error: str | None = None

    @property
    def planned(self) -> bool:
        """A plan directory was written (whatever its status)."""
        return self.status != "error"
