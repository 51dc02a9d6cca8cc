"""Tasks: what the end effector must do. Each task measures its own error along a run."""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError


class Task(ABC):
    """A task for the end effector, with a tolerance that decides 'reached'."""

    #: How a scenario file states this kind of goal (for error messages).
    goal_form: ClassVar[str] = "a goal"
    tolerance: float

    @abstractmethod
    def errors(self, t: Array, ee: Array) -> Array:
        """Task error norm [m] at each sample, (N,), from times (N,) and ee positions (N, 3)."""


@dataclass(frozen=True)
class ReachPoint(Task):
    """Bring the end effector to ``position`` (3,) [m] within ``tolerance`` [m]."""

    goal_form: ClassVar[str] = "a goal position (goal.position)"
    position: tuple[float, float, float]
    tolerance: float = 1e-3

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _point(self.position, "goal.position"))
        object.__setattr__(self, "tolerance", _positive(self.tolerance, "goal.tolerance"))

    def errors(self, t: Array, ee: Array) -> Array:
        return np.asarray(np.linalg.norm(ee - np.asarray(self.position), axis=1), dtype=float)


def _point(value: object, field: str) -> tuple[float, float, float]:
    """``value`` as 3 finite floats (a point [m]); InputError otherwise."""
    raw = np.asarray(value) if not isinstance(value, str | bytes) else np.asarray(None)
    if raw.dtype.kind not in "iuf" or raw.shape != (3,) or not np.isfinite(raw).all():
        raise InputError(field, f"expected 3 finite numbers [m], got {type(value).__name__}"
                         + (f" of shape {raw.shape}" if raw.dtype.kind in "iuf" else ""))
    x, y, z = (float(v) for v in raw)
    return (x, y, z)


def _positive(value: object, field: str) -> float:
    """``value`` as a finite float > 0; InputError otherwise."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise InputError(field, f"expected a number > 0, got {type(value).__name__}")
    if not (math.isfinite(value) and value > 0):
        raise InputError(field, f"expected a finite number > 0, got {value!r}")
    return float(value)


def completion_time(t: Array, errors: Array, tolerance: float) -> float | None:
    """T(tol): first time after which ``errors < tolerance`` holds for good (None if never).

    Task completion time (docs/extended_jacobian.md): T(tol) = first time after which
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
    |ee(t) - X_d(t)| ([AbdessemedDjebrani] sections 2 and 3).
    """

    goal_form: ClassVar[str] = "a path to track (goal.path)"
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

    Used by the manipulability-area base planner ([Nagatani]); the trajectory's time is the
    segment parameter s in [0, 1]. The error is the distance to the point at parameter t.
    """

    goal_form: ClassVar[str] = "a segment to draw (goal.segment {start, end, normal})"
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


def _smoothstep5(tau: Array) -> tuple[Array, Array]:
    """Quintic blend s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 and ds/dtau on [0, 1].

    s(0) = 0, s(1) = 1, and s' = s'' = 0 at both ends (rest-to-rest blend).
    """
    s = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
    ds = 30.0 * tau**2 * (1.0 - tau) ** 2
    return s, ds


@dataclass(frozen=True)
class WaypointPath(TrackPath):
    """Waypoints ``points[i]`` (K, 3) [m] reached at ``times[i]`` (K,) [s], strictly increasing.

    Time law: between waypoints i and i + 1, with tau = (t - t_i) / (t_{i+1} - t_i),
    X_d(t) = P_i + s(tau) (P_{i+1} - P_i) where s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 is the
    quintic rest-to-rest blend: the path is C^2, stops at every waypoint (zero velocity and
    acceleration there) and runs on straight segments between them. Before ``times[0]`` the
    reference holds ``points[0]``, after ``times[-1]`` it holds ``points[-1]``;
    ``duration = times[-1]``.
    """

    points: tuple[tuple[float, float, float], ...]
    times: tuple[float, ...]
    tolerance: float = 1e-3

    @property
    def duration(self) -> float:  # type: ignore[override]
        return float(self.times[-1])

    def _segment(self, t: float) -> tuple[int, float, float]:
        """Segment index i, blend parameter tau in [0, 1] and 1 / (t_{i+1} - t_i)."""
        times = np.asarray(self.times, dtype=float)
        i = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2))
        inv = 1.0 / (times[i + 1] - times[i])
        tau = float(np.clip((t - times[i]) * inv, 0.0, 1.0))
        return i, tau, inv

    def position(self, t: float) -> Array:
        i, tau, _ = self._segment(t)
        p = np.asarray(self.points, dtype=float)
        s, _ = _smoothstep5(np.asarray(tau))
        return np.asarray(p[i] + float(s) * (p[i + 1] - p[i]), dtype=float)

    def velocity(self, t: float) -> Array:
        i, tau, inv = self._segment(t)
        p = np.asarray(self.points, dtype=float)
        _, ds = _smoothstep5(np.asarray(tau))
        return np.asarray(float(ds) * inv * (p[i + 1] - p[i]), dtype=float)


@dataclass(frozen=True)
class PolynomialPath(TrackPath):
    """Polynomial path X_d(t) = sum_k c_k t^k on [0, duration] [m], c_k = ``coefficients[k]`` (3,).

    After ``duration`` the reference holds X_d(duration) (zero velocity); before 0 it holds
    X_d(0).
    """

    coefficients: tuple[tuple[float, float, float], ...]
    duration: float
    tolerance: float = 1e-3

    def position(self, t: float) -> Array:
        s = float(np.clip(t, 0.0, self.duration))
        c = np.asarray(self.coefficients, dtype=float)  # (K, 3)
        powers = s ** np.arange(len(c), dtype=float)
        return np.asarray(powers @ c, dtype=float)

    def velocity(self, t: float) -> Array:
        if t < 0.0 or t > self.duration:
            return np.zeros(3)
        c = np.asarray(self.coefficients, dtype=float)
        k = np.arange(1, len(c), dtype=float)
        return np.asarray((k * t ** (k - 1)) @ c[1:], dtype=float) if len(c) > 1 else np.zeros(3)
