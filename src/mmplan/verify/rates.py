r"""Velocity and acceleration limits, checked at every sample of a trajectory.

Quantities (the platform pose is the first three coordinates x, y, heading of every robot):

* per coordinate: :math:`|\dot q_i|` and :math:`|\ddot q_i|`;
* platform planar speed :math:`\sqrt{\dot x^2 + \dot y^2}` and yaw rate :math:`|\dot\theta|`;
* platform planar acceleration :math:`\sqrt{\ddot x^2 + \ddot y^2}` and :math:`|\ddot\theta|`.

Each quantity with a finite limit (:class:`~mmplan.robot.RateLimits`) is checked twice:

* on the dq, ddq columns, at every sample: value <= limit (1 + ``RATE_REL_TOL``), 1e-6
  relative (numerical slack only);
* on finite differences that do not trust those columns: velocities from q (the secant
  :math:`(q_{k+1} - q_k)/\Delta t_k`, for the platform :math:`|(\Delta x, \Delta y)|/\Delta t_k`),
  accelerations from dq (:math:`(\dot q_{k+1} - \dot q_k)/\Delta t_k`): value <= limit
  (1 + ``FD_REL_TOL``), 1 % (the dq consistency tolerance of :mod:`.check`). A secant is the
  mean rate over its step, never above the true peak, so an honest plan passes; a file whose
  dq column is scaled down cannot hide a speed above the limit by more than 1 %.

Peaks and ``limit_margins`` (limit - peak, negative when broken) are those of the columns. When
``t`` is not time (a segment task: ``t`` is the segment parameter) the rates are not in SI units:
no peaks are reported, and a finite limit is a failure (the plan cannot show it holds).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.robot import RateLimits

RATE_REL_TOL = 1e-6  # relative slack on the dq, ddq columns
FD_REL_TOL = 1e-2  # relative slack on the finite-difference rates (as DQ_REL_TOL)


@dataclass(frozen=True)
class RateCheck:
    """One limited quantity: its limit, the peak of the columns and of the finite differences.

    Attributes:
        key: ``velocity.<name>``, ``acceleration.<name>``, ``platform_speed``,
            ``platform_yaw_rate``, ``platform_acceleration`` or ``platform_yaw_acceleration``
            (as in :attr:`RateLimits.sources` and summary.json ``limit_margins``).
        label: What is bounded, e.g. ``|dq| phi1`` or ``platform speed``.
        unit: SI unit of the value.
        limit: The bound (finite).
        peak, peak_time: Largest value from the dq/ddq columns and its time.
        fd_peak, fd_time: Largest finite-difference value and the start of its step (0 and
            nan for one sample).
    """

    key: str
    label: str
    unit: str
    limit: float
    peak: float
    peak_time: float
    fd_peak: float
    fd_time: float

    def failures(self) -> list[str]:
        """The broken bound, naming value, limit and time ([] when within).

        The columns' line when they break the limit, else the finite differences' line when
        they do (the columns understate the motion).
        """
        what = f"{self.label} = {{:.4g}} {self.unit} > limit {self.limit:.4g} {self.unit}"
        if not self.peak <= self.limit * (1 + RATE_REL_TOL):
            return [f"rate limits: {what.format(self.peak)} at t = {self.peak_time:.4g} s"]
        if not self.fd_peak <= self.limit * (1 + FD_REL_TOL):
            source = "q" if self.key.startswith(("velocity", "platform_speed",
                                                 "platform_yaw_rate")) else "dq"
            return [f"rate limits: {what.format(self.fd_peak)} + {FD_REL_TOL:.0%} from "
                    f"finite differences of {source} at t = {self.fd_time:.4g} s "
                    f"(the dq/ddq columns understate it)"]
        return []


@dataclass(frozen=True)
class RateReport:
    """Peaks of the rates and the checks of the finite limits.

    Attributes:
        timed: False when ``t`` is not time (rates not in SI units, peaks None / empty).
        peak_velocity, peak_acceleration: max |dq_i|, max |ddq_i| by coordinate name.
        peak_platform_speed_mps, peak_platform_yaw_rate_radps: max planar speed, max |dtheta|.
        peak_platform_acceleration_mps2, peak_platform_yaw_acceleration_radps2: likewise.
        checks: One :class:`RateCheck` per finite limit.
        untimed_limits: Keys of finite limits that could not be checked (``timed`` False).
    """

    timed: bool = True
    peak_velocity: Mapping[str, float] = field(default_factory=dict)
    peak_acceleration: Mapping[str, float] = field(default_factory=dict)
    peak_platform_speed_mps: float | None = None
    peak_platform_yaw_rate_radps: float | None = None
    peak_platform_acceleration_mps2: float | None = None
    peak_platform_yaw_acceleration_radps2: float | None = None
    checks: tuple[RateCheck, ...] = ()
    untimed_limits: tuple[str, ...] = ()

    def failures(self) -> list[str]:
        """One line per broken limit (see :meth:`RateCheck.failures`)."""
        out = [line for c in self.checks for line in c.failures()]
        if self.untimed_limits:
            out.append(f"rate limits: {', '.join(self.untimed_limits)} set but t is the segment "
                       f"parameter, not time; the plan cannot show that they hold")
        return out

    @property
    def limit_margins(self) -> dict[str, float]:
        """limit - peak of the columns, for each finite limit (negative when broken)."""
        return {c.key: c.limit - c.peak for c in self.checks}


def _peak(values: Array, t: Array) -> tuple[float, float]:
    """Largest entry of ``values`` (N,) and its time (NaN counts as the largest)."""
    if values.size == 0:
        return 0.0, math.nan
    k = int(np.argmax(np.where(np.isnan(values), np.inf, values)))
    return float(values[k]), float(t[k])


def check_rates(t: Array, q: Array, dq: Array, ddq: Array, coordinates: tuple[str, ...],
                limits: RateLimits, units: Mapping[str, str] | None = None,
                timed: bool = True) -> RateReport:
    """Peaks and limit checks of the rates of one trajectory (module doc).

    Args:
        t: Sample times (N,) [s].
        q, dq, ddq: Columns (N, n) in ``coordinates`` order; the first three are x, y, heading.
        coordinates: Coordinate names.
        limits: The limits to check.
        units: Unit of each coordinate, ``"m"`` or ``"rad"`` (default ``"rad"``).
        timed: False when ``t`` is a path parameter, not time.

    Raises:
        InputError: ``limits`` bounds a coordinate that is not in ``coordinates``.
    """
    for kind in ("velocity", "acceleration"):
        unknown = sorted(set(getattr(limits, kind)) - set(coordinates))
        if unknown:
            raise InputError(f"limits.{kind}", f"unknown coordinates {unknown}; the robot has "
                             f"{', '.join(coordinates)}")
    finite = _finite_keys(limits)
    if not timed:
        return RateReport(timed=False, untimed_limits=tuple(finite))
    dt = np.diff(t)[:, None]  # (N - 1, 1)
    fd_v = np.diff(q, axis=0) / dt  # secant rates from q (N - 1, n)
    fd_a = np.diff(dq, axis=0) / dt  # secant rates from dq
    t_fd = t[:-1]
    # (key, label, unit, limit, column values (N,), finite-difference values (N - 1,))
    rows: list[tuple[str, str, str, float, Array, Array]] = [
        ("platform_speed", "platform speed", "m/s", limits.platform_speed,
         np.hypot(dq[:, 0], dq[:, 1]), np.hypot(fd_v[:, 0], fd_v[:, 1])),
        ("platform_yaw_rate", "platform yaw rate", "rad/s", limits.platform_yaw_rate,
         np.abs(dq[:, 2]), np.abs(fd_v[:, 2])),
        ("platform_acceleration", "platform acceleration", "m/s^2",
         limits.platform_acceleration, np.hypot(ddq[:, 0], ddq[:, 1]),
         np.hypot(fd_a[:, 0], fd_a[:, 1])),
        ("platform_yaw_acceleration", "platform yaw acceleration", "rad/s^2",
         limits.platform_yaw_acceleration, np.abs(ddq[:, 2]), np.abs(fd_a[:, 2])),
    ]
    for j, name in enumerate(coordinates):
        unit = (units or {}).get(name, "rad")
        for kind, label, col, fd, per in (("velocity", "|dq|", dq, fd_v, "/s"),
                                           ("acceleration", "|ddq|", ddq, fd_a, "/s^2")):
            bound = getattr(limits, kind).get(name, math.inf)
            rows.append((f"{kind}.{name}", f"{label} {name}", unit + per, bound,
                         np.abs(col[:, j]), np.abs(fd[:, j])))
    checks = []
    for key, label, unit, limit, values, fd_values in rows:
        if math.isfinite(limit):
            peak, at = _peak(values, t)
            fd_peak, fd_at = _peak(fd_values, t_fd)
            checks.append(RateCheck(key, label, unit, float(limit), peak, at, fd_peak, fd_at))
    return RateReport(
        peak_velocity={c: _peak(np.abs(dq[:, j]), t)[0] for j, c in enumerate(coordinates)},
        peak_acceleration={c: _peak(np.abs(ddq[:, j]), t)[0] for j, c in enumerate(coordinates)},
        peak_platform_speed_mps=_peak(rows[0][4], t)[0],
        peak_platform_yaw_rate_radps=_peak(rows[1][4], t)[0],
        peak_platform_acceleration_mps2=_peak(rows[2][4], t)[0],
        peak_platform_yaw_acceleration_radps2=_peak(rows[3][4], t)[0],
        checks=tuple(checks),
    )


def _finite_keys(limits: RateLimits) -> list[str]:
    keys = [f"{kind}.{name}" for kind in ("velocity", "acceleration")
            for name, v in getattr(limits, kind).items() if math.isfinite(v)]
    keys += [k for k in ("platform_speed", "platform_yaw_rate", "platform_acceleration",
                         "platform_yaw_acceleration") if math.isfinite(getattr(limits, k))]
    return keys
