r"""Vibration of a compliant arm tip driven by a planned motion ([Pajak]'s claim).

[Pajak] (section 6, Figs. 8-9; see docs/extended_jacobian.md) measures the arm-tip acceleration
of a youBot and finds 10-20 Hz vibrations excited by rapid changes of the platform velocity,
smaller with its smooth generator (eq. (17)). This module quantifies that claim in simulation,
as an analysis of a :class:`~mmplan.trajectory.Trajectory` (not a planner).

Model: a tip mass m on an isotropic 3-D spring-damper (stiffness k, damping c) attached to the
planned end-effector point p(t). With the deflection x = p_tip - p (3-vector),
natural frequency :math:`\omega = 2\pi f_n = \sqrt{k/m}` and damping ratio
:math:`\zeta = c / (2 \sqrt{k m})`, Newton's law :math:`m \ddot p_{tip} = -k x - c \dot x`
(gravity is constant: it only shifts the static deflection and is removed by superposition)
gives, per axis,

.. math::

    \ddot x + 2\zeta\omega \dot x + \omega^2 x = -a(t), \qquad a(t) = \ddot p(t),

    a_{tip} = a + \ddot x = -(2\zeta\omega \dot x + \omega^2 x),

where :math:`a(t) = J(q)\ddot q + \dot J(q, \dot q)\dot q` is the planned end-effector
acceleration (exact, from q, dq, ddq via CasADi; :math:`\dot J \dot q` is the derivative of
:math:`J \dot q` along :math:`\dot q`). :math:`\ddot x` is the *vibration acceleration* (what an
accelerometer on the tip reads beyond the planned rigid motion); :math:`a_{tip}` is the
absolute tip acceleration. The arm starts at rest (x = dx = 0).

Integration is exact for a piecewise-linear input (first-order hold between samples): with the
state :math:`s = [x; \dot x]`, :math:`\dot s = F s + G a`, :math:`F = [[0, 1], [-\omega^2,
-2\zeta\omega]]`, :math:`G = [0; -1]`, and on a step h the input
:math:`a(t_i + \tau) = a_i + \tau (a_{i+1} - a_i)/h`, the matrix exponential of the augmented
matrix :math:`[[F, G, 0], [0, 0, 1], [0, 0, 0]] h` gives
:math:`s_{i+1} = \Phi s_i + \Gamma_0 a_i + \Gamma_1 (a_{i+1} - a_i)/h` without truncation error.

Spectrum: one-sided amplitude of each axis of the vibration acceleration by the FFT over the
whole record (rectangular window, uniform grid; a non-uniform record is resampled linearly at
its smallest step): :math:`A_0 = |X_0|/N`, :math:`A_k = 2|X_k|/N` (0 < k < N/2),
:math:`A_{N/2} = |X_{N/2}|/N`; a sinusoid of amplitude a on a bin shows as A_k = a, and
Parseval reads :math:`\overline{x^2} = A_0^2 + \sum_{0<k<N/2} A_k^2/2 + A_{N/2}^2`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from mmplan.analysis.expm import expm_scaled
from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.robot.robot import Robot
from mmplan.trajectory import PlanResult, Trajectory

#: Defaults: a 15 Hz tip mode ([Pajak] Fig. 9 shows 10-20 Hz), 3 % damping.
FREQUENCY_HZ = 15.0
DAMPING_RATIO = 0.03


@dataclass(frozen=True)
class VibrationResult:
    """Tip vibration of a compliant arm driven by a trajectory.

    Attributes:
        t: Sample times [s], (N,) (the trajectory's, or its uniform resampling).
        ee_acceleration: Planned end-effector acceleration a(t) [m/s^2], (N, 3).
        deflection: Tip deflection x [m], (N, 3).
        vibration_acceleration: Deflection acceleration (vibration) [m/s^2], (N, 3).
        tip_acceleration: Absolute tip acceleration a + ddx [m/s^2], (N, 3).
        rms: RMS of |vibration acceleration| over the record [m/s^2].
        rms_first_second: The same over the first second of motion [m/s^2].
        peak: max_t |vibration acceleration| [m/s^2].
        tip_rms: RMS of |absolute tip acceleration| [m/s^2].
        tip_peak: max_t |absolute tip acceleration| [m/s^2].
        freq: Frequencies of the one-sided spectrum [Hz], (F,).
        amplitude: One-sided amplitude per axis of the vibration acceleration [m/s^2], (F, 3).
        frequency_hz: Natural frequency of the tip mode [Hz].
        damping_ratio: Its damping ratio.
    """

    t: Array
    ee_acceleration: Array
    deflection: Array
    vibration_acceleration: Array
    tip_acceleration: Array
    rms: float
    rms_first_second: float
    peak: float
    tip_rms: float
    tip_peak: float
    freq: Array
    amplitude: Array
    frequency_hz: float
    damping_ratio: float


def ee_acceleration(robot: Robot, q: Array, dq: Array, ddq: Array) -> Array:
    """Planned end-effector acceleration J(q) ddq + dJ/dt dq, (N, 3), from (N, n) samples."""
    natives = robot.compiled()  # the robot's compiled library, when on disk: no model built
    if natives is not None:  # laid out as the mapped call's (N, 3) view: the same sums below
        return np.ascontiguousarray(natives.many("ee_acceleration", q, dq, ddq).T).T
    fn = robot.functions["ee_acceleration"].map(len(q))
    return np.asarray(fn(q.T, dq.T, ddq.T), dtype=float).T


def simulate_oscillator(
    t: ArrayLike, drive: ArrayLike, frequency_hz: float, damping_ratio: float
) -> tuple[Array, Array, Array]:
    """Exact (first-order hold) response of ddx + 2 zeta w dx + w^2 x = -a(t) from rest.

    Args:
        t: Strictly increasing sample times [s], (N,).
        drive: Input a at the samples, (N,) or (N, d) (each column one axis).
        frequency_hz: Natural frequency f_n = w / (2 pi) [Hz].
        damping_ratio: zeta (0 <= zeta < 1 typical; any zeta >= 0 is exact).

    Returns:
        x, dx, ddx with the shape of ``drive``.
    """
    t = np.asarray(t, dtype=float)
    a = np.asarray(drive, dtype=float)
    flat = a.ndim == 1
    a2 = a[:, None] if flat else a
    w = 2.0 * np.pi * frequency_hz
    F = np.array([[0.0, 1.0], [-(w**2), -2.0 * damping_ratio * w]])
    aug = np.zeros((4, 4))
    aug[:2, :2], aug[1, 2], aug[2, 3] = F, -1.0, 1.0
    steps = np.diff(t)
    # one exponential per step length (to 1e-12 s), at the first step of that length
    _, first, which = np.unique(np.round(steps, 12), return_index=True, return_inverse=True)
    E = expm_scaled(aug, steps[first])[which.reshape(-1), :2]  # (N - 1, 2, 4)
    slope = np.diff(a2, axis=0) / steps[:, None]
    push = E[:, :, 2, None] * a2[:-1, None, :] + E[:, :, 3, None] * slope[:, None, :]
    A = E[:, :, :2]
    state = np.zeros((2, a2.shape[1]))
    x, dx = np.zeros_like(a2), np.zeros_like(a2)
    for i in range(len(steps)):  # the linear recursion itself, its inputs computed above
        state = A[i] @ state + push[i]
        x[i + 1], dx[i + 1] = state
    ddx = -a2 - 2.0 * damping_ratio * w * dx - w**2 * x
    if flat:
        return x[:, 0], dx[:, 0], ddx[:, 0]
    return x, dx, ddx


def amplitude_spectrum(signal: ArrayLike, dt: float) -> tuple[Array, Array]:
    """One-sided FFT amplitude spectrum (module docstring) of a uniformly sampled signal.

    Args:
        signal: (N,) or (N, d) samples, spacing ``dt``.
        dt: Sample spacing [s].

    Returns:
        freq (F,) [Hz] and amplitude (F,) or (F, d), F = N // 2 + 1.
    """
    values = np.asarray(signal, dtype=float)
    n = len(values)
    spec: Array = np.abs(np.fft.rfft(values, axis=0)) / n
    spec[1 : (n + 1) // 2] *= 2.0
    freq: Array = np.asarray(np.fft.rfftfreq(n, dt), dtype=float)
    return freq, spec


def _uniform(t: Array, values: Array) -> tuple[Array, Array]:
    steps = np.diff(t)
    if len(steps) == 0 or np.ptp(steps) <= 1e-9 * steps.max():
        return t, values
    h = float(steps.min())
    grid = t[0] + h * np.arange(int(np.floor((t[-1] - t[0]) / h + 1e-9)) + 1)
    return grid, np.column_stack([np.interp(grid, t, v) for v in values.T])


def vibration_study(
    trajectory: Trajectory,
    robot: Robot,
    *,
    frequency_hz: float = FREQUENCY_HZ,
    damping_ratio: float = DAMPING_RATIO,
    first_window: float = 1.0,
) -> VibrationResult:
    """Tip vibration of a compliant arm following ``trajectory`` (module docstring).

    Args:
        trajectory: Planned motion (q, dq, ddq of ``robot``'s coordinates).
        robot: The robot that the trajectory belongs to (for the end-effector acceleration).
        frequency_hz: Natural frequency of the tip mode [Hz] ([Pajak]: 10-20 Hz band).
        damping_ratio: Damping ratio zeta of the tip mode.
        first_window: Length of the initial window for ``rms_first_second`` [s].

    Raises:
        InputError: a non-positive frequency or window, a negative damping ratio, a
            trajectory of another robot or with fewer than 2 samples.
    """
    if not (np.isfinite(frequency_hz) and frequency_hz > 0):
        raise InputError("vibration.frequency_hz", f"must be > 0, got {frequency_hz}")
    if not (np.isfinite(damping_ratio) and damping_ratio >= 0):
        raise InputError("vibration.damping_ratio", f"must be >= 0, got {damping_ratio}")
    if not first_window > 0:
        raise InputError("vibration.first_window", f"must be > 0, got {first_window}")
    if tuple(trajectory.coordinates) != tuple(robot.coordinates):
        raise InputError("trajectory", f"coordinates do not match robot {robot.name!r}")
    if trajectory.samples < 2:
        raise InputError("trajectory", "needs at least 2 samples for a vibration study")
    acc = ee_acceleration(robot, trajectory.q, trajectory.dq, trajectory.ddq)
    t, acc = _uniform(trajectory.t, acc)
    x, _, ddx = simulate_oscillator(t, acc, frequency_hz, damping_ratio)
    tip = acc + ddx
    vib_norm, tip_norm = np.linalg.norm(ddx, axis=1), np.linalg.norm(tip, axis=1)
    first = t - t[0] < first_window
    freq, amp = amplitude_spectrum(ddx, float(t[1] - t[0]))
    return VibrationResult(
        t=t,
        ee_acceleration=acc,
        deflection=x,
        vibration_acceleration=ddx,
        tip_acceleration=tip,
        rms=float(np.sqrt(np.mean(vib_norm**2))),
        rms_first_second=float(np.sqrt(np.mean(vib_norm[first] ** 2))),
        peak=float(vib_norm.max()),
        tip_rms=float(np.sqrt(np.mean(tip_norm**2))),
        tip_peak=float(tip_norm.max()),
        freq=freq,
        amplitude=amp,
        frequency_hz=float(frequency_hz),
        damping_ratio=float(damping_ratio),
    )


def vibration_artifacts(result: VibrationResult) -> dict[str, Array]:
    """Arrays for artifacts.npz: the spectrum (axis name contains "freq") and the time series.

    Keys: ``vibration_freq_hz`` (F,), ``vibration_amplitude_x/_y/_z`` (F,) per axis,
    ``vibration_amplitude`` (F,) the root-sum-square over the axes; ``vibration_time_s`` (N,)
    with ``vibration_acceleration_norm`` (N,) |vibration acceleration|.
    """
    amp = result.amplitude
    out = {"vibration_freq_hz": np.asarray(result.freq, dtype=float)}
    for i, axis in enumerate("xyz"):
        out[f"vibration_amplitude_{axis}"] = np.asarray(amp[:, i], dtype=float)
    out["vibration_amplitude"] = np.sqrt(np.sum(amp**2, axis=1))
    out["vibration_time_s"] = np.asarray(result.t, dtype=float)
    out["vibration_acceleration_norm"] = np.linalg.norm(result.vibration_acceleration, axis=1)
    return out


def with_vibration(result: PlanResult, robot: Robot) -> PlanResult:
    """``result`` with the vibration study of its trajectory added (default tip mode).

    Adds :func:`vibration_artifacts` to ``artifacts`` (artifacts.npz, drawn by the report as
    a spectrum) and the scalars ``vibration_rms``, ``vibration_rms_first_second``,
    ``vibration_peak``, ``tip_acceleration_rms`` [m/s^2], ``vibration_frequency_hz`` and
    ``vibration_damping_ratio`` to ``info`` (summary.json). A trajectory with fewer than two
    samples is returned unchanged.
    """
    if result.trajectory.samples < 2:
        return result
    study = vibration_study(result.trajectory, robot)
    info = {
        **result.info,
        "vibration_rms": study.rms,
        "vibration_rms_first_second": study.rms_first_second,
        "vibration_peak": study.peak,
        "tip_acceleration_rms": study.tip_rms,
        "vibration_frequency_hz": study.frequency_hz,
        "vibration_damping_ratio": study.damping_ratio,
    }
    artifacts = {**result.artifacts, **vibration_artifacts(study)}
    return replace(result, info=info, artifacts=artifacts)
