r"""A trajectory at a fixed control rate: one interpolant of the plan, sampled uniformly.

Planners write samples at uneven times (0.02-0.107 s after the extended-Jacobian time
scaling); a robot's controller runs at a fixed rate. :func:`resample` evaluates one
interpolant of the plan at :math:`t_0 + k/f` (rate :math:`f` in Hz), so that the exported
q, dq, ddq are exact derivatives of one curve, not held samples:

* **q, dq, ddq**: the plan's own continuous-time meaning, the cubic Hermite interpolant
  through :math:`(t_i, q_i, \dot q_i)` (:mod:`mmplan.interpolant`, docs/conventions.md
  "Between samples"): q and dq are its values, ddq its exact derivative (linear on each
  original step). It is C1; its acceleration may jump at an original sample, where the
  written ddq is that of the step starting there. The written ddq therefore differs from the
  plan's own ddq column at the plan's samples (a planner writes a one-sided value there, e.g.
  the time scaling's); what counts is that q, dq, ddq are derivatives of one curve, the one the
  planners hold their limits on. Since the exported samples are values of that curve, the
  exported ddq and dq stay within the peaks of the plan's interpolant, and every rate check of
  :mod:`mmplan.verify.rates` (columns, secants of q, least acceleration between samples)
  passes on the export whenever the plan's interpolant holds its limits, at any rate. (The
  quartic that also matched the plan's one-sided ddq overshot: on youbot3r-obstacles-torque
  at 100 Hz |ddq| of phi1 21.6 rad/s^2 against the limit 20 the plan held at its samples.)
* **Pfaffian constraint**: the interpolant satisfies :math:`A(q)\dot q = 0` only at the
  original samples (in between, about 1e-5 m/s on that plan, above the checker's 1e-6).
  :math:`\dot q` is therefore projected onto :math:`\ker A(q)`:
  :math:`\dot q \leftarrow \dot q - A^T (A A^T)^{-1} A \dot q`, which changes it by about
  that residual (measured: ``Resampled.dq_projection``); q and ddq are kept.
* **tau** (where the plan has effort columns): the efforts the exported motion needs, from
  the robot model, :math:`\tau = (N^T B)^{-1} N^T (M(q)\ddot q + c(q, \dot q))` of the
  exported q, dq, ddq ([PajakPajak] eq. (22)), as the checker requires of every plan. They
  differ from the plan's efforts at its samples where ddq does (the plan's one-sided
  acceleration against the interpolant's), and from a linear interpolation of the plan's
  efforts by up to 1.4 N m on youbot3r-obstacles-torque at 1000 Hz (arm joint q1 at
  t = 5.59 s, next to a switch of the time scaling); the torque limits hold on them there (the
  plan's efforts keep the 10 % safety zone).
* **u and extra columns** (where present): linear interpolation.
* **ee**: recomputed from q by the robot's forward kinematics.

mmplan's planners hold their rate limits on the interpolant, so their plans export with every
check passing. A plan from elsewhere whose interpolant breaks a limit between its samples
exports with the failures named (:func:`mmplan.io.export.export_plan`); so does one whose
interpolant slips enough that the projection changes dq by more than the checker grants it
(:data:`mmplan.verify.rates.DQ_TOL`, 1e-5).

The last step is shorter when the duration is not a multiple of :math:`1/f`: the export
ends exactly at the plan's final time (steps :math:`1/f`, the last one between
:math:`10^{-3}/f` and :math:`1.001/f`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mmplan import interpolant
from mmplan.arrays import Array
from mmplan.errors import InputError, require
from mmplan.robot import Robot
from mmplan.trajectory import Trajectory

#: Control rates accepted [Hz]: a robot controller runs at 1 Hz to a few kHz.
MIN_RATE_HZ = 1.0
MAX_RATE_HZ = 10_000.0
#: Samples a resampled plan may hold (10 kHz over 200 s).
MAX_SAMPLES = 2_000_000
DEFAULT_RATE_HZ = 100.0


def check_rate(rate: float, duration: float | None = None) -> float:
    """``rate`` as float when it is a usable control rate [Hz], else InputError (``--rate``)."""
    try:
        value = float(rate)
    except (TypeError, ValueError):
        raise InputError("--rate", f"{rate!r} is not a number (Hz)") from None
    if not math.isfinite(value) or not MIN_RATE_HZ <= value <= MAX_RATE_HZ:
        raise InputError("--rate", f"{rate!r} Hz is outside [{MIN_RATE_HZ:g}, {MAX_RATE_HZ:g}] Hz")
    if duration is not None and duration * value + 2 > MAX_SAMPLES:
        raise InputError("--rate", f"{value:g} Hz over {duration:.4g} s gives "
                         f"{int(duration * value) + 2} samples; at most {MAX_SAMPLES}")
    return value


def control_times(t0: float, t1: float, rate: float) -> Array:
    """Sample times t0 + k/rate before t1 (by more than 1e-3/rate), then t1 exactly, (M,)."""
    if t1 <= t0:
        return np.array([t0], dtype=float)
    count = math.ceil((t1 - t0) * rate - 1e-3)
    return np.append(t0 + np.arange(count) / rate, t1)


def _pfaffian_rows(robot: Robot, q: Array) -> Array:
    """A(q_k) for every sample, (M, h, n)."""
    M = q.shape[0]
    A = np.asarray(robot.functions["pfaffian"].map(M)(np.ascontiguousarray(q.T)), dtype=float)
    return np.ascontiguousarray(A.reshape(robot.h, M, robot.n).transpose(1, 0, 2))


def pfaffian_residuals(robot: Robot, q: Array, dq: Array) -> Array:
    """|A(q_k) dq_k|_2 per sample [m/s], (M,) (zeros for a robot without constraints)."""
    if robot.h == 0:
        return np.zeros(q.shape[0])
    return np.asarray(np.linalg.norm(np.einsum("khn,kn->kh", _pfaffian_rows(robot, q), dq),
                                     axis=1), dtype=float)


def project_to_constraints(robot: Robot, q: Array, dq: Array) -> Array:
    """dq - A^T (A A^T)^-1 A dq per sample: the nearest velocities with A(q) dq = 0, (M, n)."""
    if robot.h == 0:
        return dq.copy()
    A = _pfaffian_rows(robot, q)  # (M, h, n)
    r = np.einsum("khn,kn->kh", A, dq)
    lam = np.linalg.solve(A @ A.transpose(0, 2, 1), r[:, :, None])[:, :, 0]  # (M, h)
    return np.asarray(dq - np.einsum("khn,kh->kn", A, lam), dtype=float)


@dataclass(frozen=True)
class Resampled:
    """A trajectory at a fixed control rate, and what the interpolation left.

    Attributes:
        trajectory: The resampled trajectory.
        rate_hz: The control rate [Hz].
        source_samples: Samples of the original trajectory.
        pfaffian_interpolated: max_t |A(q) dq| of the interpolant before the projection [m/s].
        dq_projection: max_t |dq change| made by the projection (inf-norm; m/s or rad/s).
        pfaffian: max_t |A(q) dq| after the projection [m/s].
        source_step_min: The original trajectory's shortest step [s] (0 for one sample).
    """

    trajectory: Trajectory
    rate_hz: float
    source_samples: int
    pfaffian_interpolated: float
    dq_projection: float
    pfaffian: float
    source_step_min: float = 0.0

    def info(self) -> dict[str, Any]:
        """These numbers as a JSON-ready dict (summary.json ``planner_info.export``)."""
        return {"rate_hz": self.rate_hz, "source_samples": self.source_samples,
                "samples": self.trajectory.samples,
                "interpolation": "cubic Hermite (q, dq), ddq its derivative; tau from the model; "
                                 "u, extra linear",
                "pfaffian_residual_interpolated": self.pfaffian_interpolated,
                "dq_projection_max": self.dq_projection}


def resample_detailed(trajectory: Trajectory, rate: float, robot: Robot) -> Resampled:
    """:func:`resample` with the residuals it measured (see :class:`Resampled`).

    Raises:
        InputError: a bad rate, coordinates that are not the robot's, or non-finite values.
    """
    require(trajectory, Trajectory, "trajectory", "a Trajectory")
    require(robot, Robot, "robot", "a Robot")
    tr = trajectory
    if tr.coordinates != robot.coordinates:
        raise InputError("trajectory", f"coordinates {tr.coordinates} are not those of "
                         f"{robot.name} {robot.coordinates}")
    if not tr.is_finite():
        raise InputError("trajectory", "holds NaN or inf values; there is no motion to export")
    rate = check_rate(rate, tr.duration)
    times = control_times(float(tr.t[0]), float(tr.t[-1]), rate)
    if tr.samples == 1:
        q, dq, ddq = tr.q.copy(), tr.dq.copy(), tr.ddq.copy()
    else:
        q, dq, ddq = interpolant.evaluate(tr.t, tr.q, tr.dq, times)
        for k in (0, -1):  # exactly the plan's start and end (no rounding of h s)
            q[k], dq[k] = tr.q[k], tr.dq[k]
    before = pfaffian_residuals(robot, q, dq)
    projected = project_to_constraints(robot, q, dq)
    change = float(np.max(np.abs(projected - dq)))
    after = pfaffian_residuals(robot, q, projected)

    tau = None
    if tr.tau is not None:
        fn = robot.functions["tau"].map(len(times))
        tau = np.asarray(fn(q.T, projected.T, ddq.T), dtype=float).T  # (M, n_act)

    def linear(values: Array) -> Array:
        if tr.samples == 1:
            return values.copy()
        v2 = values.reshape(tr.samples, -1)
        out = np.column_stack([np.interp(times, tr.t, v2[:, j]) for j in range(v2.shape[1])])
        return out.reshape((len(times), *values.shape[1:]))

    ee = np.asarray(robot.functions["ee_position"].map(len(times))(np.ascontiguousarray(q.T)),
                    dtype=float).T
    out = Trajectory(coordinates=tr.coordinates, t=times, q=q, dq=projected, ddq=ddq, ee=ee,
                     actuators=robot.actuators if tau is not None else tr.actuators, tau=tau,
                     u=None if tr.u is None else linear(tr.u),
                     extra={k: linear(np.asarray(v, dtype=float)) for k, v in tr.extra.items()})
    step_min = float(np.min(np.diff(tr.t))) if tr.samples > 1 else 0.0
    return Resampled(out, rate, tr.samples, float(np.max(before)), change, float(np.max(after)),
                     step_min)


def resample(trajectory: Trajectory, rate: float, robot: Robot) -> Trajectory:
    """``trajectory`` sampled at ``rate`` Hz (see the module doc for the interpolation).

    Args:
        trajectory: A planned trajectory (t in seconds).
        rate: Control rate [Hz], in [MIN_RATE_HZ, MAX_RATE_HZ].
        robot: The robot it moves (forward kinematics, Pfaffian constraints).

    Raises:
        InputError: a bad rate, coordinates that are not the robot's, or non-finite values.
    """
    return resample_detailed(trajectory, rate, robot).trajectory
