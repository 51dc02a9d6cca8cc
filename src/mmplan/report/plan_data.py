"""Reading a plan directory (docs/conventions.md) for the report: plain files, no planner code.

A plan directory holds ``trajectory.csv``, ``summary.json``, ``scenario.yaml`` and optionally
``history.csv`` (per-iteration series) and ``artifacts.npz`` (method data, e.g. grids).
"""

from __future__ import annotations

import csv
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mmplan.arrays import Array
from mmplan.errors import InputError

REQUIRED_FILES = ("trajectory.csv", "summary.json", "scenario.yaml")


@dataclass(frozen=True)
class PlanData:
    """Everything a plan directory holds, as arrays and plain mappings.

    Attributes:
        directory: The plan directory.
        t: Sample times [s] (N,).
        coordinates: Generalized coordinate names (``q.<name>`` columns, file order).
        q, dq, ddq: (N, n).
        ee: End-effector position [m] (N, 3).
        actuators: Actuator names (``tau.<name>`` columns); empty without efforts.
        tau: (N, n_act) or None.
        u: Virtual control (N,) or None.
        extra: Further columns between ``u`` and ``ee.x`` (e.g. platform controls ``u1``).
        summary: Parsed summary.json.
        scenario: Parsed (resolved) scenario.yaml.
        history: Columns of history.csv (each (K,)); empty when absent.
        artifacts: Arrays of artifacts.npz; empty when absent.
    """

    directory: Path
    t: Array
    coordinates: tuple[str, ...]
    q: Array
    dq: Array
    ddq: Array
    ee: Array
    actuators: tuple[str, ...] = ()
    tau: Array | None = None
    u: Array | None = None
    extra: Mapping[str, Array] = field(default_factory=dict)
    summary: Mapping[str, Any] = field(default_factory=dict)
    scenario: Mapping[str, Any] = field(default_factory=dict)
    history: Mapping[str, Array] = field(default_factory=dict)
    artifacts: Mapping[str, Array] = field(default_factory=dict)

    @property
    def samples(self) -> int:
        """Number of trajectory samples N."""
        return len(self.t)


def read_csv_columns(path: Path) -> dict[str, Array]:
    """Columns of a CSV file with a header row, as float arrays (empty cells -> NaN).

    Raises:
        InputError: unreadable file, ragged rows or non-numeric values; the field names the
            file, line and column.
    """
    try:
        with path.open(newline="") as handle:
            header = [h.strip() for h in handle.readline().strip().split(",")]
            try:
                data = np.loadtxt(handle, delimiter=",", ndmin=2, dtype=float)
            except ValueError:
                handle.seek(0)
                _locate_bad_cell(path, list(csv.reader(handle)))
                raise
    except OSError as exc:
        raise InputError(path.name, f"cannot read: {exc.strerror}") from None
    if header == [""]:
        raise InputError(path.name, "empty file; expected a header row")
    if data.size == 0:
        data = np.empty((0, len(header)))
    if data.shape[1] != len(header):
        raise InputError(path.name, f"{len(header)} header names but {data.shape[1]} columns")
    return {name: data[:, j] for j, name in enumerate(header)}


def _locate_bad_cell(path: Path, rows: list[list[str]]) -> None:
    """Raise an InputError naming the first ragged row or non-numeric cell."""
    header = [h.strip() for h in rows[0]]
    for i, row in enumerate(rows[1:]):
        if not row:
            continue
        if len(row) != len(header):
            raise InputError(
                f"{path.name}:{i + 2}", f"expected {len(header)} values, got {len(row)}"
            )
        for j, cell in enumerate(row):
            try:
                float(cell)
            except ValueError:
                raise InputError(
                    f"{path.name}:{i + 2}:{header[j]}", f"not a number: {cell.strip()!r}"
                ) from None


def _prefixed(columns: Mapping[str, Array], prefix: str) -> tuple[tuple[str, ...], Array | None]:
    names = tuple(k[len(prefix) :] for k in columns if k.startswith(prefix))
    if not names:
        return (), None
    return names, np.column_stack([columns[prefix + n] for n in names])


def parse_trajectory(
    columns: Mapping[str, Array], source: str = "trajectory.csv"
) -> dict[str, Any]:
    """Split trajectory.csv columns into t, q, dq, ddq, tau, u, extra, ee (docs/conventions.md)."""
    for key in ("t", "ee.x", "ee.y", "ee.z"):
        if key not in columns:
            raise InputError(f"{source}:{key}", "missing column")
    coordinates, q = _prefixed(columns, "q.")
    if q is None:
        raise InputError(f"{source}:q.*", "no q.<coordinate> columns")
    out: dict[str, Any] = {"t": np.asarray(columns["t"]), "coordinates": coordinates, "q": q}
    for name in ("dq", "ddq"):
        names, values = _prefixed(columns, name + ".")
        if values is None or names != coordinates:
            raise InputError(f"{source}:{name}.*", f"expected columns for {coordinates}")
        out[name] = values
    out["actuators"], out["tau"] = _prefixed(columns, "tau.")
    out["u"] = np.asarray(columns["u"]) if "u" in columns else None
    known = {"t", "u", "ee.x", "ee.y", "ee.z"}
    out["extra"] = {
        k: np.asarray(v)
        for k, v in columns.items()
        if k not in known and not k.startswith(("q.", "dq.", "ddq.", "tau."))
    }
    out["ee"] = np.column_stack([columns["ee.x"], columns["ee.y"], columns["ee.z"]])
    if len(out["t"]) == 0:
        raise InputError(source, "no samples")
    return out


def check_plan_dir(directory: str | Path) -> Path:
    """``directory`` as a path, once it is seen to be a directory with the required files.

    Raises:
        InputError: it is not, naming the first file missing.
    """
    root = Path(directory)
    if not root.is_dir():
        raise InputError(str(root), "not a plan directory")
    for name in REQUIRED_FILES:
        if not (root / name).is_file():
            raise InputError(
                str(root), f"not a plan directory: {name} missing (written by `mmplan plan`)"
            )
    return root


def read_plan_dir(directory: str | Path) -> PlanData:
    """Read a plan directory written by ``mmplan plan``.

    Raises:
        InputError: the directory or a required file is missing or malformed.
    """
    root = check_plan_dir(directory)
    traj = parse_trajectory(read_csv_columns(root / "trajectory.csv"))
    try:
        summary = json.loads((root / "summary.json").read_text())
    except json.JSONDecodeError as exc:
        raise InputError("summary.json", f"invalid JSON: {exc.msg} (line {exc.lineno})") from None
    try:
        scenario = yaml.safe_load((root / "scenario.yaml").read_text())
    except yaml.YAMLError as exc:
        raise InputError("scenario.yaml", f"invalid YAML: {exc}") from None
    if not isinstance(scenario, dict) or "robot" not in scenario:
        raise InputError("scenario.yaml", "expected a mapping with a 'robot' key")
    history: dict[str, Array] = {}
    if (root / "history.csv").is_file():
        history = read_csv_columns(root / "history.csv")
    artifacts: dict[str, Array] = {}
    if (root / "artifacts.npz").is_file():
        with np.load(root / "artifacts.npz", allow_pickle=False) as npz:
            artifacts = {k: np.asarray(npz[k]) for k in npz.files}
    return PlanData(
        directory=root,
        summary=summary if isinstance(summary, dict) else {},
        scenario=scenario,
        history=history,
        artifacts=artifacts,
        **traj,
    )
