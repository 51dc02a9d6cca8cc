"""The C loops of the time-scaling passes (:mod:`mmplan.time_scaling.native`) against their
specification, the CasADi step functions of :mod:`mmplan.time_scaling.passes` run on the
virtual machine: the same K_lo, K_hi, empty flags and x to the bit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mmplan.compile import codegen, threads
from mmplan.time_scaling import native, native_peaks
from mmplan.time_scaling import passes as topp_passes
from mmplan.time_scaling.passes import BIG

from .test_topp import _assert_same, _random_problem


def _same_bits(a: object, b: object) -> None:
    """Equal to the bit (-0.0 and +0.0 differ, as NaN payloads; assert_array_equal would
    let both pass)."""
    x, y = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    assert x.shape == y.shape
    np.testing.assert_array_equal(x.view(np.uint64), y.view(np.uint64))


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
    assert threads.library() is not None  # the process's worker takes half the fixed pairs
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
                _same_bits(c, vm)
        kernels.split = True
        empty += bool(np.any(c_sets[2] > 0.5))
        full = kernels.backward(*data, last, N - 2)
        K_lo, K_hi = np.append(full[0], last[0]), np.append(full[1], last[1])
        x0 = float(rng.uniform(0.0, 0.5))
        _same_bits(kernels.forward(*data, K_lo, K_hi, x0),
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
        _same_bits(c, vm)
    assert not np.any(c_sets[2] > 0.5)


@pytest.mark.skipif(codegen.compiler() is None, reason="needs a C compiler")
def test_degenerate_rows_follow_casadi_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    """Rows that only the box on u (the last slab) or exact zeros decide: zero rows, parallel
    duplicates (det = 0), signed zeros in the data and x_upper, rows without an x term,
    infinite and -0.0 limits (after an independent review's adversarial set: a fold of the
    per-slab accumulators that stopped one slab short passed the random problems above and
    fails here)."""
    kernels = native.kernels()
    assert kernels is not None
    monkeypatch.setattr(threads, "idle_core", lambda: True)
    assert threads.library() is not None
    rng = np.random.default_rng(21)
    for trial in range(40):
        N, n = int(rng.integers(3, 70)), int(rng.choice([1, 2, 3, 5]))
        sigma = np.cumsum(np.r_[0.0, rng.uniform(0.01, 0.1, N - 1)])
        alpha, beta = rng.normal(size=(N, n)), rng.normal(size=(N, n))
        g = rng.normal(size=(N, n)) * 0.1
        lo, hi = rng.uniform(-2.0, 0.0, n), rng.uniform(0.0, 2.0, n)
        x_up = rng.uniform(0.2, 3.0, N)
        kind = trial % 5
        if kind == 0:  # a zero row
            alpha[:, 0] = beta[:, 0] = 0.0
        elif kind == 1 and n > 1:  # parallel rows
            alpha[:, 1], beta[:, 1] = alpha[:, 0], beta[:, 0]
        elif kind == 2:  # signed zeros
            for a in (alpha, beta, g):
                a[rng.random((N, n)) < 0.4] = -0.0
            x_up[rng.random(N) < 0.2] = -0.0
        elif kind == 3:  # no x term
            alpha[:] = 0.0
            beta = -np.abs(beta)
        else:  # infinite and signed-zero limits
            lo[0], hi[-1], lo[-1], hi[0] = -np.inf, np.inf, -0.0, 0.0
            x_up[rng.random(N) < 0.2] = np.inf
        zone = np.concatenate([np.where(np.isfinite(lo), lo, -BIG),
                               np.where(np.isfinite(hi), hi, BIG)])  # fmt: skip
        data = (alpha, beta, g, sigma, x_up, zone)
        last = (0.0, float(rng.uniform(0.0, 1.0)))
        vm_sets = _vm(monkeypatch, *data, last, N - 2, forward=False)
        for split in (True, False):
            kernels.split = split
            c_sets = kernels.backward(*data, last, N - 2)
            for c, vm in zip(c_sets, vm_sets, strict=True):  # type: ignore[call-overload]
                _same_bits(c, vm)
    kernels.split = True


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


@pytest.mark.skipif(codegen.compiler() is None, reason="needs a C compiler")
def test_a_compiler_that_rejects_a_flag_gets_the_plain_build(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A compiler that rejects -fvect-cost-model (gcc's) or -march=native: the passes and
    the peaks are built with the plain flags (not the VM), give the same bits, and a later
    process takes that library without trying the rejected flags again."""
    real = codegen.compiler()
    cc = tmp_path / "picky-cc"
    cc.write_text(
        "#!/bin/sh\n"
        'for a in "$@"; do case "$a" in -fvect-cost-model=*|-march=native) exit 1;; esac; done\n'
        f'exec {real} "$@"\n'
    )
    cc.chmod(0o755)
    monkeypatch.setenv("CC", str(cc))
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path / "cache"))
    native.kernels.cache_clear()
    native_peaks.peaks.cache_clear()
    try:
        kernels = native.kernels()
        assert kernels is not None and native_peaks.peaks() is not None
        assert codegen.source_is_cached(native.SOURCE, native.PREFIX, native.FALLBACK)
        assert not codegen.source_is_cached(native.SOURCE, native.PREFIX, native.FLAGS)
        rng = np.random.default_rng(11)
        N, n = 90, 5
        sigma, alpha, beta, g, lo, hi, w_max = _random_problem(rng, N, n)
        zone = np.concatenate([np.where(np.isfinite(lo), lo, -BIG),
                               np.where(np.isfinite(hi), hi, BIG)])  # fmt: skip
        data = (alpha, beta, g, sigma, np.full(N, w_max**2), zone)
        c_sets = kernels.backward(*data, (0.0, 0.5), N - 2)
        vm_sets = _vm(monkeypatch, *data, (0.0, 0.5), N - 2, forward=False)
        for c, vm in zip(c_sets, vm_sets, strict=True):  # type: ignore[call-overload]
            _same_bits(c, vm)
        cc.write_text("#!/bin/sh\nexit 1\n")  # no build possible now: the cached one loads
        native.kernels.cache_clear()
        assert native.kernels() is not None
    finally:
        native.kernels.cache_clear()
        native_peaks.peaks.cache_clear()
