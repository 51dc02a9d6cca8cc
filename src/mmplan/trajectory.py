"""Trajectory: the time series a planner produces, and the result of a planning run."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError, ModelError, require


class Status(StrEnum):
    """How a planning run ended (summary.json ``status``).

    ``Status("reached")`` is ``Status.REACHED``; any other value than the exact string of a
    member raises :class:`~mmplan.errors.InputError` (not ``ValueError``).
    """

    REACHED = "reached"
    STALLED = "stalled"
    DIVERGED = "diverged"
    INFEASIBLE = "infeasible"
    TIMEOUT = "timeout"

    @classmethod
    def _missing_(cls, value: object) -> Status:
        plain = value is None or isinstance(value, str | int | float)
        shown = repr(value)[:60] if plain else type(value).__name__
        raise InputError(
            "status", f"{shown} is not a status; one of {', '.join(s.value for s in cls)}"
        )


def _check_result(result: Solution | PlanResult) -> None:
    """A result's status as a :class:`Status` (its exact string value accepted), its
    trajectory a :class:`Trajectory`; InputError otherwise."""
    object.__setattr__(result, "status", Status(result.status))
    require(result.trajectory, Trajectory, "trajectory", "a Trajectory")


@dataclass(frozen=True)
class Trajectory:
    """Sampled whole-body trajectory.

    Attributes:
        coordinates: Names of the generalized coordinates (robot order).
        t: Sample times [s], (N,), strictly increasing.
        q, dq, ddq: Coordinates, velocities, accelerations, (N, n).
        ee: End-effector position [m], (N, 3).
        actuators: Names of the actuators (empty when the planner has no efforts).
        tau: Actuator efforts (N, n_act) or None.
        u: Virtual control (N,) or None.
        extra: Further named columns (N,) written after ``u`` (e.g. platform controls).
    """

    coordinates: tuple[str, ...]
    t: Array
    q: Array
    dq: Array
    ddq: Array
    ee: Array
    actuators: tuple[str, ...] = ()
    tau: Array | None = None
    u: Array | None = None
    extra: Mapping[str, Array] = field(default_factory=dict)

    def __post_init__(self) -> None:
        N, n = len(self.t), len(self.coordinates)
        shapes: dict[str, tuple[int, ...]] = {
            "t": (N,),
            "q": (N, n),
            "dq": (N, n),
            "ddq": (N, n),
            "ee": (N, 3),
        }
        if self.tau is not None:
            shapes["tau"] = (N, len(self.actuators))
        if self.u is not None:
            shapes["u"] = (N,)
        for name, shape in shapes.items():
            value = getattr(self, name)
            if np.shape(value) != shape:
                raise ModelError(
                    f"Trajectory.{name}: expected shape {shape}, got {np.shape(value)}"
                )
        for name, value in self.extra.items():
            if np.shape(value) != (N,):
                raise ModelError(f"Trajectory.extra[{name!r}]: expected shape {(N,)}")
        if N == 0:
            raise ModelError("Trajectory: no samples")
        if N > 1 and not np.all(np.diff(self.t) > 0):
            raise ModelError("Trajectory.t must be strictly increasing")

    @property
    def samples(self) -> int:
        """Number of samples N."""
        return len(self.t)

    @property
    def duration(self) -> float:
        """t[-1] - t[0] [s]."""
        return float(self.t[-1] - self.t[0])

    def is_finite(self) -> bool:
        """True when no column holds NaN or inf."""
        arrays = [self.t, self.q, self.dq, self.ddq, self.ee, *self.extra.values()]
        arrays += [a for a in (self.tau, self.u) if a is not None]
        return all(bool(np.isfinite(a).all()) for a in arrays)

    def at_time(self, time: float) -> Array:
        """q at ``time`` by linear interpolation (clamped to the ends), (n,)."""
        return np.array([np.interp(time, self.t, self.q[:, i]) for i in range(self.q.shape[1])])

    def columns(self) -> tuple[list[str], Array]:
        """Header and data (N, columns) in the order of docs/conventions.md."""
        names = ["t"]
        names += [f"q.{c}" for c in self.coordinates]
        names += [f"dq.{c}" for c in self.coordinates]
        names += [f"ddq.{c}" for c in self.coordinates]
        blocks = [self.t[:, None], self.q, self.dq, self.ddq]
        if self.tau is not None:
            names += [f"tau.{a}" for a in self.actuators]
            blocks.append(self.tau)
        if self.u is not None:
            names.append("u")
            blocks.append(self.u[:, None])
        for key, value in self.extra.items():
            names.append(key)
            blocks.append(np.asarray(value)[:, None])
        names += ["ee.x", "ee.y", "ee.z"]
        blocks.append(self.ee)
        return names, np.hstack(blocks)


@dataclass(frozen=True)
class Solution:
    """What a method's solve returns; :meth:`Planner.plan` adds the method name and the time.

    Attributes are those of :class:`PlanResult` of the same names.
    """

    status: Status
    trajectory: Trajectory
    message: str = ""
    info: Mapping[str, Any] = field(default_factory=dict)
    history: Mapping[str, Array] = field(default_factory=dict)
    artifacts: Mapping[str, Array] = field(default_factory=dict)

    def __post_init__(self) -> None:
        _check_result(self)


@dataclass(frozen=True)
class PlanResult:
    """What a planner returns: always a trajectory (what it has), and a status saying why.

    Attributes:
        status: How the run ended.
        trajectory: The planned (or partial) trajectory.
        planner: Method name.
        message: One line for the user (why it stopped, where).
        compute_time_s: Wall-clock planning time [s].
        info: Planner-specific scalars for summary.json (iterations, max cond(E), ...).
        history: Named per-iteration series of equal length (e.g. error norm per
            iteration), written to history.csv.
        artifacts: Named arrays of any shape for reports (e.g. manipulability grids),
            written to artifacts.npz.
    """

    status: Status
    trajectory: Trajectory
    planner: str
    message: str = ""
    compute_time_s: float = 0.0
    info: Mapping[str, Any] = field(default_factory=dict)
    history: Mapping[str, Array] = field(default_factory=dict)
    artifacts: Mapping[str, Array] = field(default_factory=dict)

    def __post_init__(self) -> None:
        _check_result(self)
        require(self.planner, str, "planner", "the method name (str)")

    @property
    def reached(self) -> bool:
        """True when the task was reached."""
        return self.status is Status.REACHED
