"""The NumPy matrix exponential of the vibration study against closed forms and SciPy."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import scipy.linalg

from mmplan.analysis.expm import balance, expm


@pytest.mark.parametrize("hz", [0.5, 15.0, 200.0])
@pytest.mark.parametrize("h", [1e-5, 0.01, 0.05])
def test_undamped_oscillator_is_a_rotation(hz: float, h: float) -> None:
    """exp([[0, 1], [-w^2, 0]] h) = [[cos, sin/w], [-w sin, cos]] (w h): badly scaled for a
    stiff mode (entries 1 and w^2), which balancing must handle."""
    w = 2 * np.pi * hz
    exact = np.array([[np.cos(w * h), np.sin(w * h) / w], [-w * np.sin(w * h), np.cos(w * h)]])
    got = expm(np.array([[0.0, 1.0], [-w * w, 0.0]]) * h)
    assert np.abs(got - exact).max() <= 1e-11 * np.abs(exact).max()


def test_nilpotent_and_diagonal_closed_forms() -> None:
    shift = np.diag([2.0, 3.0, 5.0], k=1)  # N^4 = 0: exp = I + N + N^2/2 + N^3/6
    exact = np.eye(4) + shift + shift @ shift / 2 + shift @ shift @ shift / 6
    assert np.allclose(expm(shift), exact, rtol=1e-15, atol=1e-14)
    values = np.array([-30.0, -1.0, 0.0, 2.5])
    assert np.allclose(expm(np.diag(values)), np.diag(np.exp(values)), rtol=1e-12, atol=0)
    assert np.allclose(expm(np.zeros((3, 3))), np.eye(3), rtol=0, atol=1e-15)


def test_agrees_with_scipy(rng: np.random.Generator) -> None:
    worst = 0.0
    for _ in range(200):
        a = rng.normal(size=(4, 4)) * rng.uniform(1e-3, 20.0)
        ref = scipy.linalg.expm(a)
        worst = max(worst, float(np.abs(expm(a) - ref).max() / np.abs(ref).max()))
    w = 2 * np.pi * 15.0  # the study's augmented step matrix, damped
    for zeta in (0.0, 0.03, 1.0, 3.0):
        aug = np.zeros((4, 4))
        aug[:2, :2] = [[0.0, 1.0], [-w * w, -2 * zeta * w]]
        aug[1, 2], aug[2, 3] = -1.0, 1.0
        for h in (1e-4, 0.005, 0.02, 0.1):
            ref = scipy.linalg.expm(aug * h)
            worst = max(worst, float(np.abs(expm(aug * h) - ref).max() / np.abs(ref).max()))
    assert worst < 1e-10


def test_balance_is_a_similarity_by_powers_of_two() -> None:
    a = np.array([[0.0, 1.0], [-1e6, -3.0]])
    b, d = balance(a)
    assert np.array_equal(b, a * d[None, :] / d[:, None])  # D^-1 A D, exactly
    assert np.all(np.log2(d) == np.round(np.log2(d)))
    assert np.abs(b).max() < 1e4  # entries of w (1e3), not w^2 (1e6), side by side


def test_the_study_does_not_import_scipy_linalg() -> None:
    """`mmplan plan` runs the study; scipy.linalg took a quarter of a second to import."""
    code = ("import sys, mmplan.analysis.vibration\n"
            "print('scipy.linalg' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "False"


def test_a_stack_of_scaled_exponentials_equals_one_at_a_time() -> None:
    """expm_scaled(A, h) against expm(h A) for the vibration study's oscillator matrix over
    step lengths that need 0 to several squarings, and for a random matrix."""
    from mmplan.analysis.expm import expm, expm_scaled

    w, z = 2 * np.pi * 15.0, 0.05
    aug = np.zeros((4, 4))
    aug[:2, :2] = [[0.0, 1.0], [-(w**2), -2 * z * w]]
    aug[1, 2], aug[2, 3] = -1.0, 1.0
    rng = np.random.default_rng(2)
    for matrix in (aug, rng.normal(size=(4, 4))):
        hs = np.concatenate([[1e-6, 0.001, 0.02, 0.0275], rng.uniform(0.0, 0.5, 20)])
        stack = expm_scaled(matrix, hs)
        for h, got in zip(hs, stack, strict=True):
            want = expm(matrix * h)
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-13 * np.abs(want).max())
