"""Error hierarchy of mmplan.

Every error a user can trigger derives from :class:`MmplanError` and carries a one-line,
human-readable message that names the offending field (a key path for scenario files) and
the problem. The CLI maps :class:`InputError` to exit code 2 and :class:`PlanningError` to
exit code 3; nothing else reaches the user as a traceback.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

#: Longest message of an :class:`InputError` (characters); longer ones are cut.
MAX_MESSAGE = 1000


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
        self.field = one_line(str(field), 200)
        self.problem = one_line(str(problem), MAX_MESSAGE)
        text = f"{self.field}: {self.problem}" if self.field else self.problem
        super().__init__(one_line(text, MAX_MESSAGE))


class UnknownNameError(InputError):
    """A robot, scenario, method or shape name that does not exist."""


class PlanningError(MmplanError):
    """Planning ran but could not produce a usable result (exit code 3)."""

    exit_code = 3


class ModelError(MmplanError):
    """A robot or scene model is inconsistent (a programming or description error)."""

    exit_code = 2


def one_line(text: str, limit: int = MAX_MESSAGE) -> str:
    """``text`` on one line (line breaks escaped) and at most ``limit`` characters."""
    text = text[: 4 * limit].replace("\r", "\\r").replace("\n", "\\n").replace("\t", " ")
    return text if len(text) <= limit else text[: limit - 3] + "..."


def type_name(value: object) -> str:
    """The name of ``value``'s type, for "expected X, got Y" messages."""
    return type(value).__name__


def require(value: object, kind: type | tuple[type, ...], field: str, expected: str) -> None:
    """Check an argument of a public function: an :class:`InputError` unless ``value`` is a
    ``kind`` (a bool is never accepted where a number or a path is expected).

    Args:
        value: The argument.
        kind: The accepted type(s).
        field: The argument's name, e.g. ``"problem"``.
        expected: The accepted form in words, e.g. ``"a Problem (Scenario.build())"``.
    """
    if not isinstance(value, kind) or (isinstance(value, bool) and bool not in _types(kind)):
        raise InputError(field, f"expected {expected}, got {type_name(value)}")


def _types(kind: type | tuple[type, ...]) -> tuple[type, ...]:
    return kind if isinstance(kind, tuple) else (kind,)


def path_argument(value: Any, field: str) -> Path:
    """``value`` (a str or os.PathLike naming a file or folder) as a Path; InputError otherwise."""
    if isinstance(value, Path):
        return value
    if isinstance(value, str | os.PathLike):
        try:
            return Path(value)
        except TypeError:  # an os.PathLike whose __fspath__ gives bytes
            pass
    raise InputError(field, f"expected a path (str or os.PathLike), got {type_name(value)}")
