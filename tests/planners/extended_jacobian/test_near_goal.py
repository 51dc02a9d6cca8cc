"""Near-goal projection of the obstacle push (near_goal.py): closed-form properties."""

from __future__ import annotations

import itertools

import casadi as ca
import numpy as np
import pytest

from mmplan.planners.extended_jacobian import near_goal as nearpush
from mmplan.planners.extended_jacobian.generator import wheel_metric_inverse
from mmplan.robot.library import get_robot


def _projected(
    J: np.ndarray, A: np.ndarray, winv: np.ndarray, fp: np.ndarray, sigma: float
) -> np.ndarray:
    n = fp.size
    f, s = ca.SX.sym("f", n), ca.SX.sym("s")
    Js, As = ca.SX.sym("J", *J.shape), ca.SX.sym("A", *A.shape)
    out = nearpush.project_push(f, Js, As, winv, s)
    fn = ca.Function("proj", [f, Js, As, s], [out])
    return np.asarray(fn(fp, J, A, sigma), dtype=float).ravel()


@pytest.mark.parametrize("sigma", [0.0, 0.3, 1.0])
def test_projection_scales_the_task_part_and_stays_in_ker_a(sigma: float) -> None:
    """J fp' = (1 - sigma) J fp, A fp' = 0, and fp' - fp lies in the range of W^-1 Jc^T."""
    robot = get_robot("youbot-3r")
    rng = np.random.default_rng(3)
    q = np.array([0.3, -0.2, 0.4, 0.0, 0.0, 0.2, -0.4, 0.9])
    J, A = robot.jacobian(q), robot.pfaffian(q)
    winv = wheel_metric_inverse(robot)
    WA = winv[:, None] * A.T
    P = np.eye(robot.n) - WA @ np.linalg.solve(A @ WA, A)
    fp = P @ rng.normal(size=robot.n)  # a push in ker A, as generator.py builds it
    out = _projected(J, A, winv, fp, sigma)
    np.testing.assert_allclose(J @ out, (1.0 - sigma) * (J @ fp), atol=1e-9)
    np.testing.assert_allclose(A @ out, 0.0, atol=1e-9)
    Jc = np.vstack([J, A])
    coef, *_ = np.linalg.lstsq(winv[:, None] * Jc.T, out - fp, rcond=None)
    np.testing.assert_allclose(winv[:, None] * Jc.T @ coef, out - fp, atol=1e-9)
    if sigma == 1.0:  # the self-motion part is kept: fp' = (I - Jc^+ Jc) fp, wheel metric
        WJ = winv[:, None] * Jc.T
        expected = fp - WJ @ np.linalg.solve(Jc @ WJ, Jc @ fp)
        np.testing.assert_allclose(out, expected, atol=1e-9)


def test_fade_is_one_near_the_goal_and_zero_far_or_deep() -> None:
    """sigma = 1 within R_IN while K <= K_LO; 0 beyond R_OUT or from K_HI; monotone between."""
    e, k = ca.SX.sym("e"), ca.SX.sym("k")
    fade = ca.Function("fade", [e, k], [nearpush.fade(e, k)])

    def f(err: float, K: float) -> float:
        return float(fade(err, K))

    assert f(0.0, 0.0) == 1.0 and f(nearpush.R_IN, nearpush.K_LO) == 1.0
    assert f(nearpush.R_OUT, 0.0) == 0.0 and f(1.0, 0.0) == 0.0
    assert f(0.0, nearpush.K_HI) == 0.0 and f(0.0, 10.0) == 0.0
    errs = np.linspace(nearpush.R_IN, nearpush.R_OUT, 11)
    values = [f(x, 0.0) for x in errs]
    assert all(a >= b for a, b in itertools.pairwise(values))
    Ks = np.linspace(nearpush.K_LO, nearpush.K_HI, 11)
    values = [f(0.0, x) for x in Ks]
    assert all(a >= b for a, b in itertools.pairwise(values))


def test_arm_push_fades_towards_a_joint_limit_only() -> None:
    """Arm components pushing towards a limit vanish at it and are whole ``margin`` away;
    pushes away from the limit and platform components are untouched."""
    n, arm = 5, [3, 4]
    lo, hi = np.array([-1.0, -1.0]), np.array([1.0, 1.0])
    f, q = ca.SX.sym("f", n), ca.SX.sym("q", n)
    fn = ca.Function("lim", [f, q], [nearpush.fade_at_limits(f, q, arm, lo, hi, margin=0.2)])

    def out(push: list[float], qv: list[float]) -> np.ndarray:
        return np.asarray(fn(push, qv), dtype=float).ravel()

    push = [1.0, -2.0, 3.0, 0.5, -0.5]
    np.testing.assert_allclose(out(push, [0, 0, 0, 0.0, 0.0]), push)  # far from the limits
    np.testing.assert_allclose(out(push, [0, 0, 0, 1.0, -1.0]), [1.0, -2.0, 3.0, 0.0, 0.0])
    np.testing.assert_allclose(out(push, [0, 0, 0, 0.9, -0.9]), [1.0, -2.0, 3.0, 0.25, -0.25])
    np.testing.assert_allclose(out(push, [0, 0, 0, -1.0, 1.0]), push)  # pushed away from them
