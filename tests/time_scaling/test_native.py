"""The C loops of the time-scaling passes (:mod:`mmplan.time_scaling.native`) against their
specification, the CasADi step functions of :mod:`mmplan.time_scaling.passes` run on the
virtual machine: the same K_lo, K_hi, empty flags and x to the bit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mmplan.compile import codegen, threads
from mmplan.time_scaling import native
from mmplan.time_scaling import passes as topp_passes
from mmplan.time_scaling.passes import BIG

from .test_topp import _assert_same, _random_problem


def _vm(monkeypatch: pytest.MonkeyPatch, *args: object, forward: bool) -> object:
    """A pass on the VM (the C loops switched off)."""
    with monkeypatch.context() as m:
        m.setattr(native, "kernels", lambda: None)
        return (topp_passes.forward if forward else topp_passes.backward)(*args)


@pytest.mark.skipif(codegen.compiler() is None, reason="needs a C compiler")
def test_c_loops_equal_the_casadi_steps_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    """40 seeded problems, 3-200 samples (several VM chunks), 1-15 rows (straight-line and
    mapped backward steps on the VM), infinite limits, infeasible zones, a restart at m."""
    kernels = native.kernels()
    assert kernels is not None
    monkeypatch.setattr(threads, "idle_core", lambda: True)  # split whatever the load
    rng = np.random.default_rng(7)
    empty = 0
    for _ in range(40):
        N, n = int(rng.integers(3, 200)), int(rng.choice([1, 2, 5, 9, 15]))
        sigma, alpha, beta, g, lo, hi, w_max = _random_problem(rng, N, n)
        zone = np.concatenate([np.where(np.isfinite(lo), lo, -BIG),
                               np.where(np.isfinite(hi), hi, BIG)])  # fmt: skip
        x_up = np.minimum(np.full(N, w_max**2), rng.uniform(0.2, 3.0, N))
        last = (0.0, float(rng.uniform(0.0, 1.0)))
        top = int(rng.integers(0, N - 1))
        data = (alpha, beta, g, sigma, x_up, zone)
        vm_sets = _vm(monkeypatch, *data, last, top, forward=False)
        for split in (True, False):  # two threads from 64 intervals, and one
            kernels.split = split
            c_sets = kernels.backward(*data, last, top)
            for c, vm in zip(c_sets, vm_sets, strict=True):  # type: ignore[call-overload]
                np.testing.assert_array_equal(c, vm)
        kernels.split = True
        empty += bool(np.any(c_sets[2] > 0.5))
        full = kernels.backward(*data, last, N - 2)
        K_lo, K_hi = np.append(full[0], last[0]), np.append(full[1], last[1])
        x0 = float(rng.uniform(0.0, 0.5))
        np.testing.assert_array_equal(kernels.forward(*data, K_lo, K_hi, x0),
                                      _vm(monkeypatch, *data, K_lo, K_hi, x0, forward=True))
    assert empty >= 5  # infeasible sets were compared too


@pytest.mark.skipif(codegen.compiler() is None, reason="needs a C compiler")
def test_signed_zeros_follow_casadi(monkeypatch: pytest.MonkeyPatch) -> None:
    """Rows with alpha = 0 and beta < 0 (a planar acceleration polygon where the path starts
    straight): the flipped slab's a is -0.0 in plain C but +0.0 in CasADi's if_else, which
    flips the sign of a division by a zero det. Without the +0.0 of ``sel`` the C backward
    pass made the first set empty (measured) where the specification does not."""
    kernels = native.kernels()
    assert kernels is not None
    N, m = 50, 6
    sigma = np.linspace(0.0, 1.0, N)
    angles = np.pi * np.arange(m) / m
    alpha = np.zeros((N, m))
    alpha[1:] = 0.3 * np.cos(angles)[None, :] * np.linspace(0.0, 1.0, N - 1)[:, None]
    beta = np.tile(-np.cos(angles + 0.4), (N, 1))  # some negative: flipped slabs
    zone = np.concatenate([np.full(m, -0.5), np.full(m, 0.5)])
    data = (alpha, beta, np.zeros((N, m)), sigma, np.full(N, 1.0), zone)
    c_sets = kernels.backward(*data, (0.0, 0.2), N - 2)
    vm_sets = _vm(monkeypatch, *data, (0.0, 0.2), N - 2, forward=False)
    for c, vm in zip(c_sets, vm_sets, strict=True):  # type: ignore[call-overload]
        np.testing.assert_array_equal(c, vm)
    assert not np.any(c_sets[2] > 0.5)


def test_a_library_that_does_not_load_falls_back(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A cached file that is not a loadable library (another machine's, or damaged): the C
    loops are off and the scaling runs on the VM, no exception."""
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    bad = codegen._library(native.SOURCE, native.PREFIX, native.FLAGS)
    bad.parent.mkdir(parents=True, exist_ok=True)
    bad.write_bytes(b"not a shared library")
    native.kernels.cache_clear()
    try:
        assert native.kernels() is None
        rng = np.random.default_rng(5)
        _assert_same(_random_problem(rng, 60, 3))
    finally:
        native.kernels.cache_clear()
