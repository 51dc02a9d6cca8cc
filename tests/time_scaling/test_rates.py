"""Velocity and acceleration limits in the time-optimal scaling (time_scaling/rates.py, topp.py).

Oracle: toppra 0.6.10 (TOPP-RA by its authors; seidel solver, first-order interpolation) on
a spline path with joint velocity, acceleration and torque limits. Measured (3 dof, grid
N = 101 / 201 / 401): durations 5.770369 / 5.751965 / 5.742392 s, ours shorter by 1.7e-6 /
3.0e-6 / 5.1e-6 s (toppra's solver keeps a small margin), x = sdot^2 within 2e-7.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mmplan.robot.limits import RateLimits
from mmplan.time_scaling.rates import POLYGON_SIDES, RateModel
from mmplan.time_scaling.retime import retime_path
from mmplan.time_scaling.topp import Scaling, time_optimal_scaling

VLIM = np.array([1.0, 1.5, 2.0])
ALIM = np.array([2.0, 3.0, 4.0])
TLIM = np.array([6.0, 8.0, 3.0])


def _spline() -> object:
    toppra = pytest.importorskip("toppra")
    rng = np.random.default_rng(1)
    way = np.cumsum(rng.normal(0.0, 1.0, (6, 3)), axis=0)
    return toppra.SplineInterpolator(np.linspace(0.0, 1.0, 6), way)


def _inv_dyn(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """A coupled 3-dof model: M(q) qdd + Coriolis-like terms + gravity."""
    M = np.array([[2.0 + np.cos(q[1]), 0.5, 0.0], [0.5, 1.0, 0.2], [0.0, 0.2, 0.5]])
    c = 0.3 * np.sin(q[1]) * np.array([qd[0] * qd[1], -qd[0] ** 2, qd[2] ** 2])
    g = np.array([0.0, 2.0 * np.cos(q[1]), 0.5 * np.sin(q[2])])
    return np.asarray(M @ qdd + c + g)


def _ours(path: object, grid: np.ndarray) -> Scaling:
    """Our scaling of ``path`` on ``grid``: torque rows, acceleration rows from RateModel,
    velocity limits as x_upper; rest at both ends (x_upper = 0 at the last sample)."""
    q, qs, qss = path(grid), path(grid, 1), path(grid, 2)  # type: ignore[operator]
    z = np.zeros(3)
    g = np.array([_inv_dyn(a, z, z) for a in q])
    beta = np.array([_inv_dyn(a, z, b) for a, b in zip(q, qs, strict=True)]) - g
    alpha = np.array([_inv_dyn(a, b, c) for a, b, c in zip(q, qs, qss, strict=True)]) - g
    names = ("a", "b", "c")
    rates = RateLimits(velocity=dict(zip(names, VLIM, strict=True)),
                       acceleration=dict(zip(names, ALIM, strict=True)))  # fmt: skip
    rr = RateModel.build(names, rates).path_rows(qs, qss)
    x_upper = rr.x_upper.copy()
    x_upper[-1] = 0.0  # rest at the end, as toppra's sd_end = 0
    return time_optimal_scaling(
        grid, np.hstack([alpha, rr.alpha]), np.hstack([beta, rr.beta]), np.hstack([g, rr.g]),
        np.concatenate([-TLIM, rr.lo]), np.concatenate([TLIM, rr.hi]), w_max=1e3,
        x_upper=x_upper,
    )  # fmt: skip


@pytest.mark.parametrize("N", [101, 201])
def test_same_duration_as_toppra_with_velocity_acceleration_and_torque_limits(N: int) -> None:
    """Same problem in toppra: durations within 1e-5 s (relative 2e-6), x within 1e-6."""
    toppra = pytest.importorskip("toppra")
    from toppra import algorithm, constraint

    path = _spline()
    grid = np.linspace(0.0, 1.0, N)
    interp = constraint.DiscretizationType.Interpolation
    cons = [
        constraint.JointVelocityConstraint(VLIM),
        constraint.JointAccelerationConstraint(ALIM, discretization_scheme=interp),
        constraint.JointTorqueConstraint(
            _inv_dyn, np.column_stack([-TLIM, TLIM]), np.zeros(3), discretization_scheme=interp
        ),
    ]
    _, sd, _ = algorithm.TOPPRA(cons, path, gridpoints=grid, solver_wrapper="seidel") \
        .compute_parameterization(0.0, 0.0)  # fmt: skip
    assert sd is not None, toppra.__version__
    t_toppra = float(np.sum(2.0 * np.diff(grid) / (sd[1:] + sd[:-1])))
    ours = _ours(path, grid)
    assert ours.feasible
    assert abs(ours.t[-1] - t_toppra) < 1e-5, (ours.t[-1], t_toppra)
    np.testing.assert_allclose(ours.x, sd**2, atol=1e-6)


def _dense_excess(path: object, grid: np.ndarray, sc: Scaling, sub: int = 10) -> dict[str, float]:
    """Largest relative excess over the limits between grid points: x linear in s on each
    interval (constant v), the exact spline q', q'' in between."""
    worst = {"velocity": 0.0, "acceleration": 0.0, "torque": 0.0}
    for i in range(len(grid) - 1):
        s = np.linspace(grid[i], grid[i + 1], sub + 1)
        x = np.maximum(sc.x[i] + sc.v[i] * (s - grid[i]), 0.0)
        q, qs, qss = path(s), path(s, 1), path(s, 2)  # type: ignore[operator]
        dq = np.sqrt(x)[:, None] * qs
        ddq = qss * x[:, None] + 0.5 * sc.v[i] * qs
        tau = np.array([_inv_dyn(a, b, c) for a, b, c in zip(q, dq, ddq, strict=True)])
        for key, val, lim in (("velocity", dq, VLIM), ("acceleration", ddq, ALIM),
                              ("torque", tau, TLIM)):  # fmt: skip
            worst[key] = max(worst[key], float((np.abs(val) / lim).max() - 1.0))
    return worst


def test_limits_between_grid_points_exceeded_by_at_most_the_stated_slack() -> None:
    """Dense resampling (10 points an interval): at N = 201 (about 29 ms an interval) the
    limits hold at the samples and are exceeded in between by at most 0.5 % (measured:
    velocity 0.18 %, acceleration 0.063 %, torque 0), shrinking like the square of the grid
    step (N = 401: velocity 0.046 %)."""
    pytest.importorskip("toppra")
    path = _spline()
    coarse = _dense_excess(path, np.linspace(0.0, 1.0, 201), _ours(path, np.linspace(0, 1, 201)))
    fine = _dense_excess(path, np.linspace(0.0, 1.0, 401), _ours(path, np.linspace(0, 1, 401)))
    assert max(coarse.values()) < 5e-3, coarse
    assert coarse["velocity"] > 0.0  # the interval interior is not checked by the passes
    assert fine["velocity"] < coarse["velocity"] / 3.0, (coarse, fine)


# --- platform speed and acceleration: exact and inner-polygon rows ---------------------------


def _planar_path(N: int = 400) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A figure-eight of the platform (x, y, theta) with an arm joint, sigma in [0, 10]."""
    s = np.linspace(0.0, 10.0, N)
    w = 2 * np.pi / 10.0
    q = np.column_stack([np.sin(w * s) * 2.0, np.sin(2 * w * s), 0.3 * s, np.cos(w * s)])
    qs = np.column_stack([2 * w * np.cos(w * s), 2 * w * np.cos(2 * w * s), 0.3 + 0 * s,
                          -w * np.sin(w * s)])  # fmt: skip
    qss = np.column_stack([-2 * w**2 * np.sin(w * s), -4 * w**2 * np.sin(2 * w * s), 0 * s,
                           -(w**2) * np.cos(w * s)])  # fmt: skip
    return s, q, qs, qss


def _scaled_planar(rates: RateLimits) -> tuple[RateModel, np.ndarray, np.ndarray, Scaling]:
    s, _, qs, qss = _planar_path()
    model = RateModel.build(("x", "y", "theta", "q1"), rates, planar=(0, 1, 2), linear=("x", "y"))
    rr = model.path_rows(qs, qss)
    sc = time_optimal_scaling(s, rr.alpha, rr.beta, rr.g, rr.lo, rr.hi, w_max=5.0,
                              x_upper=rr.x_upper)  # fmt: skip
    assert sc.feasible
    dq = np.sqrt(sc.x)[:, None] * qs
    ddq = sc.x[:, None] * qss + 0.5 * sc.v[:, None] * qs
    return model, dq, ddq, sc


def test_platform_speed_is_exact_at_the_samples() -> None:
    """|(dx, dy)| <= v at every sample, equal to it (to 1e-12) where it binds; the yaw rate and
    the joint velocity limit hold too."""
    rates = RateLimits(velocity={"q1": 0.5}, platform_speed=0.8, platform_yaw_rate=0.25,
                       platform_acceleration=0.5)  # fmt: skip
    model, dq, ddq, _ = _scaled_planar(rates)
    speed = np.hypot(dq[:, 0], dq[:, 1])
    assert speed.max() <= 0.8 * (1 + 1e-12)
    assert np.isclose(speed.max(), 0.8, rtol=1e-12, atol=0)
    assert np.abs(dq[:, 2]).max() <= 0.25 * (1 + 1e-12)
    assert np.abs(dq[:, 3]).max() <= 0.5 * (1 + 1e-12)
    assert model.first_violation(np.arange(len(dq)), dq, ddq) is None


def test_planar_acceleration_polygon_never_exceeds_the_norm() -> None:
    """Inner polygon: |(ddx, ddy)| <= a at every sample and, where it binds, at least
    a cos(pi / K) (what the polygon gives away at most)."""
    a = 0.5
    model, _, ddq, _ = _scaled_planar(RateLimits(platform_acceleration=a))
    acc = np.hypot(ddq[:, 0], ddq[:, 1])
    assert acc[:-1].max() <= a * (1 + 1e-9)
    assert acc[:-1].max() >= a * math.cos(math.pi / POLYGON_SIDES) * (1 - 1e-9)
    assert model.row_count == POLYGON_SIDES // 2


def test_acceleration_rows_hold_at_both_ends_of_every_interval() -> None:
    """|ddq| <= a with the v of interval i at sample i and at sample i + 1."""
    s, _, qs, qss = _planar_path()
    _, _, _, sc = _scaled_planar(RateLimits(acceleration={"x": 0.3, "q1": 0.2}))
    v = sc.v[:-1, None]
    for x, p, pp in ((sc.x[:-1, None], qs[:-1], qss[:-1]), (sc.x[1:, None], qs[1:], qss[1:])):
        ddq = x * pp + 0.5 * v * p
        assert np.abs(ddq[:, 0]).max() <= 0.3 * (1 + 1e-9)
        assert np.abs(ddq[:, 3]).max() <= 0.2 * (1 + 1e-9)
    assert len(s) == len(sc.x)


# --- verdicts on samples ---------------------------------------------------------------------


def test_first_violation_names_quantity_time_value_and_limit() -> None:
    model = RateModel.build(("x", "y", "theta", "q1"), RateLimits(velocity={"q1": 1.57}),
                            planar=(0, 1, 2))  # fmt: skip
    t = np.linspace(0.0, 2.0, 21)
    dq = np.zeros((21, 4))
    dq[12:15, 3] = [2.3, 2.5, 1.0]
    v = model.first_violation(t, dq, np.zeros_like(dq))
    assert v is not None
    assert v.message == (
        "joint q1 needs 2.3 rad/s at t = 1.20 s, limit 1.57 (2 samples, peak 2.5 at t = 1.30 s)"
    )
    dq[12:15, 3] = 1.57
    assert model.first_violation(t, dq, np.zeros_like(dq)) is None


def test_uniform_stretch_factor() -> None:
    """c = max(velocity ratio, sqrt(acceleration ratio)) and the stretched samples hold."""
    model = RateModel.build(("x", "y", "theta"), RateLimits(platform_speed=1.0,
                            platform_yaw_acceleration=2.0), planar=(0, 1, 2))  # fmt: skip
    t, q = np.array([0.0, 1.0]), np.array([[0.0, 0.0, 0.0], [1.5, 2.0, 0.0]])  # secant 2.5 m/s
    dq = np.array([[0.0, 0.0, 0.0], [3.0, 4.0, 0.0]])
    ddq = np.array([[0.0, 0.0, 32.0], [0.0, 0.0, 0.0]])
    c = model.stretch(t, q, dq, ddq)
    assert c == pytest.approx(5.0)
    assert model.first_violation(c * t, dq / c, ddq / c**2, q) is None
    ddq[0, 2] = 200.0
    assert model.stretch(t, q, dq, ddq) == pytest.approx(10.0)
    q[1, 0] = 30.0  # the interpolant between the samples bulges to 44.3 m/s and dominates
    s = np.linspace(0.0, 1.0, 100_001)[:, None]
    a = 6 * (q[1] - q[0]) - 4 * dq[0] - 2 * dq[1]  # Hermite accelerations at both ends (h = 1)
    b = -6 * (q[1] - q[0]) + 2 * dq[0] + 4 * dq[1]
    v = dq[0] + a * s + (b - a) * s**2 / 2
    bulge = float(np.hypot(v[:, 0], v[:, 1]).max())
    assert bulge == pytest.approx(44.31, abs=0.01) and bulge > np.hypot(30.0, 2.0)
    c = model.stretch(t, q, dq, ddq)
    assert c == pytest.approx(bulge, rel=1e-9)
    assert model.first_violation(c * t, dq / c, ddq / c**2, q) is None
    assert model.first_violation(0.99 * c * t, dq / (0.99 * c), ddq / c**2, q) is not None


def test_compiled_passes_match_the_reference_with_velocity_bounds_and_free_start() -> None:
    """Per-sample x bounds and x_start = None (the largest controllable x_0): compiled passes
    and the NumPy reference agree (same problems as tests/time_scaling/test_topp.py)."""
    from tests.time_scaling.test_topp import _assert_same, _random_problem

    rng = np.random.default_rng(21)
    free_starts = 0
    for N in [2, 3, 257, 40, 120, 300]:
        args = _random_problem(rng, N, int(rng.choice([1, 3])))
        sigma = args[0]
        x_upper = (0.2 + rng.uniform(0.0, 1.0)) * (1.5 + np.sin(3.0 * sigma + rng.uniform(0, 6)))
        x_upper[rng.random(N) < 0.1] = np.inf
        for start in (0.0, None):
            sc = _assert_same(args, x_upper=x_upper, x_start=start)
            assert np.all(sc.x <= np.minimum(x_upper, args[-1] ** 2) * (1 + 1e-12))
            free_starts += start is None and sc.feasible and sc.x[0] > 0
    assert free_starts >= 2


def _dense_interpolant_ratio(model: RateModel, t: np.ndarray, q: np.ndarray,
                             dq: np.ndarray) -> float:
    """Largest value / limit on the cubic Hermite through (t, q, dq), sampled 400 times a
    step (independent of mmplan.interpolant)."""
    s = np.linspace(0.0, 1.0, 401)[None, :, None]
    h = np.diff(t)[:, None, None]
    dp = np.diff(q, axis=0)[:, None] / h
    a = (6 * dp - 4 * dq[:-1, None] - 2 * dq[1:, None]) / h
    b = (-6 * dp + 2 * dq[:-1, None] + 4 * dq[1:, None]) / h
    vel = dq[:-1, None] + h * (a * s + (b - a) * s**2 / 2)
    acc = a + (b - a) * s
    worst = 0.0
    for qt in model.quantities:
        m = (vel if qt.kind == "velocity" else acc)[..., list(qt.index)]
        worst = max(worst, float(np.sqrt(np.sum(m * m, axis=2)).max() / qt.limit))
    return worst


def test_retime_holds_the_interpolant_between_samples_too() -> None:
    """On a coarse grid (20 samples for 10 s of figure-eight) the cubic Hermite interpolant of a
    scaling that holds the limits at the samples exceeds them between them (by 13 % on dense
    sampling); retime_path tightens those steps (5 rounds, 2.4 % longer) until it holds
    everywhere (dense sampling: within 1e-9), and the samples still hold."""
    s, q, qs, qss = _planar_path(20)
    rates = RateLimits(acceleration={"q1": 0.3}, platform_speed=0.8, platform_acceleration=0.4)
    model = RateModel.build(("x", "y", "theta", "q1"), rates, planar=(0, 1, 2), linear=("x", "y"))
    once = retime_path(s, q, qs, qss, model, w_max=5.0)
    rr = model.path_rows(qs, qss)
    plain = time_optimal_scaling(s, rr.alpha, rr.beta, rr.g, rr.lo, rr.hi, w_max=5.0,
                                 x_upper=rr.x_upper)  # fmt: skip
    dq = np.sqrt(plain.x)[:, None] * qs
    assert _dense_interpolant_ratio(model, plain.t, q, dq) > 1.1
    assert once.rounds > 1 and once.step_ratio <= 1.0
    t = once.scaling.t
    assert _dense_interpolant_ratio(model, t, q, once.dq) <= 1.0 + 1e-9
    assert model.first_violation(t, once.dq, once.ddq, q) is None
    assert t[-1] > plain.t[-1]  # at some cost in time
    # the peaks it returns are those of its result (the planner's final check reuses them)
    np.testing.assert_array_equal(once.peaks, model.interval_ratios(t, q, once.dq))


def test_first_violation_between_samples_names_the_step() -> None:
    """dq = 0 at both samples, q moved 1 rad in 1 s: the interpolant peaks at 1.5 rad/s."""
    model = RateModel.build(("x", "y", "theta", "q1"), RateLimits(velocity={"q1": 1.4}),
                            planar=(0, 1, 2))  # fmt: skip
    t = np.array([0.0, 1.0, 2.0])
    q = np.zeros((3, 4))
    q[2, 3] = 1.0
    v = model.first_violation(t, np.zeros((3, 4)), np.zeros((3, 4)), q)
    assert v is not None and v.message == (
        "joint q1 needs 1.5 rad/s between the samples at t = 1.00 and 2.00 s, limit 1.4")
    assert model.first_violation(t, np.zeros((3, 4)), np.zeros((3, 4))) is None  # samples only
    given = model.interval_ratios(t, q, np.zeros((3, 4)))
    assert model.first_violation(t, np.zeros((3, 4)), np.zeros((3, 4)), q, peaks=given) == v
    assert model.first_violation(t, np.zeros((3, 4)), np.zeros((3, 4)), q,
                                 peaks=0.0 * given) is None  # the peaks given are used
    assert model.first_violation(1.5 / 1.4 * t, np.zeros((3, 4)), np.zeros((3, 4)), q) is None


def test_free_start_takes_the_largest_controllable_rate() -> None:
    """x_start = None: x_0 is the top of the first controllable set (here the velocity bound
    0.7 at sample 0, then an acceleration row that lets x fall by at most 0.1 a unit of s);
    x_start = 0 starts from rest; x_start above the set is infeasible."""
    s = np.linspace(0.0, 1.0, 11)
    ones = np.ones((11, 1))
    rows = (0 * ones, 2 * ones, 0 * ones, np.array([-0.1]), np.array([0.1]))  # |v| <= 0.1
    x_upper = np.full(11, 0.7)
    free = time_optimal_scaling(s, *rows, w_max=2.0, x_upper=x_upper, x_start=None)
    assert free.feasible and free.x[0] == pytest.approx(0.7)
    rest = time_optimal_scaling(s, *rows, w_max=2.0, x_upper=x_upper)
    assert rest.feasible and rest.x[0] == 0.0 and rest.x[-1] == pytest.approx(0.1)
    assert not time_optimal_scaling(s, *rows, w_max=2.0, x_upper=x_upper, x_start=0.8).feasible


def test_retime_slows_the_whole_motion_when_the_rounds_run_out(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """With one round of local tightening allowed, the excess left between samples is removed
    by slowing the whole motion down (speeds / c, accelerations / c^2): the interpolant then
    holds everywhere. (A random youbot-3r scene once ended 'infeasible' 2e-6 over a wheel's
    acceleration after the 12 rounds, although the checker saw no violation.)"""
    import mmplan.time_scaling.retime as retime_module

    monkeypatch.setattr(retime_module, "MAX_ROUNDS", 1)
    s, q, qs, qss = _planar_path(20)
    rates = RateLimits(acceleration={"q1": 0.3}, platform_speed=0.8, platform_acceleration=0.4)
    model = RateModel.build(("x", "y", "theta", "q1"), rates, planar=(0, 1, 2), linear=("x", "y"))
    out = retime_module.retime_path(s, q, qs, qss, model, w_max=5.0)
    assert out.rounds == 1 and out.step_ratio <= 1.0
    t = out.scaling.t
    assert _dense_interpolant_ratio(model, t, q, out.dq) <= 1.0 + 1e-9
    assert model.first_violation(t, out.dq, out.ddq, q) is None
    np.testing.assert_array_equal(out.peaks, model.interval_ratios(t, q, out.dq))
