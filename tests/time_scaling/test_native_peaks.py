"""The C loop of the interpolant's step peaks (:mod:`mmplan.time_scaling.native_peaks`) against
NumPy's (:meth:`mmplan.time_scaling.rates.RateModel.interval_ratios_numpy`, the
specification): every quantity kind (one coordinate and planar, velocity and acceleration),
steps of zero and non-finite length, NaN."""

from __future__ import annotations

import numpy as np
import pytest

from mmplan.compile import codegen
from mmplan.robot.limits import RateLimits
from mmplan.time_scaling import native_peaks
from mmplan.time_scaling.rates import RateModel


def _model() -> RateModel:
    rates = RateLimits(velocity={"q1": 0.5, "q2": 2.0}, acceleration={"q1": 3.0},
                       platform_speed=0.8, platform_yaw_rate=0.25,
                       platform_acceleration=0.5, platform_yaw_acceleration=1.5)  # fmt: skip
    return RateModel.build(("x", "y", "theta", "q1", "q2"), rates, planar=(0, 1, 2),
                           linear=("x", "y"))  # fmt: skip


@pytest.mark.skipif(codegen.compiler() is None, reason="needs a C compiler")
def test_c_peaks_equal_numpy(monkeypatch: pytest.MonkeyPatch) -> None:
    model = _model()
    kinds = {(qt.kind, len(qt.index)) for qt in model.quantities}
    assert kinds == {("velocity", 1), ("velocity", 2), ("acceleration", 1), ("acceleration", 2)}
    compiled = native_peaks.peaks()
    assert compiled is not None
    rng = np.random.default_rng(2)
    interior = 0
    speed = [qt.label for qt in model.quantities].index("platform speed")
    for trial in range(30):
        N = int(rng.integers(2, 400))
        t = np.cumsum(rng.uniform(0.001, 0.05, N))
        if trial % 3 == 0:
            t[rng.integers(0, N)] = t[max(0, int(rng.integers(0, N)) - 1)]  # a zero step
        if trial % 5 == 0:
            t[-1] = np.inf  # a step of infinite length (a scaling at rest)
        q = np.cumsum(rng.normal(0.0, 0.02, (N, 5)), axis=0)
        dq = rng.normal(0.0, 1.0, (N, 5))
        if trial % 7 == 0:
            dq[rng.integers(0, N), 0] = np.nan
        c = compiled(t, q, dq, *model.peak_columns)
        ref = model.interval_ratios_numpy(t, q, dq)
        np.testing.assert_allclose(c, ref, rtol=1e-14, atol=0.0)
        assert np.array_equal(np.isnan(c), np.isnan(ref))
        interior += int(np.sum(ref[:, speed] > np.maximum(np.hypot(dq[:-1, 0], dq[:-1, 1]),
                                                      np.hypot(dq[1:, 0], dq[1:, 1])) / 0.8))
    assert interior > 20  # planar speeds peaking inside a step were compared
    with monkeypatch.context() as m:  # the public method uses the C loop
        m.setattr(native_peaks, "peaks", lambda: None)
        ref = model.interval_ratios(t, q, dq)
    np.testing.assert_allclose(model.interval_ratios(t, q, dq), ref, rtol=1e-14, atol=0.0)
