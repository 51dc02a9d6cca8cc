"""``mmplan export``: a plan at a fixed control rate, as a plan folder and/or a ROS 2 bag.

The resampling is :mod:`mmplan.io.control_rate` (:func:`resample`, re-exported here), the
bag :mod:`mmplan.io.ros2`; :func:`export_plan` reads a plan folder and writes both.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError, path_argument
from mmplan.io.control_rate import (
    DEFAULT_RATE_HZ,
    Resampled,
    check_rate,
    resample,
    resample_detailed,
)

if TYPE_CHECKING:
    from mmplan.io.ros2 import BagSummary

__all__ = ["DEFAULT_RATE_HZ", "Exported", "Resampled", "export_plan", "resample",
           "resample_detailed"]


@dataclass(frozen=True)
class Exported:
    """What :func:`export_plan` wrote.

    Attributes:
        resampled: The resampled trajectory and its residuals.
        plan_dir: The plan folder written (None without ``out``).
        bag: The rosbag2 written (None without ``ros2``).
        failures: The independent checker's failures on the exported trajectory (one line
            each; empty when every check holds).
    """

    resampled: Resampled
    plan_dir: Path | None = None
    bag: BagSummary | None = None
    failures: tuple[str, ...] = ()


def export_plan(plan_dir: str | Path, *, rate: float = DEFAULT_RATE_HZ,
                out: str | Path | None = None, ros2: str | Path | None = None,
                step: Callable[[str], None] | None = None) -> Exported:
    """Resample the plan in ``plan_dir`` at ``rate`` Hz; write a plan folder and/or a bag.

    Each output is written completely or not at all (a temporary folder renamed into
    place); all arguments are checked before anything is written.

    Args:
        plan_dir: A plan folder (``mmplan plan ... --out plan_dir``).
        rate: Control rate [Hz].
        out: Plan folder to write, like :func:`mmplan.io.write_plan` (a new, empty or
            earlier plan folder); its summary.json is recomputed by the checker, its status,
            message and planner numbers are the plan's, ``planner_info.export`` holds
            :meth:`Resampled.info`; history.csv and artifacts.npz are carried over.
        ros2: rosbag2 folder to write (:func:`mmplan.io.ros2.write_bag`).
        step: Called with a short description as each step starts (progress lines).

    Raises:
        InputError: nothing to write, an unreadable plan, a bad rate, a plan whose t is not
            time (manipulability-area), an output that may not be written, rosbags missing.
    """
    from mmplan.io import ros2 as ros2_io  # no rosbags import until a bag is written
    from mmplan.io.plan_folder import check_out_dir, read_plan, read_summary, write_plan
    from mmplan.task import DrawSegment
    from mmplan.trajectory import PlanResult, Status
    from mmplan.verify.check import check

    note = step or (lambda _: None)
    if out is None and ros2 is None:
        raise InputError("export", "nothing to write: give --out DIR and/or --ros2 BAG")
    check_rate(rate)
    folder = path_argument(plan_dir, "plan_dir")
    outputs = [(flag, path_argument(p, flag)) for flag, p in (("--out", out), ("--ros2", ros2))
               if p is not None]
    _check_apart(folder, outputs)
    if out is not None:
        check_out_dir(out)
    if ros2 is not None:
        ros2_io.require_rosbags()
        ros2_io.check_bag_dir(ros2)
    note("reading the plan")
    trajectory, scenario = read_plan(folder)
    summary = read_summary(folder)
    problem = scenario.build()
    if isinstance(problem.task, DrawSegment):
        raise InputError(str(folder), "t of a manipulability-area plan is the segment parameter, "
                         "not time: it has no control rate")
    try:
        status = Status(str(summary.get("status")))
    except InputError as err:
        raise InputError(str(folder / "summary.json"), err.problem) from None
    note(f"resampling at {float(rate):g} Hz")
    resampled = resample_detailed(trajectory, rate, problem.robot)
    written = bag = None
    failures: list[str] = []
    if out is not None:
        note("writing and checking the plan folder")
        info = summary.get("planner_info")
        result = PlanResult(
            status, resampled.trajectory, scenario.method,
            message=str(summary.get("message") or ""),
            compute_time_s=float(summary.get("compute_time_s") or 0.0),
            info={**(info if isinstance(info, dict) else {}), "export": resampled.info()},
            history=_read_history(folder / "history.csv"),
            artifacts=_read_artifacts(folder / "artifacts.npz"))
        fmt = "npz" if (folder / "trajectory.npz").is_file() else "csv"
        written = write_plan(out, result, problem, scenario, fmt=fmt)
        failures = [str(f) for f in read_summary(written).get("check_failures", [])]
    else:
        note("checking the resampled plan")
        failures = check(resampled.trajectory, problem, status=status).failures()
    if ros2 is not None:
        note("writing the ROS 2 bag")
        bag = ros2_io.write_bag(resampled.trajectory, problem.robot, ros2)
    return Exported(resampled, written, bag, tuple(failures))


def _check_apart(plan: Path, outputs: list[tuple[str, Path]]) -> None:
    """Outputs must be neither the plan folder, nor inside it or inside each other."""
    try:
        src = plan.resolve()
        full = [(flag, path, path.resolve()) for flag, path in outputs]
    except (OSError, RuntimeError) as exc:
        raise InputError("export", str(exc)) from None
    for flag, path, res in full:
        if res == src or src in res.parents:
            raise InputError(flag, f"{path} is the plan folder being exported or inside it; "
                             "name another folder")
    if len(full) == 2:
        (_, a, ra), (_, b, rb) = full
        if ra == rb or ra in rb.parents or rb in ra.parents:
            raise InputError("--ros2", f"{b} and --out {a} overlap; name separate folders")


def _read_history(path: Path) -> dict[str, Array]:
    """history.csv of a plan folder as named columns ({} when absent)."""
    if not path.is_file():
        return {}
    try:
        with path.open(encoding="utf-8") as fh:
            names = fh.readline().strip().split(",")
            data = np.loadtxt(fh, delimiter=",", ndmin=2, dtype=float)
    except (OSError, ValueError) as exc:
        raise InputError(str(path), f"cannot read: {exc}") from None
    if data.size == 0:
        return {}
    if data.shape[1] != len(names):
        raise InputError(str(path), f"{len(names)} header names but {data.shape[1]} columns")
    return {name: data[:, j] for j, name in enumerate(names)}


def _read_artifacts(path: Path) -> dict[str, Array]:
    """artifacts.npz of a plan folder ({} when absent)."""
    if not path.is_file():
        return {}
    try:
        with np.load(path, allow_pickle=False) as npz:
            return {key: np.asarray(npz[key]) for key in npz.files}
    except (OSError, ValueError) as exc:
        raise InputError(str(path), f"cannot read: {exc}") from None
