"""Our value of each published number, read from the written plan files, and its verdict.

Implements the :class:`~mmplan.reproduce.published.Measure` operations and the
:class:`~mmplan.reproduce.published.Check` rules for ``mmplan reproduce``. Values come only from
files a run wrote (summary.json, scenario.yaml, trajectory.csv), never from planner objects.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import yaml

from mmplan.reproduce.published import FLOOR_TWINS, Check, Op, Reference, no_floor

Value = float | tuple[float, float] | str


class RunFiles(Protocol):
    """What evaluation needs of a run (see :class:`mmplan.reproduce.run.RunOutcome`)."""

    @property
    def directory(self) -> Path: ...

    @property
    def status(self) -> str: ...

    @property
    def planned(self) -> bool: ...


@dataclass(frozen=True)
class Evaluated:
    """One table row: the reference, our value and the verdict.

    Attributes:
        ref: The published number.
        run: Run whose report the row links to.
        ours: Our value (None when it could not be obtained, see ``verdict``).
        delta: ours - paper (for points: the distance between them); None for text.
        rel: delta / |paper| (None when paper is 0 or not a number).
        verdict: matches / differs / differs (expected) / holds / within slack / violated /
            no value: <why>; " (plan: <status>)" appended when a run did not reach its task.
        statuses: Plan status of every run the value needs.
        without_floor: The row evaluated on the runs without the floor
            (:data:`~mmplan.reproduce.published.FLOOR_TWINS`), None when the row reads no such
            run (:func:`with_floor_note`).
    """

    ref: Reference
    run: str
    ours: Value | None
    delta: float | None
    rel: float | None
    verdict: str
    statuses: tuple[str, ...]
    without_floor: Evaluated | None = None

    @property
    def floor_changed(self) -> bool | None:
        """Whether the floor changes our value (None: no run without the floor to compare)."""
        if self.without_floor is None:
            return None
        other = self.without_floor.ours
        if self.ours is None or other is None:
            return self.ours is not other
        if isinstance(self.ours, str) or isinstance(other, str):
            return self.ours != other
        a, b = np.ravel(self.ours), np.ravel(other)
        return not bool(np.allclose(a, b, rtol=1e-9, atol=1e-12))


class MissingValueError(Exception):
    """Our value is not available (the message says why)."""


def evaluate(ref: Reference, runs: Mapping[str, RunFiles]) -> Evaluated:
    """Compute our value of ``ref`` from the runs' files and judge it."""
    m = ref.measure
    statuses = tuple(runs[name].status if name in runs else "not run" for name in m.runs)
    try:
        ours = _measure(ref, runs)
    except MissingValueError as exc:
        return Evaluated(ref, m.runs[0], None, None, None, f"no value: {exc}", statuses)
    delta, rel = _difference(ref.paper, ours)
    verdict = _verdict(ref, ours, delta)
    unreached = sorted({s for s in statuses if s != "reached"})
    if unreached:
        verdict += f" (plan: {', '.join(unreached)})"
    return Evaluated(ref, m.runs[0], ours, delta, rel, verdict, statuses)


def with_floor_note(row: Evaluated, runs: Mapping[str, RunFiles]) -> Evaluated:
    """``row`` with :attr:`Evaluated.without_floor` set when a run it reads has a twin without
    the floor among ``runs`` (:data:`~mmplan.reproduce.published.FLOOR_TWINS`)."""
    names = row.ref.measure.runs
    if not any(n in FLOOR_TWINS and no_floor(n) in runs for n in names):
        return row
    twins = tuple(no_floor(n) if n in FLOOR_TWINS else n for n in names)
    twin_ref = replace(row.ref, measure=replace(row.ref.measure, runs=twins))
    return replace(row, without_floor=evaluate(twin_ref, runs))


def _measure(ref: Reference, runs: Mapping[str, RunFiles]) -> Value:
    m = ref.measure
    for name in m.runs:
        if name not in runs:
            raise MissingValueError(f"{name} not run")
        if not runs[name].planned:
            raise MissingValueError(f"{name} failed to plan")
    first = runs[m.runs[0]].directory
    if m.op is Op.VALUE:
        return _typed(_lookup(first, m.key), ref.paper, m.runs[0], m.key)
    if m.op is Op.INCREASE:
        a, b = (_number(_lookup(runs[n].directory, m.key), n, m.key) for n in m.runs[:2])
        if a == 0:
            raise MissingValueError(f"{m.runs[0]}: {'.'.join(m.key)} is 0")
        return b / a - 1.0
    if m.op is Op.MINUS:
        return (_number(_lookup(first, m.key), m.runs[0], m.key)
                - _number(_lookup(first, m.other), m.runs[0], m.other))
    columns = _columns(first, m.key)  # (N, k)
    if m.op is Op.COLUMN_MAX_ABS:
        return float(np.max(np.abs(columns)))
    if m.op is Op.COLUMN_FIRST_ABS:
        return float(np.max(np.abs(columns[0])))
    return float(np.max(np.hypot(columns[:, 0], columns[:, 1])))  # Op.PLANAR_NORM_MAX


def _lookup(directory: Path, key: Sequence[str]) -> Any:
    """Value at a key path of summary.json (or of scenario.yaml for ``"@scenario", ...``)."""
    if key and key[0] == "@scenario":
        node: Any = _read(directory / "scenario.yaml")
        path = list(key[1:])
    else:
        node, path = _read(directory / "summary.json"), list(key)
    for part in path:
        if not isinstance(node, Mapping) or part not in node:
            raise MissingValueError(f"{directory.name}: no {'.'.join(key)}")
        node = node[part]
    if node is None:
        raise MissingValueError(f"{directory.name}: {'.'.join(key)} is null")
    return node


def _read(path: Path) -> Any:
    try:
        text = path.read_text(encoding="utf-8")
        return json.loads(text) if path.suffix == ".json" else yaml.safe_load(text)
    except (OSError, ValueError, yaml.YAMLError) as exc:
        raise MissingValueError(f"cannot read {path.parent.name}/{path.name}: {exc}") from None


def _number(value: Any, run: str, key: Sequence[str]) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise MissingValueError(f"{run}: {'.'.join(key)} = {value!r} is not a number") from None
    if not math.isfinite(number):
        raise MissingValueError(f"{run}: {'.'.join(key)} = {value!r}")
    return number


def _typed(value: Any, paper: Value, run: str, key: Sequence[str]) -> Value:
    """Our value in the paper value's form (number, point or text)."""
    if isinstance(paper, str):
        return str(value)
    if isinstance(paper, tuple):
        if not isinstance(value, list | tuple) or len(value) != 2:
            raise MissingValueError(f"{run}: {'.'.join(key)} = {value!r} is not a point (x, y)")
        return (_number(value[0], run, (*key, "x")), _number(value[1], run, (*key, "y")))
    return _number(value, run, key)


def _columns(directory: Path, names: Sequence[str]) -> np.ndarray:
    path = directory / "trajectory.csv"
    try:
        with path.open(encoding="utf-8") as handle:
            header = handle.readline().strip().split(",")
    except OSError as exc:
        raise MissingValueError(f"cannot read {directory.name}/trajectory.csv: {exc}") from None
    missing = [n for n in names if n not in header]
    if missing:
        raise MissingValueError(f"{directory.name}/trajectory.csv has no column {missing[0]}")
    cols = [header.index(n) for n in names]
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=cols, ndmin=2, dtype=float)
    if data.size == 0 or not np.isfinite(data).all():
        raise MissingValueError(f"{directory.name}/trajectory.csv: empty or non-finite {names}")
    return data


def _difference(paper: Value, ours: Value) -> tuple[float | None, float | None]:
    if isinstance(paper, str) or isinstance(ours, str):
        return None, None
    if isinstance(paper, tuple) and isinstance(ours, tuple):
        delta = math.dist(paper, ours)
        return delta, delta / math.hypot(*paper) if any(paper) else None
    assert isinstance(paper, float) and isinstance(ours, float)  # forms match by _typed
    delta = ours - paper
    return delta, (delta / abs(paper) if paper != 0 else None)


def _verdict(ref: Reference, ours: Value, delta: float | None) -> str:
    if ref.check is Check.EQUALS:
        same = ours == ref.paper if delta is None else abs(delta) <= 1e-9 * max(
            1.0, abs(float(ref.paper) if isinstance(ref.paper, float) else 1.0))
        return "matches" if same else "differs"
    assert delta is not None
    paper = ref.paper
    scale = math.hypot(*paper) if isinstance(paper, tuple) else abs(float(paper))
    allowed = ref.tol * scale if ref.relative else ref.tol
    if ref.check is Check.CLOSE:
        if abs(delta) <= allowed:
            return "matches"
        return "differs (expected)" if ref.known_gap else "differs"
    signed = delta if ref.check is Check.AT_MOST else -delta  # > 0: on the wrong side
    if signed <= 1e-9 * max(scale, 1.0):  # float rounding (a value computed as the bound)
        return "holds"
    return "within slack" if signed <= allowed else "violated"
