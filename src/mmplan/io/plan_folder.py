"""Writing and reading plan directories (the contract of docs/conventions.md).

A plan directory holds

* ``trajectory.csv``: header + one row per sample, columns :meth:`Trajectory.columns`
  (``t, q.*, dq.*, ddq.*, [tau.*, u, extra], ee.x, ee.y, ee.z``), every value with 17
  significant digits (round-trips float64 exactly);
* ``summary.json``: the contract keys with values from the independent checker
  (:func:`mmplan.verify.check.check`), plus ``check_passed`` and ``check_failures`` (the checker's
  verdict, one line per failed check), ``message``, ``scenario`` and ``planner_info``;
  non-finite numbers are written as null;
* ``scenario.yaml``: the resolved scenario (every default filled in, the floor height
  ``ground`` included, so that ``mmplan check`` rebuilds the same scene; for a problem built in
  Python, the problem itself: :func:`~mmplan.scenario.from_problem.scenario_from_problem`);
* ``history.csv`` (when the planner recorded per-iteration series), ``artifacts.npz`` (when it
  produced arrays for reports), ``trajectory.npz`` (with ``fmt="npz"``, besides the CSV).

Writing is atomic: everything goes to a temporary directory next to ``out_dir`` that is
renamed into place only when complete, so an error or interrupt leaves no partial output
(and an existing ``out_dir`` is replaced only after success). The temporary directories
(``.<name>.tmp-<pid>-<start>-*`` and, while a plan is replaced, ``.<name>.old-...``) name their
owner process and its start time, and the owner holds an ``flock`` on them while it writes; a
process killed mid-write (``kill -9``) leaves them behind, and the next :func:`write_plan` into
the same parent removes those whose owner is gone (:mod:`mmplan.io.stale`).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError, ModelError, path_argument, require
from mmplan.io.stale import owned_temp_dir, release, remove_stale
from mmplan.problem import Problem
from mmplan.scenario.loader import Scenario, load_scenario
from mmplan.trajectory import PlanResult, Trajectory
from mmplan.verify.check import check

FORMATS = ("csv", "npz")
#: Largest summary.json read (bytes).
MAX_SUMMARY_BYTES = 10_000_000


def write_plan(out_dir: str | Path, result: PlanResult, problem: Problem,
               scenario: Scenario | None = None, fmt: str = "csv") -> Path:
    """Write a plan directory atomically; returns its path.

    Args:
        out_dir: Directory to create; an existing empty or plan directory is replaced once
            the new one is complete (permissions 0777 & ~umask, like ``mkdir``).
        result: The planner's result.
        problem: The problem it solved (for the checker).
        scenario: The scenario (written resolved as scenario.yaml). None for a problem built
            in Python: scenario.yaml then records the problem itself (robot by its built-in
            name or its URDF load arguments, limits, start, goal, obstacles, settings;
            :func:`~mmplan.scenario.from_problem.scenario_from_problem`), named after
            ``out_dir``, so that ``mmplan check`` and ``mmplan report`` can rebuild it.
        fmt: ``"csv"`` (trajectory.csv only) or ``"npz"`` (trajectory.npz too).

    Raises:
        InputError: bad ``fmt``; ``out_dir`` is an existing file, a non-empty directory that
            is not a plan directory (:func:`is_plan_dir`), the root or the working
            directory; or it cannot be created or written; without ``scenario``, a robot or
            task that a scenario cannot record.
    """
    if fmt not in FORMATS:
        raise InputError("--format", f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    require(result, PlanResult, "result", "a PlanResult (Planner.plan(problem))")
    require(problem, Problem, "problem", "a Problem (Scenario.build())")
    if scenario is not None:
        require(scenario, Scenario, "scenario", "a Scenario (mmplan.load_scenario) or None")
    out = check_out_dir(out_dir)
    if scenario is None:
        from mmplan.scenario.from_problem import scenario_from_problem

        scenario = scenario_from_problem(problem, name=out.name)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        remove_stale(out.parent)  # left by runs killed mid-write
        tmp, lock = owned_temp_dir(out, "tmp")
    except OSError as exc:
        raise InputError("--out", f"cannot create {_short(out)}: {exc.strerror or exc}") from None
    try:
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes 0700; a plan folder is a normal one
        _write_all(tmp, result, problem, scenario, fmt)
        _replace(tmp, out)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise InputError("--out", f"cannot write {_short(out)}: {exc.strerror or exc}") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    finally:
        release(lock)
    return out


#: Entries a plan directory may hold (everything mmplan writes into one); a folder holding
#: anything else is never replaced by :func:`write_plan`.
PLAN_REQUIRED = ("summary.json", "trajectory.csv", "scenario.yaml")
PLAN_FILES = frozenset((*PLAN_REQUIRED, "history.csv", "artifacts.npz", "trajectory.npz",
                        "report.html", "figures"))


def is_plan_dir(folder: Path) -> bool:
    """True when ``folder`` holds the three plan files and nothing mmplan does not write."""
    try:
        names = {p.name for p in folder.iterdir()}
    except OSError:
        return False
    if not set(PLAN_REQUIRED) <= names or not names <= PLAN_FILES:
        return False
    figures = folder / "figures"
    if figures.exists():
        if figures.is_symlink() or not figures.is_dir():
            return False
        return all(f.suffix == ".png" and f.is_file() for f in figures.iterdir())
    return True


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def check_out_dir(out_dir: str | Path) -> Path:
    """``out_dir`` (absolute) when write_plan may create or replace it, else InputError.

    Accepted: a path that does not exist yet, an empty directory, or a plan directory
    (:func:`is_plan_dir`). Rejected: the file-system root, the working directory or one of
    its ancestors, an existing file, any other existing directory.
    """
    out = path_argument(out_dir, "--out")
    if not str(out_dir).strip():
        raise InputError("--out", "empty path")
    try:
        full = out.resolve()
        cwd = Path.cwd().resolve()
        if full == cwd or full in cwd.parents or full.parent == full:
            raise InputError("--out", f"{_short(out)} is the working directory, one of its "
                             "parents or the root; name a new folder")
        if out.is_symlink() or (out.exists() and not out.is_dir()):
            raise InputError("--out", f"{_short(out)} exists and is not a directory")
        if out.is_dir() and any(out.iterdir()) and not is_plan_dir(out):
            raise InputError("--out", f"{_short(out)} exists and is not a plan directory")
        _check_writable(full)
    except (OSError, RuntimeError, ValueError) as exc:  # too long, a loop, a NUL byte, ...
        problem = getattr(exc, "strerror", None) or str(exc)
        raise InputError("--out", f"{_short(out)}: {problem}") from None
    return Path(full)


def _check_writable(full: Path) -> None:
    """InputError unless ``full`` (or its nearest existing ancestor) is a writable directory."""
    target = full if full.exists() else full.parent
    while not target.exists() and target.parent != target:
        target = target.parent
    if not target.is_dir():
        raise InputError("--out", f"cannot create {_short(full)}: {_short(target)} is not a "
                         "directory")
    if not os.access(target, os.W_OK | os.X_OK):
        raise InputError("--out", f"cannot create {_short(full)}: {_short(target)} is not "
                         "writable")


def _short(path: Path | str) -> str:
    """A path for a one-line message: long ones keep their start and end."""
    text = str(path)
    return text if len(text) <= 120 else f"{text[:60]}...{text[-40:]} ({len(text)} characters)"


def _replace(tmp: Path, out: Path) -> None:
    """Rename ``tmp`` to ``out``; an existing ``out`` is moved aside first and removed after."""
    if not out.exists():
        os.replace(tmp, out)
        return
    old, lock = owned_temp_dir(out, "old")
    try:
        aside = old / out.name  # a stale .old- dir is put back under this name (stale.py)
        try:
            os.replace(out, aside)
        except BaseException:
            old.rmdir()
            raise
        try:
            os.replace(tmp, out)
        except BaseException:
            os.replace(aside, out)  # put the previous plan back
            old.rmdir()
            raise
        shutil.rmtree(old, ignore_errors=True)
    finally:
        release(lock)


#: Planner ``info`` keys copied to the top level of summary.json (issue 5: the
#: manipulability-area planner reports its threshold next to ``manipulability_min``).
SURFACED_INFO = ("manipulability_threshold",)


def _write_all(folder: Path, result: PlanResult, problem: Problem, scenario: Scenario,
               fmt: str) -> None:
    tr = result.trajectory
    write_csv(folder / "trajectory.csv", *tr.columns())
    status = str(result.status.value)
    report = check(tr, problem, status=status)
    summary = report.summary(status=status, planner=result.planner,
                             compute_time_s=float(result.compute_time_s))
    summary.update(check_passed=report.ok, check_failures=report.failures())
    for key in SURFACED_INFO:  # planner numbers the issues ask for at the top level
        if key in result.info:
            summary[key] = result.info[key]
    summary.update(message=result.message, scenario=scenario.name,
                   planner_info=dict(result.info))
    (folder / "summary.json").write_text(json.dumps(_jsonable(summary), indent=2) + "\n",
                                         encoding="utf-8")
    (folder / "scenario.yaml").write_text(scenario.to_yaml(), encoding="utf-8")
    if result.history:
        names = list(result.history)
        cols = [np.asarray(result.history[k], dtype=float).reshape(-1) for k in names]
        if len({len(c) for c in cols}) != 1:
            raise ModelError(f"PlanResult.history: series of unequal lengths "
                             f"{ {k: len(c) for k, c in zip(names, cols, strict=True)} }")
        write_csv(folder / "history.csv", names, np.column_stack(cols))
    if result.artifacts:
        art: dict[str, Any] = {k: np.asarray(v) for k, v in result.artifacts.items()}
        np.savez(folder / "artifacts.npz", **art)
    if fmt == "npz":
        arrays: dict[str, Any] = {"t": tr.t, "q": tr.q, "dq": tr.dq, "ddq": tr.ddq, "ee": tr.ee,
                                  "coordinates": np.array(tr.coordinates),
                                  "actuators": np.array(tr.actuators, dtype=str)}
        if tr.tau is not None:
            arrays["tau"] = tr.tau
        if tr.u is not None:
            arrays["u"] = tr.u
        arrays.update({f"extra.{k}": np.asarray(v) for k, v in tr.extra.items()})
        np.savez(folder / "trajectory.npz", **arrays)


def write_csv(path: Path, names: list[str], data: Array) -> None:
    """CSV with a header line and 17 significant digits per value."""
    np.savetxt(path, np.atleast_2d(data), fmt="%.17g", delimiter=",", header=",".join(names),
               comments="")


def _jsonable(value: Any) -> Any:
    """JSON-safe copy: numpy scalars/arrays to Python, non-finite floats to null.

    JSON has no NaN or inf; a number that does not exist (a manipulability of an infeasible
    run, an unbounded limit) is written as null, never as a string.
    """
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return _jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if value is None or isinstance(value, bool | int | float | str):
        return value
    return str(value)


def read_trajectory_csv(path: str | Path) -> Trajectory:
    """Read trajectory.csv back into a :class:`Trajectory`.

    Raises:
        InputError: missing file, bad header or malformed numbers.
    """
    path = path_argument(path, "path")
    try:
        with path.open(encoding="utf-8") as fh:
            header = fh.readline().strip().split(",")
            with warnings.catch_warnings():  # "no data" is reported below as one line
                warnings.simplefilter("ignore", UserWarning)
                data = np.loadtxt(fh, delimiter=",", ndmin=2, dtype=float)
    except OSError as exc:
        raise InputError(str(path), f"cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise InputError(str(path), "not UTF-8 text") from None
    except ValueError as exc:
        first = str(exc).splitlines()[0] if str(exc) else "not numbers"
        raise InputError(str(path), f"malformed numbers: {first[:200]}") from None
    if data.size == 0:
        raise InputError(str(path), "no samples")
    if data.shape[1] != len(header):
        raise InputError(str(path), f"{len(header)} header names but {data.shape[1]} columns")
    col = {name: i for i, name in enumerate(header)}
    if len(col) != len(header) or header[0] != "t" or header[-3:] != ["ee.x", "ee.y", "ee.z"]:
        raise InputError(str(path), "header must be t, q.*, dq.*, ddq.*, ..., ee.x, ee.y, ee.z "
                         "with unique names")
    coords = tuple(h[2:] for h in header if h.startswith("q."))
    actuators = tuple(h[4:] for h in header if h.startswith("tau."))

    def block(prefix: str, names: tuple[str, ...]) -> Array:
        try:
            return data[:, [col[f"{prefix}{c}"] for c in names]]
        except KeyError as exc:
            raise InputError(str(path), f"missing column {exc.args[0]}") from None

    known = {"t", "u", "ee.x", "ee.y", "ee.z"}
    extra = {h: data[:, i] for i, h in enumerate(header)
             if h not in known and not h.startswith(("q.", "dq.", "ddq.", "tau."))}
    try:
        return Trajectory(coordinates=coords, t=data[:, 0], q=block("q.", coords),
                          dq=block("dq.", coords), ddq=block("ddq.", coords),
                          ee=block("ee.", ("x", "y", "z")), actuators=actuators,
                          tau=block("tau.", actuators) if actuators else None,
                          u=data[:, col["u"]] if "u" in col else None, extra=extra)
    except ModelError as exc:
        raise InputError(str(path), str(exc)) from None


def read_plan(directory: str | Path) -> tuple[Trajectory, Scenario]:
    """Read a plan directory written by :func:`write_plan`: its trajectory and scenario.

    The planner that made the plan need not be installed (its settings are then kept as
    written, unvalidated): checking a plan needs only the robot, scene and task.

    Raises:
        InputError: not a plan directory, or unreadable files.
    """
    folder = path_argument(directory, "directory")
    if not folder.is_dir():
        raise InputError(str(folder), "no such directory")
    for name in ("trajectory.csv", "scenario.yaml"):
        if not (folder / name).is_file():
            raise InputError(str(folder), f"not a plan directory: {name} missing")
    # no start checks: a start in collision or outside the limits is a failed check, not bad input
    scenario = load_scenario(folder / "scenario.yaml", require_planner=False, check_start=False)
    return read_trajectory_csv(folder / "trajectory.csv"), scenario


def read_summary(directory: str | Path) -> dict[str, Any]:
    """summary.json of a plan directory as a dict (InputError if missing or malformed)."""
    path = path_argument(directory, "directory") / "summary.json"
    try:
        with path.open("rb") as fh:
            raw = fh.read(MAX_SUMMARY_BYTES + 1)
    except OSError as exc:
        raise InputError(str(path), f"cannot read: {exc.strerror or exc}") from None
    if len(raw) > MAX_SUMMARY_BYTES:
        raise InputError(str(path), f"larger than {MAX_SUMMARY_BYTES / 1e6:g} MB; mmplan writes "
                         "a few kB")
    try:
        data = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise InputError(str(path), f"not UTF-8 text (byte {exc.start}: "
                         f"{raw[exc.start:exc.start + 1]!r})") from None
    except json.JSONDecodeError as exc:
        raise InputError(str(path), f"malformed JSON: {exc}") from None
    except (ValueError, RecursionError) as exc:  # a 5000-digit number, [[[[...]]]] nesting
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(str(path), f"malformed JSON: {first[:200]}") from None
    if not isinstance(data, dict):
        raise InputError(str(path), "expected a JSON object")
    return data
