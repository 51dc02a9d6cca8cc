r"""Velocity and acceleration limits of a trajectory: at its samples and between them.

Quantities (the platform pose is the first three coordinates x, y, heading of every robot):

* per coordinate: :math:`|\dot q_i|` and :math:`|\ddot q_i|`;
* platform planar speed :math:`\sqrt{\dot x^2 + \dot y^2}` and yaw rate :math:`|\dot\theta|`;
* platform planar acceleration :math:`\sqrt{\ddot x^2 + \ddot y^2}` and :math:`|\ddot\theta|`.

Between samples a trajectory means the cubic Hermite interpolant through
:math:`(t_k, q_k, \dot q_k)` (:mod:`mmplan.interpolant`, docs/conventions.md "Between
samples"): the planners hold their limits on it and ``mmplan export`` samples it. Each
quantity with a finite limit (:class:`~mmplan.robot.RateLimits`) is checked twice, with the
slack ``RATE_REL_TOL`` = 1e-6 relative (numerical rounding only):

* **samples**: the dq, ddq columns at every sample, value <= limit (1 + ``RATE_REL_TOL``);
* **steps**: from q and dq alone (the ddq column is not trusted), what *every* C1 motion
  through consecutive samples must reach, whatever the interpolation:

  - velocity: the secant :math:`|\Delta q_k|/h_k` (the platform's
    :math:`|(\Delta x, \Delta y)|/h_k`), the mean rate over the step;
  - a coordinate's acceleration (yaw included): the least peak of any motion with the
    step's end values,

    .. math::

        A^*_k = \frac{2|e_k| + \sqrt{4e_k^2 + h_k^2\Delta\dot q_k^2}}{h_k^2},\qquad
        e_k = \Delta q_k - \tfrac{h_k}{2}(\dot q_k + \dot q_{k+1}),

    reached by one switch between :math:`\pm A^*_k` (bang-bang), never above the Hermite's
    peak :math:`|\Delta\dot q_k|/h_k + 6|e_k|/h_k^2`. dq is granted ``DQ_TOL`` = 1e-6
    (rad/s, m/s): :math:`|e_k|` is lowered by :math:`h_k`\ ``DQ_TOL`` and
    :math:`|\Delta\dot q_k|` by 2 ``DQ_TOL`` first, so that rounding, and the projection of
    an export's dq onto :math:`\ker A(q)` (at most 5.4e-8 rad/s on the wheels, 1.5e-13 rad/s
    on the heading measured), are not read as accelerations of order DQ_TOL/h (the
    allowance costs at most 6 ``DQ_TOL``/h: 6e-3 rad/s^2 at 1 kHz). A dq column scaled down
    (a tampered file) moves :math:`e_k` by a finite fraction of :math:`h\dot q` and is caught;
  - the platform's planar acceleration: from q alone, the second divided difference over
    two steps, :math:`2\,|(s_{k+1} - s_k)|/(t_{k+2} - t_k)` with :math:`s_k` the secant
    velocity of (x, y) (the mean of the acceleration over the two steps is at least that
    large). Not from dq: the interpolant of x, y slips sideways between samples (up to 2.5e-5
    m/s on the youBot plans), which an export removes from dq but not from q.

Why the step check asks what any motion needs rather than what the Hermite reaches: a
plan sampled at other times (an export at a fixed rate) has its own Hermite, which on a
step that contains one of the plan's samples is a different curve: its acceleration is the
line with the same mean and first moment as the plan's piecewise-linear one, and overshoots a
jump of the plan's acceleration by up to a third of the jump (measured on the youBot plans
exported at 50, 100 and 1000 Hz: the exports' own Hermites reach up to 1.10-1.41 times a limit
that the plans' Hermites hold, the wheels' of youbot3r-obstacles(-torque) and the platform
acceleration of youbot4r-reach). The bounds above never exceed the peaks of the motion the
samples come from, so samples of a motion within the limits pass, at any rate; and a file
passes only when, for each limit by itself, a motion through its samples within it exists
(exactly so for the coordinates' limits and the speeds; the planar acceleration's bound is a
lower one). Planners hold the stronger condition, their Hermite within the limits
(:meth:`mmplan.time_scaling.RateModel.interval_ratios`).

Peaks and ``limit_margins`` (limit - peak, negative when broken) are those of the columns. When
``t`` is not time (a segment task: ``t`` is the segment parameter) the rates are not in SI units:
no peaks are reported, and a finite limit is a failure (the plan cannot show it holds).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.robot import RateLimits

RATE_REL_TOL = 1e-6  # relative slack of every rate check
DQ_TOL = 1e-6  # uncertainty granted to the dq column in the step bounds [m/s or rad/s]


@dataclass(frozen=True)
class RateCheck:
    """One limited quantity: its limit, the peak of the columns and the steps' least need.

    Attributes:
        key: ``velocity.<name>``, ``acceleration.<name>``, ``platform_speed``,
            ``platform_yaw_rate``, ``platform_acceleration`` or ``platform_yaw_acceleration``
            (as in :attr:`RateLimits.sources` and summary.json ``limit_margins``).
        label: What is bounded, e.g. ``|dq| phi1`` or ``platform speed``.
        unit: SI unit of the value.
        limit: The bound (finite).
        peak, peak_time: Largest value from the dq/ddq columns and its time.
        step_peak: Largest value that every motion through two consecutive samples reaches
            (module doc; 0 for one sample).
        step_start, step_end: The times of those two samples (nan for one sample).
    """

    key: str
    label: str
    unit: str
    limit: float
    peak: float
    peak_time: float
    step_peak: float
    step_start: float
    step_end: float

    def failures(self) -> list[str]:
        """The broken bound, naming value, limit and time ([] when within).

        The columns' line when they break the limit, else the steps' line when they do (the
        columns understate the motion the samples describe).
        """
        what = f"{self.label} = {{:.4g}} {self.unit} > limit {self.limit:.4g} {self.unit}"
        if not self.peak <= self.limit * (1 + RATE_REL_TOL):
            return [f"rate limits: {what.format(self.peak)} at t = {self.peak_time:.4g} s"]
        if not self.step_peak <= self.limit * (1 + RATE_REL_TOL):
            how = ("the secant of q" if self.key.startswith(
                ("velocity", "platform_speed", "platform_yaw_rate")) else
                "the second difference of q" if self.key == "platform_acceleration" else
                "the least peak of any motion with those q, dq")  # fmt: skip
            return [f"rate limits: {what.format(self.step_peak)} between the samples at "
                    f"t = {self.step_start:.4g} and {self.step_end:.4g} s ({how}; the dq/ddq "
                    f"columns understate it)"]
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
    steps = _Steps(t, q, dq)
    # (key, label, unit, limit, column values (N,), the step bound's kind and indices)
    rows: list[tuple[str, str, str, float, Array, str, tuple[int, ...]]] = [
        ("platform_speed", "platform speed", "m/s", limits.platform_speed,
         np.hypot(dq[:, 0], dq[:, 1]), "velocity", (0, 1)),
        ("platform_yaw_rate", "platform yaw rate", "rad/s", limits.platform_yaw_rate,
         np.abs(dq[:, 2]), "velocity", (2,)),
        ("platform_acceleration", "platform acceleration", "m/s^2",
         limits.platform_acceleration, np.hypot(ddq[:, 0], ddq[:, 1]), "acceleration", (0, 1)),
        ("platform_yaw_acceleration", "platform yaw acceleration", "rad/s^2",
         limits.platform_yaw_acceleration, np.abs(ddq[:, 2]), "acceleration", (2,)),
    ]
    for j, name in enumerate(coordinates):
        unit = (units or {}).get(name, "rad")
        for kind, label, col, per in (("velocity", "|dq|", dq, "/s"),
                                      ("acceleration", "|ddq|", ddq, "/s^2")):
            bound = getattr(limits, kind).get(name, math.inf)
            rows.append((f"{kind}.{name}", f"{label} {name}", unit + per, bound,
                         np.abs(col[:, j]), kind, (j,)))
    checks = []
    for key, label, unit, limit, values, kind, index in rows:
        if not math.isfinite(limit):
            continue
        step_values, first, last = (steps.secant(index) if kind == "velocity"
                                    else steps.least_acceleration(index))  # fmt: skip
        peak, at = _peak(values, t)
        step_peak, k = _peak(step_values, np.arange(len(step_values), dtype=float))
        start = end = math.nan
        if step_values.size:
            start, end = float(t[first[int(k)]]), float(t[last[int(k)]])
        checks.append(RateCheck(key, label, unit, float(limit), peak, at, step_peak, start, end))
    return RateReport(
        peak_velocity={c: _peak(np.abs(dq[:, j]), t)[0] for j, c in enumerate(coordinates)},
        peak_acceleration={c: _peak(np.abs(ddq[:, j]), t)[0] for j, c in enumerate(coordinates)},
        peak_platform_speed_mps=_peak(rows[0][4], t)[0],
        peak_platform_yaw_rate_radps=_peak(rows[1][4], t)[0],
        peak_platform_acceleration_mps2=_peak(rows[2][4], t)[0],
        peak_platform_yaw_acceleration_radps2=_peak(rows[3][4], t)[0],
        checks=tuple(checks),
    )


#: A bound per window of samples, and the indices of each window's first and last sample.
_Windows = tuple[Array, NDArray[np.intp], NDArray[np.intp]]


class _Steps:
    """What every C1 motion through consecutive samples must reach (module doc). Each method
    returns the bound per window and the index of the window's first and last sample."""

    def __init__(self, t: Array, q: Array, dq: Array) -> None:
        h = np.diff(t)
        self.finite = np.isfinite(h) & (h > 0.0)  # (N - 1,): other steps are not judged
        self.h = np.where(self.finite, h, 1.0)  # (N - 1,)
        self.dpos = np.diff(q, axis=0)  # (N - 1, n)
        self.dvel = np.diff(dq, axis=0)
        self.trap = self.dpos - 0.5 * self.h[:, None] * (dq[:-1] + dq[1:])  # e_k
        self.one = np.arange(len(h), dtype=np.intp)

    def secant(self, index: tuple[int, ...]) -> _Windows:
        """|Delta q| / h over the coordinates ``index`` (a norm for two) per step."""
        d = self.dpos[:, list(index)]
        speed = np.where(self.finite, np.sqrt(np.sum(d * d, axis=1)) / self.h, 0.0)
        return speed, self.one, self.one + 1

    def least_acceleration(self, index: tuple[int, ...]) -> _Windows:
        """A* of one coordinate per step, with the DQ_TOL allowance; for two, the planar
        second divided difference of q per pair of steps."""
        if len(index) == 2:
            d = self.dpos[:, list(index)] / self.h[:, None]  # secant velocities (N - 1, 2)
            span = self.h[1:] + self.h[:-1]
            both = self.finite[1:] & self.finite[:-1]
            dd = 2.0 * np.sqrt(np.sum(np.diff(d, axis=0) ** 2, axis=1)) / span
            return np.where(both, dd, 0.0), self.one[:-1], self.one[:-1] + 2
        e = np.maximum(np.abs(self.trap[:, index[0]]) - DQ_TOL * self.h, 0.0)
        dv = np.maximum(np.abs(self.dvel[:, index[0]]) - 2.0 * DQ_TOL, 0.0)
        need = (2.0 * e + np.sqrt(4.0 * e * e + (self.h * dv) ** 2)) / (self.h * self.h)
        return np.where(self.finite, need, 0.0), self.one, self.one + 1


def _finite_keys(limits: RateLimits) -> list[str]:
    keys = [f"{kind}.{name}" for kind in ("velocity", "acceleration")
            for name, v in getattr(limits, kind).items() if math.isfinite(v)]
    keys += [k for k in ("platform_speed", "platform_yaw_rate", "platform_acceleration",
                         "platform_yaw_acceleration") if math.isfinite(getattr(limits, k))]
    return keys
