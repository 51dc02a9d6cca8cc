"""Error hierarchy of mmplan.

Every error a user can trigger derives from :class:`MmplanError` and carries a one-line,
human-readable message that names the offending field (a key path for scenario files) and
the problem. The CLI maps :class:`InputError` to exit code 2 and :class:`PlanningError` to
exit code 3; nothing else reaches the user as a traceback.
"""

from __future__ import annotations


class MmplanError(Exception):
    """Root of all mmplan errors."""

    exit_code: int = 1


class InputError(MmplanError):
    """Bad input detectable before planning (exit code 2).

    Args:
        field: Key path of the offending value, e.g. ``"limits.torque.min[2]"``.
        problem: What is wrong, with the value and the expected form.
    """

    exit_code = 2

    def __init__(self, field: str, problem: str) -> None:
        self.field = field
        self.problem = problem
        super().__init__(f"{field}: {problem}" if field else problem)


class UnknownNameError(InputError):
    """A robot, scenario, method or shape name that does not exist."""


class PlanningError(MmplanError):
    """Planning ran but could not produce a usable result (exit code 3)."""

    exit_code = 3


class ModelError(MmplanError):
    """A robot or scene model is inconsistent (a programming or description error)."""

    exit_code = 2
