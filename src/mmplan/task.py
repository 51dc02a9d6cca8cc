"""Tasks: what the end effector must do. Each task measures its own error along a run."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


class Task(ABC):
    """A task for the end effector, with a tolerance that decides 'reached'."""

    tolerance: float

    @abstractmethod
    def errors(self, t: Array, ee: Array) -> Array:
        """Task error norm [m] at each sample, (N,), from times (N,) and ee positions (N, 3)."""


@dataclass(frozen=True)
class ReachPoint(Task):
    """Bring the end effector to ``position`` (3,) [m] within ``tolerance`` [m]."""

    position: tuple[float, float, float]
    tolerance: float = 1e-3

    def errors(self, t: Array, ee: Array) -> Array:
        return np.asarray(np.linalg.norm(ee - np.asarray(self.position), axis=1), dtype=float)


def completion_time(t: Array, errors: Array, tolerance: float) -> float | None:
    """T(tol): first time after which ``errors < tolerance`` holds for good (None if never).

    SPEC section 3: task completion time T(tol) = first time after which
    |k(q) - p_f| < tol holds until the end of the trajectory.
    """
    above = np.flatnonzero(np.asarray(errors) >= tolerance)
    if above.size == 0:
        return float(t[0])
    last = int(above[-1])
    if last == len(t) - 1:
        return None
    return float(t[last + 1])


class TrackPath(Task):
    """Follow a time-parametrized end-effector path X_d(t) on [0, duration].

    Subclasses give the reference position and velocity; the error at a sample is
    |ee(t) - X_d(t)| (paper 001 sections 2 and 3).
    """

    duration: float

    @abstractmethod
    def position(self, t: float) -> Array:
        """X_d(t) [m], (3,)."""

    @abstractmethod
    def velocity(self, t: float) -> Array:
        """dX_d/dt (t) [m/s], (3,)."""

    def errors(self, t: Array, ee: Array) -> Array:
        ref = np.array([self.position(float(s)) for s in t])
        return np.asarray(np.linalg.norm(ee - ref, axis=1), dtype=float)


@dataclass(frozen=True)
class LinePath(TrackPath):
    """Straight line at constant speed: X_d(t) = start + t * velocity_vector."""

    start: tuple[float, float, float]
    speed: tuple[float, float, float]
    duration: float
    tolerance: float = 1e-3

    def position(self, t: float) -> Array:
        return np.asarray(self.start, dtype=float) + t * np.asarray(self.speed, dtype=float)

    def velocity(self, t: float) -> Array:
        return np.asarray(self.speed, dtype=float)


@dataclass(frozen=True)
class DrawSegment(Task):
    """Move the tool tip along the segment ``start`` -> ``end`` [m] with the tool axis
    along ``-normal`` (pointing into the surface whose outward normal is ``normal``).

    Used by the manipulability-area base planner (paper 004); the trajectory's time is the
    segment parameter s in [0, 1]. The error is the distance to the point at parameter t.
    """

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    normal: tuple[float, float, float]
    tolerance: float = 1e-3

    def point(self, s: float) -> Array:
        """Point at segment parameter s in [0, 1], (3,)."""
        a, b = np.asarray(self.start, float), np.asarray(self.end, float)
        return a + s * (b - a)

    def errors(self, t: Array, ee: Array) -> Array:
        ref = np.array([self.point(float(s)) for s in t])
        return np.asarray(np.linalg.norm(ee - ref, axis=1), dtype=float)
