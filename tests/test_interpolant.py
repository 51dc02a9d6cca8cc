"""The cubic Hermite interpolant between samples (mmplan.interpolant), against dense sampling of
an independent evaluation."""

from __future__ import annotations

import numpy as np
import pytest

from mmplan import interpolant


def _dense(t: np.ndarray, q: np.ndarray, dq: np.ndarray, per_step: int = 2001
           ) -> tuple[np.ndarray, np.ndarray]:
    """dq and ddq on a dense grid of every step, by the Hermite basis functions (not by the
    module's formulas), (steps, per_step, n) each."""
    s = np.linspace(0.0, 1.0, per_step)[None, :, None]
    h = np.diff(t)[:, None, None]
    q0, q1, v0, v1 = q[:-1, None], q[1:, None], dq[:-1, None], dq[1:, None]
    # derivatives of h00, h10, h01, h11 (q(s) = h00 q0 + h10 h v0 + h01 q1 + h11 h v1)
    vel = ((6 * s**2 - 6 * s) * q0 + (3 * s**2 - 4 * s + 1) * h * v0
           + (-6 * s**2 + 6 * s) * q1 + (3 * s**2 - 2 * s) * h * v1) / h
    acc = ((12 * s - 6) * q0 + (6 * s - 4) * h * v0 + (-12 * s + 6) * q1
           + (6 * s - 2) * h * v1) / h**2
    return vel, acc


def _random(rng: np.random.Generator, N: int = 40, n: int = 3
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.cumsum(rng.uniform(0.01, 0.1, N))
    return t, rng.normal(0.0, 1.0, (N, n)), rng.normal(0.0, 5.0, (N, n))


def test_a_cubic_is_its_own_interpolant() -> None:
    """Samples of q(t) = c0 + c1 t + c2 t^2 + c3 t^3: the interpolant is q itself."""
    c = np.array([[0.3, -1.0], [2.0, 0.5], [-1.5, 4.0], [0.7, -2.0]])
    t = np.array([0.0, 0.13, 0.2, 0.55, 1.0])

    def curve(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        x = x[:, None]
        return (c[0] + x * (c[1] + x * (c[2] + x * c[3])), c[1] + x * (2 * c[2] + 3 * x * c[3]),
                2 * c[2] + 6 * x * c[3])

    q, dq, _ = curve(t)
    times = np.linspace(0.0, 1.0, 37)
    for got, want in zip(interpolant.evaluate(t, q, dq, times), curve(times), strict=True):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_evaluation_hits_the_samples_and_matches_the_basis_functions() -> None:
    rng = np.random.default_rng(3)
    t, q, dq = _random(rng)
    pos, vel, acc = interpolant.evaluate(t, q, dq, t)
    np.testing.assert_allclose(pos, q, atol=1e-12)
    np.testing.assert_allclose(vel, dq, atol=1e-12)
    a, b = interpolant.step_accelerations(t, q, dq)
    np.testing.assert_allclose(acc[:-1], a, rtol=1e-12)  # the step starting at a sample
    np.testing.assert_allclose(acc[-1], b[-1], rtol=1e-12)
    v_dense, a_dense = _dense(t, q, dq)
    np.testing.assert_allclose(a, a_dense[:, 0], rtol=1e-9)
    np.testing.assert_allclose(b, a_dense[:, -1], rtol=1e-9)
    mid = 0.5 * (t[:-1] + t[1:])
    np.testing.assert_allclose(interpolant.evaluate(t, q, dq, mid)[1], v_dense[:, 1000],
                               rtol=1e-9, atol=1e-9)
    # the mean of ddq over a step is the difference of dq over its length
    np.testing.assert_allclose(0.5 * (a + b), np.diff(dq, axis=0) / np.diff(t)[:, None],
                               rtol=1e-9)


def test_peaks_are_the_extremes_of_dense_sampling() -> None:
    """Coordinates and planar norms: every step's peak equals the dense maximum (to the grid's
    resolution) and is never below it."""
    rng = np.random.default_rng(11)
    t, q, dq = _random(rng, N=200)
    v_dense, a_dense = _dense(t, q, dq)
    for index in ((0,), (2,), (0, 1)):
        cols = list(index)
        speed = np.sqrt(np.sum(v_dense[..., cols] ** 2, axis=2)).max(axis=1)
        accel = np.sqrt(np.sum(a_dense[..., cols] ** 2, axis=2)).max(axis=1)
        got_v = interpolant.peak_velocity(t, q, dq, index)
        got_a = interpolant.peak_acceleration(t, q, dq, index)
        assert np.all(got_v >= speed * (1 - 1e-12))
        np.testing.assert_allclose(got_v, speed, rtol=1e-6)
        np.testing.assert_allclose(got_a, accel, rtol=1e-12)
    # the vertex inside a step counts: dq = 0 at both ends, q moved forward
    bump = interpolant.peak_velocity(np.array([0.0, 1.0]), np.array([[0.0], [1.0]]),
                                     np.zeros((2, 1)), (0,))
    assert bump[0] == pytest.approx(1.5)  # 6 s (1 - s) at s = 1/2


def test_planar_speed_finds_a_maximum_between_sub_samples() -> None:
    """A speed peak between two sub-samples is found by the bisection, not just bracketed."""
    t = np.array([0.0, 1.0])
    s_peak = 0.5 / interpolant.SPEED_SUBSAMPLES + 0.03  # between the first two sub-samples
    # dq_x(s) = v0 + p1 s + p2 s^2 = 1 - k (s - s_peak)^2: largest |dq| 1 at s_peak
    k = 2.0
    grid = np.linspace(0.0, 1.0, interpolant.SPEED_SUBSAMPLES + 1)
    assert np.abs(1 - k * (grid - s_peak) ** 2).max() < 0.998  # the sub-samples miss it
    p2x, p1x, v0x = -k, 2 * k * s_peak, 1.0 - k * s_peak**2
    v1x = v0x + p1x + p2x
    # q1 - q0 = integral of dq over [0, 1]
    dqx = v0x + p1x / 2 + p2x / 3
    q = np.array([[0.0, 0.0], [dqx, 0.0]])
    dq = np.array([[v0x, 0.0], [v1x, 0.0]])
    a, _ = interpolant.step_accelerations(t, q, dq)
    assert a[0, 0] == pytest.approx(p1x)  # the data describe that quadratic
    assert interpolant.peak_velocity(t, q, dq, (0, 1))[0] == pytest.approx(1.0, rel=1e-12)


def test_steps_of_infinite_length_count_as_no_motion() -> None:
    t = np.array([0.0, 1.0, np.inf])
    q = np.array([[0.0], [1.0], [1.0]])
    dq = np.array([[0.0], [2.0], [0.0]])
    a, b = interpolant.step_accelerations(t, q, dq)
    assert a[1, 0] == 0.0 and b[1, 0] == 0.0
    assert interpolant.peak_velocity(t, q, dq, (0,))[1] == 2.0  # the ends only
