"""The records of the report's opening (:mod:`.overview` fills them, :mod:`.html` prints them).

Apart from :mod:`.overview` because the process drawing the figures receives them ready-made
and loads none of the robot and scene models that :mod:`.overview` needs.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class LimitRow:
    """One limit of the plan: what, the worst value along the plan, the limit, the margin.

    ``ok`` is None where the row is information only (no limit set).
    """

    key: str
    what: str
    worst: str
    limit: str
    margin: str
    ok: bool | None


@dataclass(frozen=True)
class Overview:
    """The opening of the report.

    Attributes:
        reached: The task was completed (status ``reached``).
        headline: One or two sentences: reached or not, and why.
        facts: (label, value, key) lines: times, clearance, compute time.
        limits: Rows of the limits table.
    """

    reached: bool
    headline: str
    facts: list[tuple[str, str, str]] = field(default_factory=list)
    limits: list[LimitRow] = field(default_factory=list)
