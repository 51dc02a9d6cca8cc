"""The re-timing rounds in C (time_scaling/native_rounds.py) against the NumPy loop of
time_scaling/retime.py, its specification: every output the same to the bit, on paths that
need several rounds, that run out of rounds, with effort rows, from rest and from the largest
controllable rate, infeasible, and on the paper scenario's generator path."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import mmplan.time_scaling.retime as retime
from mmplan.robot.limits import RateLimits
from mmplan.time_scaling import passes
from mmplan.time_scaling.rates import RateModel
from tests.time_scaling.test_rates import _planar_path

pytestmark = pytest.mark.skipif(passes.kernels() is None, reason="no C compiler")

RATES = RateLimits(acceleration={"q1": 0.3}, platform_speed=0.8, platform_acceleration=0.4)


def _model(rates: RateLimits = RATES) -> RateModel:
    return RateModel.build(("x", "y", "theta", "q1"), rates, planar=(0, 1, 2), linear=("x", "y"))


def _both(monkeypatch: pytest.MonkeyPatch, *args: Any, **kwargs: Any) -> tuple[Any, Any]:
    """retime_path compiled (checked to run in C) and by the NumPy loop."""
    calls: list[int] = []
    compiled_rounds: Callable[..., Any] = retime._compiled_rounds

    def counted(*a: Any, **k: Any) -> Any:
        out = compiled_rounds(*a, **k)
        calls.append(out is not None)
        return out

    monkeypatch.setattr(retime, "_compiled_rounds", counted)
    compiled = retime.retime_path(*args, **kwargs)
    assert calls == [True]
    monkeypatch.setattr(retime, "_compiled_rounds", lambda *a, **k: None)
    plain = retime.retime_path(*args, **kwargs)
    monkeypatch.setattr(retime, "_compiled_rounds", compiled_rounds)
    return compiled, plain


def _bits(a: np.ndarray) -> np.ndarray:
    """The float64 array's bits (-0.0 and 0.0 differ, as NaN payloads do)."""
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


def _assert_same(a: retime.Retimed, b: retime.Retimed) -> None:
    for name in ("x", "v", "t"):
        np.testing.assert_array_equal(_bits(getattr(a.scaling, name)),
                                      _bits(getattr(b.scaling, name)))  # fmt: skip
    assert a.scaling.feasible == b.scaling.feasible
    assert a.scaling.first_empty == b.scaling.first_empty
    np.testing.assert_array_equal(_bits(a.dq), _bits(b.dq))
    np.testing.assert_array_equal(_bits(a.ddq), _bits(b.ddq))
    assert a.rounds == b.rounds
    assert _bits(np.array([a.step_ratio])) == _bits(np.array([b.step_ratio]))
    assert (a.peaks is None) == (b.peaks is None)
    if a.peaks is not None:
        np.testing.assert_array_equal(_bits(a.peaks), _bits(b.peaks))


@pytest.mark.parametrize("samples", [2, 3, 20, 57])
def test_rounds_equal_the_numpy_loop(monkeypatch: pytest.MonkeyPatch, samples: int) -> None:
    s, q, qs, qss = _planar_path(samples)
    a, b = _both(monkeypatch, s, q, qs, qss, _model(), w_max=5.0)
    _assert_same(a, b)
    if samples == 20:
        assert a.rounds > 1  # the interpolant needed tightening (test_rates.py)


@pytest.mark.parametrize("max_rounds", [1, 2, 3])
def test_rounds_run_out_as_the_numpy_loop(monkeypatch: pytest.MonkeyPatch, max_rounds: int) -> None:
    """The whole motion slowed down after the last round: the same numbers."""
    monkeypatch.setattr(retime, "MAX_ROUNDS", max_rounds)
    s, q, qs, qss = _planar_path(20)
    a, b = _both(monkeypatch, s, q, qs, qss, _model(), w_max=5.0)
    _assert_same(a, b)
    assert a.rounds == max_rounds and a.step_ratio <= 1.0


@pytest.mark.parametrize("x_start", [0.0, None])
def test_rounds_with_effort_rows(monkeypatch: pytest.MonkeyPatch, x_start: float | None) -> None:
    """Two effort-like rows (affine in x, v around a gravity term) besides the rate rows, with
    a velocity limit of one coordinate too, from rest and from the largest controllable rate."""
    s, q, qs, qss = _planar_path(60)
    rng = np.random.default_rng(3)
    N = len(s)
    rows = (rng.normal(0.0, 1.0, (N, 2)), rng.normal(0.0, 1.0, (N, 2)),
            rng.normal(0.0, 0.2, (N, 2)), np.array([-2.0, -np.inf]),
            np.array([2.0, 1.5]))  # fmt: skip
    rates = RateLimits(velocity={"q1": 0.5}, acceleration={"q1": 0.3}, platform_speed=0.8,
                       platform_acceleration=0.4, platform_yaw_rate=0.4)  # fmt: skip
    a, b = _both(monkeypatch, s, q, qs, qss, _model(rates), rows, w_max=5.0, x_start=x_start)
    _assert_same(a, b)
    assert a.scaling.feasible


def test_infeasible_rows(monkeypatch: pytest.MonkeyPatch) -> None:
    """An effort row whose gravity term lies outside its zone: no controllable set; no peaks."""
    s, q, qs, qss = _planar_path(30)
    N = len(s)
    rows = (np.ones((N, 1)), np.zeros((N, 1)), np.full((N, 1), 3.0), np.array([-1.0]),
            np.array([1.0]))  # fmt: skip
    a, b = _both(monkeypatch, s, q, qs, qss, _model(), rows, w_max=5.0)
    _assert_same(a, b)
    assert not a.scaling.feasible and a.peaks is None


def test_a_later_round_infeasible_has_no_peaks(monkeypatch: pytest.MonkeyPatch) -> None:
    """Two samples from x_start = 0.5: the first round is over the interpolant's limit, the
    second has no controllable start; no peaks then, as the NumPy loop (found by review: the
    C rounds returned the round before's)."""
    s = np.array([0.0, 3.6225295524487224])
    q = np.array([[0.0, 0.0, 0.0, 0.0],
                  [-0.5641412280462458, 1.503077212057703, 0.8233079318720116,
                   -2.384599186382957]])  # fmt: skip
    qs = np.array([[1.805760659966526, 5.463639781456045, 2.166179979083014, 4.145775527392245],
                   [-1.7243164063044667, 4.67161939060093, 1.4380111333300922,
                    2.2529180804884397]])  # fmt: skip
    qss = np.array([[-0.0, -0.0, -0.0, -0.0],
                    [0.5096321235512054, -5.340598517810732, -3.1877011997581217,
                     5.079182663189763]])  # fmt: skip
    model = _model(RateLimits(acceleration={"q1": 0.29541501751088595}))
    a, b = _both(monkeypatch, s, q, qs, qss, model, w_max=5.0, x_start=0.5)
    _assert_same(a, b)
    assert a.rounds == 2 and not a.scaling.feasible and a.peaks is None


def test_unbounded_rate_raises_as_before() -> None:
    """No velocity limit and no w_max: the NumPy loop's error, not a C result."""
    s, q, qs, qss = _planar_path(20)
    model = _model(RateLimits(acceleration={"q1": 0.3}))
    with pytest.raises(ValueError, match="unbounded"):
        retime.retime_path(s, q, qs, qss, model, w_max=np.inf)


def test_paper_scenario_path(monkeypatch: pytest.MonkeyPatch) -> None:
    """The youbot3r-obstacles generator path (607 samples, effort rows with the consistency
    column, several rounds with the stall test): the planner's own call, both ways."""
    import mmplan
    import mmplan.planners.extended_jacobian.time_scaling as ej_time_scaling

    seen: list[tuple[Any, Any]] = []
    original = ej_time_scaling.retime_path

    def grab(*a: Any, **k: Any) -> Any:
        seen.append((a, k))
        return original(*a, **k)

    monkeypatch.setattr(ej_time_scaling, "retime_path", grab)
    scenario = mmplan.load_scenario("youbot3r-obstacles-torque")
    mmplan.get_planner(scenario.method)().plan(scenario.build())
    assert seen
    args, kwargs = seen[0]
    a, b = _both(monkeypatch, *args, **kwargs)
    _assert_same(a, b)
    assert a.rounds >= 3


def test_rows_ratios_and_residuals_equal_numpy(monkeypatch: pytest.MonkeyPatch) -> None:
    """RateModel.path_rows and ratios and the step residuals in C (native_rounds.py) against
    their NumPy code, on a path with every kind of quantity and NaN, inf and zero entries."""
    from mmplan.planners.extended_jacobian.time_scaling import step_residuals
    from mmplan.time_scaling import native

    assert native.kernels() is not None
    rates = RateLimits(velocity={"q1": 0.5, "theta": 0.7}, acceleration={"q1": 0.3, "x": 2.0},
                       platform_speed=0.8, platform_acceleration=0.4, platform_yaw_rate=0.4,
                       platform_yaw_acceleration=0.9)  # fmt: skip
    model = _model(rates)
    _, q, qs, qss = _planar_path(50)
    qs[3, 0], qs[4, 1], qss[5, 3] = np.nan, np.inf, -np.inf
    qs[6] = 0.0
    t = np.cumsum(np.full(50, 0.1))
    t[7] = t[8]  # a zero step
    compiled = (model.path_rows(qs, qss), model.ratios(qs, qss), step_residuals(t, q, qs))
    monkeypatch.setattr(native, "loaded", lambda: None)
    with np.errstate(all="ignore"):  # inf times a polygon side's zero sine
        plain = (model.path_rows(qs, qss), model.ratios(qs, qss), step_residuals(t, q, qs))
    for name in ("x_upper", "alpha", "beta", "g", "lo", "hi"):
        np.testing.assert_array_equal(getattr(compiled[0], name), getattr(plain[0], name))
    assert (compiled[0].labels, compiled[0].quantity) == (plain[0].labels, plain[0].quantity)
    np.testing.assert_array_equal(compiled[1], plain[1])
    np.testing.assert_array_equal(compiled[2], plain[2])


@pytest.mark.parametrize("seed", range(40))
def test_random_paths_equal_the_numpy_loop(monkeypatch: pytest.MonkeyPatch, seed: int) -> None:
    """Random sine paths, limits, effort rows and starts (1-12 rounds; a later round's
    forward pass runs only from the first changed sample until x meets the last round's)."""
    rng = np.random.default_rng(seed)
    N = int(rng.integers(5, 300))
    s = np.sort(rng.uniform(0.0, 10.0, N))
    s[0] = 0.0
    freq, amp = rng.uniform(0.2, 2.0, 4), rng.uniform(0.3, 3.0, 4)
    q = np.column_stack([a * np.sin(f * s) for a, f in zip(amp, freq, strict=True)])
    qs = np.column_stack([a * f * np.cos(f * s) for a, f in zip(amp, freq, strict=True)])
    qss = np.column_stack([-a * f * f * np.sin(f * s) for a, f in zip(amp, freq, strict=True)])
    rates = RateLimits(velocity={"q1": rng.uniform(0.3, 2.0)},
                       acceleration={"q1": rng.uniform(0.1, 2.0), "theta": rng.uniform(0.1, 2.0)},
                       platform_speed=rng.uniform(0.3, 2.0),
                       platform_acceleration=rng.uniform(0.1, 2.0))  # fmt: skip
    rows = None
    if seed % 2:
        rows = (rng.normal(0.0, 1.0, (N, 2)), rng.normal(0.0, 1.0, (N, 2)),
                rng.normal(0.0, 0.1, (N, 2)), np.array([-2.0, -3.0]),
                np.array([2.0, 3.0]))  # fmt: skip
    start = None if seed % 3 == 0 else 0.0
    a, b = _both(monkeypatch, s, q, qs, qss, _model(rates), rows, w_max=5.0, x_start=start)
    _assert_same(a, b)
