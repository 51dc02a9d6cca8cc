"""Vibration of a compliant tip (mmplan.analysis.vibration): closed forms, references, [Pajak]'s
claim."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from mmplan.analysis.vibration import (
    amplitude_spectrum,
    ee_acceleration,
    simulate_oscillator,
    vibration_artifacts,
    vibration_study,
    with_vibration,
)
from mmplan.errors import InputError
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.robot.library import get_robot
from mmplan.robot.robot import Robot
from mmplan.scenario.loader import load_scenario
from mmplan.trajectory import PlanResult, Status, Trajectory


def test_step_response_matches_closed_form() -> None:
    """Constant drive a0 from rest vs x = -(a0/w^2)(1 - e^{-zwt}(cos wd t + z/zd sin wd t)).

    zd = sqrt(1 - z^2), wd = w zd; dx = -(a0/wd) e^{-zwt} sin wd t.
    """
    f, z, a0 = 12.0, 0.03, 2.5
    t = np.linspace(0.0, 2.0, 1001)
    x, dx, ddx = simulate_oscillator(t, np.full_like(t, a0), f, z)
    w = 2 * np.pi * f
    wd = w * np.sqrt(1 - z**2)
    env = np.exp(-z * w * t)
    x_ref = -(a0 / w**2) * (1 - env * (np.cos(wd * t) + z / np.sqrt(1 - z**2) * np.sin(wd * t)))
    dx_ref = -(a0 / wd) * env * np.sin(wd * t)
    assert np.max(np.abs(x - x_ref)) < 1e-9 * a0 / w**2
    assert np.max(np.abs(dx - dx_ref)) < 1e-9 * a0 / wd
    # ddx = -a0 - 2 z w dx - w^2 x: jumps to -a0 at t = 0+, decays to 0.
    assert ddx[0] == pytest.approx(-a0)
    assert abs(ddx[-1]) < a0 * np.exp(-z * w * 2.0) * 1.1


def _fit_amplitude(t: np.ndarray, y: np.ndarray, w: float) -> float:
    basis = np.column_stack([np.sin(w * t), np.cos(w * t)])
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    return float(np.hypot(*coef))


@pytest.mark.parametrize("z", [0.02, 0.05])
def test_sine_at_resonance_matches_analytic_amplitude(z: float) -> None:
    """Drive A sin(w t) at w = w_n: steady |ddx| = A/(2 z), |a_tip| = A sqrt(1 + 1/(4 z^2)).

    Transfer functions ddx/a = -s^2/(s^2 + 2zws + w^2) and a_tip/a = -(2zws + w^2)/(...).
    """
    f, A = 15.0, 0.7
    w = 2 * np.pi * f
    t = np.arange(0.0, 5.0 + 1e-12, 2e-4)
    drive = A * np.sin(w * t)
    _, _, ddx = simulate_oscillator(t, drive, f, z)
    last = t > 4.0  # transient e^{-z w 4} < 7e-4 of the steady amplitude for z = 0.02
    amp = _fit_amplitude(t[last], ddx[last], w)
    tip = _fit_amplitude(t[last], drive[last] + ddx[last], w)
    transient = np.exp(-z * w * 4.0)
    assert amp == pytest.approx(A / (2 * z), rel=2e-4 + transient)
    assert tip == pytest.approx(A * np.sqrt(1 + 1 / (4 * z**2)), rel=2e-4 + transient)


def test_matches_scipy_lsim_on_random_input(rng: np.random.Generator) -> None:
    """Independent reference: scipy.signal.lsim (linear interpolation of the input)."""
    f, z = 18.0, 0.04
    w = 2 * np.pi * f
    t = np.arange(800) * 2.5e-3
    drive = rng.normal(size=(800, 3))
    x, dx, ddx = simulate_oscillator(t, drive, f, z)
    system = scipy.signal.StateSpace(
        [[0.0, 1.0], [-(w**2), -2 * z * w]], [[0.0], [-1.0]], np.eye(2), np.zeros((2, 1))
    )
    for k in range(3):
        _, _, states = scipy.signal.lsim(system, drive[:, k], t)
        scale = np.abs(states).max(axis=0)
        assert np.max(np.abs(x[:, k] - states[:, 0])) < 1e-8 * scale[0]
        assert np.max(np.abs(dx[:, k] - states[:, 1])) < 1e-8 * scale[1]
    assert np.allclose(ddx, -drive - 2 * z * w * dx - w**2 * x)


def test_nonuniform_steps_are_exact(rng: np.random.Generator) -> None:
    """A piecewise-linear drive sampled on a finer, irregular grid gives the same response."""
    coarse = np.arange(201) * 5e-3
    drive = rng.normal(size=201)
    fine = np.unique(np.concatenate([coarse, rng.uniform(0.0, coarse[-1], 500)]))
    x_c, dx_c, _ = simulate_oscillator(coarse, drive, 14.0, 0.03)
    x_f, dx_f, _ = simulate_oscillator(fine, np.interp(fine, coarse, drive), 14.0, 0.03)
    on_coarse = np.searchsorted(fine, coarse)
    assert np.allclose(x_f[on_coarse], x_c, rtol=0, atol=1e-10 * np.abs(x_c).max())
    assert np.allclose(dx_f[on_coarse], dx_c, rtol=0, atol=1e-10 * np.abs(dx_c).max())


@pytest.mark.parametrize("n", [1000, 1001])
def test_parseval_and_bin_amplitude(rng: np.random.Generator, n: int) -> None:
    """Mean square = A0^2 + sum A_k^2 / 2 (+ A_{N/2}^2); a bin sinusoid shows its amplitude."""
    dt = 0.005
    signal = rng.normal(size=(n, 3)) + 0.3
    freq, amp = amplitude_spectrum(signal, dt)
    assert freq.shape == (n // 2 + 1,) and freq[1] == pytest.approx(1 / (n * dt))
    power = amp[0] ** 2 + np.sum(amp[1:] ** 2, axis=0) / 2
    if n % 2 == 0:
        power += amp[-1] ** 2 / 2  # the Nyquist bin is not doubled
    assert np.allclose(power, np.mean(signal**2, axis=0), rtol=1e-12)
    k, a = 37, 1.3
    t = dt * np.arange(n)
    _, amp1 = amplitude_spectrum(a * np.cos(2 * np.pi * freq[k] * t + 0.4), dt)
    assert amp1[k] == pytest.approx(a, rel=1e-12)
    assert np.delete(amp1, k).max() < 1e-12


def test_ee_acceleration_matches_finite_differences() -> None:
    """J ddq + dJ dq equals the second time derivative of FK along a smooth q(t)."""
    robot = get_robot("youbot-4r")
    n = robot.n
    phase = np.linspace(0.3, 2.0, n)
    amp = np.linspace(0.2, 0.5, n)

    def q_of(t: np.ndarray) -> np.ndarray:
        return amp * np.sin(1.7 * t[:, None] + phase)

    t = np.array([0.3, 1.1, 2.4])
    q = q_of(t)
    dq = amp * 1.7 * np.cos(1.7 * t[:, None] + phase)
    ddq = -amp * 1.7**2 * np.sin(1.7 * t[:, None] + phase)
    acc = ee_acceleration(robot, q, dq, ddq)
    h = 1e-4
    for i, ti in enumerate(t):
        p = [robot.ee_position(q_of(np.array([ti + s * h]))[0]) for s in (-1, 0, 1)]
        fd = (p[0] - 2 * p[1] + p[2]) / h**2
        assert np.allclose(acc[i], fd, atol=1e-5)


def _plan(name: str) -> tuple[Trajectory, Robot]:
    problem = load_scenario(name).build()
    result = ExtendedJacobian().plan(problem)
    assert result.reached, result.message
    return result.trajectory, problem.robot


@pytest.fixture(scope="module")
def pajak_plans() -> dict[str, tuple[Trajectory, Robot]]:
    """The two [Pajak] plans (plain generator eq. (12), smooth eq. (17)), as the paper ran them:
    without the youBot's velocity and acceleration limits (with them the plain plan is
    re-timed and its t = 0 acceleration step changes)."""
    return {name: _plan(name)
            for name in ("youbot4r-reach-unlimited", "youbot4r-reach-smooth-unlimited")}


def test_smooth_generator_shakes_the_tip_less(
    pajak_plans: dict[str, tuple[Trajectory, Robot]],
) -> None:
    """[Pajak]'s claim, as measured: the smooth start removes the 10-20 Hz excitation.

    Measured (15 Hz, zeta 0.03): vibration RMS 0.30 vs 0.0007 m/s^2, first second 0.9 vs 0.0015,
    peak 2.9 (the t = 0 acceleration step) vs 0.004; absolute tip RMS 0.53 vs 0.18.
    """
    for f, z in ((10.0, 0.02), (15.0, 0.03), (20.0, 0.05)):
        plain, smooth = (
            vibration_study(tr, robot, frequency_hz=f, damping_ratio=z)
            for tr, robot in pajak_plans.values()
        )
        assert smooth.rms < 0.05 * plain.rms
        assert smooth.rms_first_second < 0.05 * plain.rms_first_second
        assert smooth.peak < 0.05 * plain.peak
        assert smooth.tip_rms < 0.5 * plain.tip_rms
        # The plain generator steps the end-effector acceleration at t = 0: the tip's
        # vibration acceleration jumps to minus that step.
        step = np.linalg.norm(plain.ee_acceleration[0])
        assert step > 1.0
        assert plain.peak == pytest.approx(step, rel=0.05)
        in_band = [r.amplitude[(r.freq > 10) & (r.freq < 20)].max() for r in (smooth, plain)]
        assert in_band[0] < 0.05 * in_band[1]


def test_artifacts_and_input_errors(pajak_plans: dict[str, tuple[Trajectory, Robot]]) -> None:
    """Artifacts: a freq axis with equally long amplitudes; bad parameters are InputError."""
    tr, robot = pajak_plans["youbot4r-reach-smooth-unlimited"]
    result = vibration_study(tr, robot)
    arts = vibration_artifacts(result)
    freq = arts["vibration_freq_hz"]
    for key in ("vibration_amplitude", "vibration_amplitude_x", "vibration_amplitude_z"):
        assert arts[key].shape == freq.shape
    assert arts["vibration_time_s"].shape == arts["vibration_acceleration_norm"].shape
    assert all(np.isfinite(v).all() for v in arts.values())
    assert freq[-1] == pytest.approx(0.5 / (tr.t[1] - tr.t[0]))
    with pytest.raises(InputError, match="frequency_hz"):
        vibration_study(tr, robot, frequency_hz=0.0)
    with pytest.raises(InputError, match="damping_ratio"):
        vibration_study(tr, robot, damping_ratio=-0.1)
    with pytest.raises(InputError, match="trajectory"):
        vibration_study(tr, get_robot("youbot-3r"))


def test_with_vibration_adds_artifacts_and_scalars() -> None:
    """The hook for the plan output: artifacts and info scalars, the rest unchanged."""
    problem = load_scenario("youbot4r-reach-smooth").build()
    t = np.arange(0.0, 2.0, 0.005)
    q = np.tile(problem.start, (len(t), 1))
    q[:, 0] = 0.1 * t**2  # platform x; wheels do not matter for the end effector
    dq, ddq = np.zeros_like(q), np.zeros_like(q)
    dq[:, 0], ddq[:, 0] = 0.2 * t, 0.2
    ee = np.array([problem.robot.ee_position(qi) for qi in q])
    tr = Trajectory(problem.robot.coordinates, t, q, dq, ddq, ee)
    base = PlanResult(Status.REACHED, tr, "test", info={"k": 1}, artifacts={"a": np.ones(2)})
    out = with_vibration(base, problem.robot)
    assert out.info["k"] == 1 and "a" in out.artifacts and out.trajectory is tr
    assert "vibration_freq_hz" in out.artifacts
    # A 0.2 m/s^2 step in x from rest: deflection acceleration starts at -0.2 (the step).
    assert out.info["vibration_peak"] == pytest.approx(0.2, rel=1e-9)


def test_analyse_adds_the_vibration_study_the_settings_ask_for() -> None:
    """The planner itself adds no study; :func:`mmplan.analysis.analyse` adds the vibration
    measures and spectrum when the settings ask for them (extended Jacobian, default on)."""
    import dataclasses

    from mmplan.analysis import analyse
    from mmplan.planners import get_planner
    from mmplan.scenario.loader import load_scenario

    scenario = load_scenario("youbot4r-reach-smooth")
    problem = scenario.build()
    planned = get_planner(scenario.method)().plan(problem)
    assert "vibration_rms" not in planned.info and not planned.artifacts
    off = dataclasses.replace(
        problem, settings=problem.settings.model_copy(update={"vibration": False})
    )
    assert analyse(planned, off) is planned
    result = analyse(planned, problem)
    assert result.trajectory is planned.trajectory and result.status is planned.status
    assert result.info["vibration_rms"] > 0
    assert result.info["vibration_rms"] < result.info["tip_acceleration_rms"]
    assert (
        result.artifacts["vibration_freq_hz"].shape == result.artifacts["vibration_amplitude"].shape
    )
