r"""Velocity and acceleration limits of a robot: as time-scaling constraints along a path, and
as a verdict on a sampled trajectory.

The limited quantities (:class:`Quantity`) come from :class:`~mmplan.robot.limits.RateLimits`:
``|dq_j|`` and ``|ddq_j|`` of named coordinates, the platform's planar speed ``|(dx, dy)|``,
its yaw rate ``|dtheta|`` and the two accelerations (platform coordinates x, y, theta first, as
every built-in platform has them). Along a path q(sigma) traversed at the time rate
w = dsigma/dt, with x = w^2 and v = dx/dsigma (:mod:`.topp`):

.. math::

    \dot q = w\,q', \qquad \ddot q = x\,q'' + \tfrac12 v\,q'.

* A velocity limit bounds x alone, exactly: :math:`|q'_j|\sqrt x \le v_j \iff
  x \le v_j^2 / q_j'^2`, and :math:`|(x', y')|\sqrt x \le v \iff x \le v^2/(x'^2 + y'^2)`
  (``x_upper``; no bound where the path does not move the quantity).
* A coordinate's acceleration limit is the exact row :math:`-a_j \le q''_j x + \tfrac12 q'_j v
  \le a_j` (alpha = q'', beta = q', g = 0 in the form of :mod:`.topp`).
* The planar acceleration limit :math:`|(\ddot x, \ddot y)| \le a` is not linear. It is
  replaced by the regular polygon of :data:`POLYGON_SIDES` sides inscribed in the circle of
  radius a: the rows :math:`|n_k \cdot (\ddot x, \ddot y)| \le a \cos(\pi/K)` for the
  K/2 normals :math:`n_k = (\cos 2\pi k/K, \sin 2\pi k/K)`. Its vertices lie on the circle,
  so the true norm never exceeds a where the rows hold; it gives away at most
  :math:`1 - \cos(\pi/K)` of the limit (3.4 % for K = 12) in the directions between two
  vertices.

The rows hold at the samples (both ends of every interval). Between samples a trajectory
means the cubic Hermite interpolant of :mod:`mmplan.interpolant`;
:meth:`RateModel.interval_ratios` gives its extremes per step, which
:func:`.retime.retime_path` holds by tightening, and :meth:`RateModel.first_violation` judges
samples and interpolant (the planners' verdict; the independent checker has its own).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Literal

import numpy as np

from mmplan import interpolant
from mmplan.arrays import Array
from mmplan.robot.limits import RateLimits
from mmplan.robot.tree import JointKind
from mmplan.time_scaling import native, native_peaks

if TYPE_CHECKING:
    from mmplan.robot.robot import Robot


#: Sides K of the polygon that replaces the planar acceleration circle (K/2 two-sided rows).
POLYGON_SIDES = 12
#: Relative slack of the sample verdict (rounding of sqrt(x) q' against the bound).
REL_TOL = 1e-9
#: Relative slack of the interpolant's step extremes in the verdict (as the checker's).
INTERVAL_TOL = 1e-6

Kind = Literal["velocity", "acceleration"]


@dataclass(frozen=True)
class Quantity:
    """One limited quantity: |dq_j| or |ddq_j| (one index) or a planar norm (two indices)."""

    label: str
    kind: Kind
    limit: float
    unit: str
    index: tuple[int, ...]

    def values(self, dq: Array, ddq: Array) -> Array:
        """The quantity at every sample (N,) of dq, ddq (N, n)."""
        m = dq if self.kind == "velocity" else ddq
        if len(self.index) == 1:
            return np.asarray(np.abs(m[:, self.index[0]]), dtype=float)
        return np.asarray(np.hypot(m[:, self.index[0]], m[:, self.index[1]]), dtype=float)


@dataclass(frozen=True)
class RateViolation:
    """The first sample (or step) at which a quantity exceeds its limit.

    ``until`` is None for a sample; for a step [t, until] the value is the peak of the cubic
    Hermite interpolant on it (:mod:`mmplan.interpolant`).
    """

    quantity: Quantity
    value: float
    t: float
    worst: float
    worst_t: float
    samples: int
    until: float | None = None

    @property
    def message(self) -> str:
        """One line: what needs how much, when, against which limit."""
        q = self.quantity
        when = (f"at t = {self.t:.2f} s" if self.until is None
                else f"between the samples at t = {self.t:.2f} and {self.until:.2f} s")  # fmt: skip
        text = f"{q.label} needs {self.value:.3g} {q.unit} {when}, limit {q.limit:.3g}"
        if self.samples > 1:
            what = "samples" if self.until is None else "steps"
            text += f" ({self.samples} {what}, peak {self.worst:.3g} at t = {self.worst_t:.2f} s)"
        return text


@dataclass(frozen=True)
class PathRates:
    """Rate limits along a sampled path as time-scaling input (:func:`.topp.time_optimal_scaling`).

    Attributes:
        x_upper: Bound of x = w^2 at each sample (N,) from the velocity limits (inf: none).
        alpha, beta, g: Acceleration rows (N, m) in the form of :mod:`.topp`.
        lo, hi: Their bounds (m,).
        labels: What each row limits (m,).
        quantity: Index in :attr:`RateModel.quantities` of the quantity of each row (m,).
    """

    x_upper: Array
    alpha: Array
    beta: Array
    g: Array
    lo: Array
    hi: Array
    labels: tuple[str, ...]
    quantity: tuple[int, ...]


@dataclass(frozen=True)
class RateModel:
    """The limited quantities of a robot (:meth:`of`) or of named coordinates (:meth:`build`)."""

    coordinates: tuple[str, ...]
    quantities: tuple[Quantity, ...]

    @classmethod
    def of(cls, robot: Robot) -> RateModel:
        """The rate limits ``robot.limits.rates`` on ``robot``'s coordinates."""
        linear = {j.coordinate for j in robot.tree.joints if j.kind is JointKind.PRISMATIC}
        planar = (0, 1, 2) if robot.n_platform >= 3 else None
        return cls.build(robot.coordinates, robot.limits.rates, planar,
                         {c for c in linear if c is not None})  # fmt: skip

    @classmethod
    def build(
        cls,
        coordinates: Sequence[str],
        rates: RateLimits,
        planar: tuple[int, int, int] | None = None,
        linear: Collection[str] = (),
    ) -> RateModel:
        """Quantities of ``rates`` (finite limits only) on ``coordinates``.

        Args:
            coordinates: Coordinate names in q order.
            rates: The limits (names not in ``coordinates`` are ignored).
            planar: Indices of the platform's x, y and heading (None: no platform limits).
            linear: Coordinates measured in m (the others in rad).
        """
        names = tuple(coordinates)
        planar_names = {names[i] for i in planar} if planar is not None else set()
        out: list[Quantity] = []
        for kind, bounds, suffix in (
            ("velocity", rates.velocity_bounds(names), "/s"),
            ("acceleration", rates.acceleration_bounds(names), "/s^2"),
        ):
            for j, name in enumerate(names):
                if math.isfinite(bounds[j]):
                    label = f"{'coordinate' if name in planar_names else 'joint'} {name}"
                    unit = ("m" if name in linear else "rad") + suffix
                    out.append(Quantity(label, kind, float(bounds[j]), unit, (j,)))  # type: ignore[arg-type]
        if planar is not None:
            px, py, yaw = planar
            for label, kind, limit, unit, index in (
                ("platform speed", "velocity", rates.platform_speed, "m/s", (px, py)),
                ("platform yaw rate", "velocity", rates.platform_yaw_rate, "rad/s", (yaw,)),
                ("platform acceleration", "acceleration", rates.platform_acceleration,
                 "m/s^2", (px, py)),
                ("platform yaw acceleration", "acceleration", rates.platform_yaw_acceleration,
                 "rad/s^2", (yaw,)),
            ):  # fmt: skip
                if math.isfinite(limit):
                    out.append(Quantity(label, kind, float(limit), unit, index))  # type: ignore[arg-type]
        return cls(names, tuple(out))

    @property
    def any(self) -> bool:
        """True when some quantity is limited."""
        return bool(self.quantities)

    @property
    def row_count(self) -> int:
        """Acceleration rows of :meth:`path_rows` (a planar norm takes POLYGON_SIDES / 2)."""
        return sum(
            (POLYGON_SIDES // 2 if len(q.index) == 2 else 1)
            for q in self.quantities
            if q.kind == "acceleration"
        )

    def path_rows(self, dq_ds: Array, ddq_ds2: Array) -> PathRates:
        """Time-scaling constraints along a path with q' = ``dq_ds`` and q'' = ``ddq_ds2``
        (N, n) (module docstring); one C loop when the time scaling's passes are loaded
        (:mod:`.native_rounds`, the same numbers as the NumPy code here)."""
        labels, owner, ri, rj, rc, rs, bound = self._rows
        hi = np.array(bound, dtype=float)
        compiled = native.loaded()
        if compiled is not None and np.ndim(dq_ds) == 2:
            kind, j1, j2, _ = self.peak_columns
            x_upper, a, b = compiled.rounds.path_rows(
                dq_ds, ddq_ds2, (kind, j1, j2, self._limits_squared), (ri, rj, rc, rs))
            return PathRates(x_upper, a, b, np.zeros((len(x_upper), len(hi))), -hi, hi, labels,
                             owner)  # fmt: skip
        N = len(dq_ds)
        x_upper = np.full(N, np.inf)
        for q in self.quantities:
            if q.kind == "velocity":
                speed2 = np.sum(np.square(dq_ds[:, list(q.index)]), axis=1)
                with np.errstate(divide="ignore"):
                    cap = np.where(speed2 > 0.0, q.limit**2 / speed2, np.inf)
                x_upper = np.minimum(x_upper, cap)
        alpha, beta = [], []
        for i, j, c, s in zip(ri, rj, rc, rs, strict=True):
            one = j < 0  # a coordinate's row; else a side of the planar polygon
            alpha.append(ddq_ds2[:, i] if one else c * ddq_ds2[:, i] + s * ddq_ds2[:, j])
            beta.append(dq_ds[:, i] if one else c * dq_ds[:, i] + s * dq_ds[:, j])
        a = np.column_stack(alpha) if alpha else np.zeros((N, 0))
        b = np.column_stack(beta) if beta else np.zeros((N, 0))
        return PathRates(x_upper, a, b, np.zeros((N, len(hi))), -hi, hi, labels, owner)

    @cached_property
    def _rows(self) -> tuple[tuple[str, ...], tuple[int, ...], Array, Array, Array, Array,
                             tuple[float, ...]]:  # fmt: skip
        """The acceleration rows of :meth:`path_rows`: labels, quantities, coordinates i and j
        (-1: a coordinate's own row), the polygon side's cosine and sine, bound."""
        labels, owner, ri, rj, rc, rs, bound = [], [], [], [], [], [], []
        for iq, q in enumerate(self.quantities):
            if q.kind == "velocity":
                continue
            if len(q.index) == 1:
                labels.append(q.label)
                owner.append(iq)
                ri.append(q.index[0])
                rj.append(-1)
                rc.append(1.0)
                rs.append(0.0)
                bound.append(q.limit)
                continue
            for k in range(POLYGON_SIDES // 2):
                labels.append(f"{q.label} (side {k + 1})")
                owner.append(iq)
                ri.append(q.index[0])
                rj.append(q.index[1])
                rc.append(math.cos(2 * math.pi * k / POLYGON_SIDES))
                rs.append(math.sin(2 * math.pi * k / POLYGON_SIDES))
                bound.append(q.limit * math.cos(math.pi / POLYGON_SIDES))
        return (tuple(labels), tuple(owner), np.array(ri), np.array(rj), np.array(rc, dtype=float),
                np.array(rs, dtype=float), tuple(bound))  # fmt: skip

    @cached_property
    def _limits_squared(self) -> Array:
        """Each quantity's limit squared (as ``limit**2`` in :meth:`path_rows`)."""
        return np.array([qt.limit**2 for qt in self.quantities], dtype=float)

    def ratios(self, dq: Array, ddq: Array) -> Array:
        """value / limit of every quantity at every sample, (N, len(quantities))."""
        if not self.quantities:
            return np.zeros((len(dq), 0))
        compiled = native.loaded()
        if compiled is not None and np.ndim(dq) == 2 and np.shape(dq) == np.shape(ddq):
            return compiled.rounds.ratios(dq, ddq, self.peak_columns)
        with np.errstate(divide="ignore", invalid="ignore"):  # a zero limit: inf or NaN
            return np.column_stack([q.values(dq, ddq) / q.limit for q in self.quantities])

    def interval_ratios(self, t: Array, q: Array, dq: Array) -> Array:
        """Peak over each step / limit, (N - 1, len(quantities)): the extremes of the cubic
        Hermite interpolant through (t, q, dq) (:mod:`mmplan.interpolant`, the meaning of a
        trajectory between its samples); 0 on a step of non-finite length."""
        if not self.quantities or len(t) < 2:
            return np.zeros((max(len(t) - 1, 0), len(self.quantities)))
        compiled = native_peaks.peaks()
        if compiled is not None:  # the same arithmetic in one C loop (:mod:`.native_peaks`)
            return compiled(t, q, dq, *self.peak_columns)
        return self.interval_ratios_numpy(t, q, dq)

    @cached_property
    def peak_columns(self) -> tuple[Array, Array, Array, Array]:
        """(kind: 0 velocity / 1 acceleration, first and second coordinate (-1: none),
        limit) of every quantity, for :mod:`.native_peaks`."""
        qs = self.quantities
        return (np.array([0 if qt.kind == "velocity" else 1 for qt in qs]),
                np.array([qt.index[0] for qt in qs]),
                np.array([qt.index[1] if len(qt.index) > 1 else -1 for qt in qs]),
                np.array([qt.limit for qt in qs], dtype=float))  # fmt: skip

    def interval_ratios_numpy(self, t: Array, q: Array, dq: Array) -> Array:
        """:meth:`interval_ratios` in NumPy (the specification; without a compiler)."""
        steps = interpolant.Steps(t, q, dq)
        out = np.empty((len(t) - 1, len(self.quantities)))
        for kind, peaks in (("velocity", steps.column_peak_velocities),
                            ("acceleration", steps.column_peak_accelerations)):  # fmt: skip
            single = [j for j, qt in enumerate(self.quantities)
                      if qt.kind == kind and len(qt.index) == 1]  # fmt: skip
            if single:  # every one-coordinate quantity of a kind in one call
                out[:, single] = peaks([self.quantities[j].index[0] for j in single])
        for j, qt in enumerate(self.quantities):
            if len(qt.index) > 1:
                out[:, j] = (steps.peak_velocity if qt.kind == "velocity"
                             else steps.peak_acceleration)(qt.index)  # fmt: skip
        limits = np.array([qt.limit for qt in self.quantities])
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.asarray(out / limits, dtype=float)

    def first_violation(
        self, t: Array, dq: Array, ddq: Array, q: Array | None = None,
        ratios: Array | None = None, peaks: Array | None = None,
    ) -> RateViolation | None:  # fmt: skip
        """The earliest sample at which a quantity exceeds its limit (beyond :data:`REL_TOL`,
        NaN counting as exceeding); when none and ``q`` is given, the earliest step on which
        the interpolant (:meth:`interval_ratios`) exceeds it beyond :data:`INTERVAL_TOL`. None
        when every limit holds. ``ratios``, ``peaks``: :meth:`ratios` and
        :meth:`interval_ratios` of these samples when the caller has them (not computed
        again)."""
        r = self.ratios(dq, ddq) if ratios is None else ratios
        found = _first(r, REL_TOL)
        if found is not None:
            k, j, count, worst = found
            qt = self.quantities[j]
            return RateViolation(qt, float(r[k, j] * qt.limit), float(t[k]),
                                 float(r[worst, j] * qt.limit), float(t[worst]), count)  # fmt: skip
        if q is None:
            return None
        m = self.interval_ratios(t, q, dq) if peaks is None else peaks
        found = _first(m, INTERVAL_TOL)
        if found is None:
            return None
        k, j, count, worst = found
        qt = self.quantities[j]
        return RateViolation(qt, float(m[k, j] * qt.limit), float(t[k]),
                             float(m[worst, j] * qt.limit), float(t[worst]), count,
                             float(t[k + 1]))  # fmt: skip

    def stretch(self, t: Array, q: Array, dq: Array, ddq: Array) -> float:
        """Smallest factor c >= 1 such that the uniform re-timing t -> c t (dq / c, ddq / c^2)
        keeps every limit at the samples and on the interpolant between them (which scales alike:
        the Hermite of the stretched samples is the stretched Hermite):
        max(1, velocity ratios, sqrt(acceleration ratios)); inf when a ratio is not finite
        (NaN, or a zero limit on a quantity that moves)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            both = np.vstack([self.ratios(dq, ddq), self.interval_ratios(t, q, dq)])
        if both.size == 0:
            return 1.0
        peak = np.max(np.where(np.isnan(both), np.inf, both), axis=0)
        if not np.all(np.isfinite(peak)):
            return math.inf
        velocity = np.array([qt.kind == "velocity" for qt in self.quantities])
        need = np.where(velocity, peak, np.sqrt(peak))
        return float(max(1.0, need.max()))


def _first(ratios: Array, tol: float) -> tuple[int, int, int, int] | None:
    """(row, column, count of bad rows in that column, its worst row) of the first entry of
    ``ratios`` above 1 + tol (NaN counts), None when there is none."""
    bad = ~(ratios <= 1.0 + tol)
    if not bad.any():
        return None
    k = int(np.argmax(bad.any(axis=1)))
    j = int(np.argmax(bad[k]))
    col = np.where(np.isnan(ratios[:, j]), np.inf, ratios[:, j])
    return k, j, int(bad[:, j].sum()), int(np.argmax(col))
