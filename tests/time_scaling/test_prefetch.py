"""The time-scaling passes built in the background (``passes.prefetch``, started by the planner
before it compiles the generator) are the ones the passes then use, with the same results."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mmplan.compile import codegen
from mmplan.time_scaling import native, native_peaks
from mmplan.time_scaling import passes as topp_passes

from .test_topp import _assert_same, _random_problem


@pytest.mark.skipif(codegen.compiler() is None, reason="needs a C compiler")
def test_prefetched_library_is_used_and_matches_the_reference(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    native.kernels.cache_clear()
    native_peaks.peaks.cache_clear()
    try:
        topp_passes.prefetch()
        assert topp_passes._PENDING  # nothing loaded: a build was started
        topp_passes.prefetch()  # a second call starts nothing more (one build for any row count)
        assert len(topp_passes._PENDING) == 1
        kernels = topp_passes.kernels()
        assert not topp_passes._PENDING
        assert isinstance(kernels, native.Kernels)
        assert len(list(tmp_path.glob("topp_native_*.so"))) == 1  # built once, then loaded
        assert len(list(tmp_path.glob("interval_peaks_*.so"))) == 1  # in the same thread
        rng = np.random.default_rng(5)
        _assert_same(_random_problem(rng, 300, 5))
        topp_passes.prefetch()  # loaded now: no build
        assert not topp_passes._PENDING
    finally:
        native.kernels.cache_clear()
        native_peaks.peaks.cache_clear()


@pytest.mark.skipif(codegen.compiler() is None, reason="needs a C compiler")
def test_idle_loads_take_libraries_on_disk_and_never_build(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``load_passes`` / ``load_peaks`` (run while a rollout waits for its chunk) load a
    library that is on disk, and build nothing when it is not (a build is prefetch's)."""
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    native.kernels.cache_clear()
    native_peaks.peaks.cache_clear()
    try:
        topp_passes.load_passes()
        topp_passes.load_peaks()
        assert not list(tmp_path.glob("*.so"))  # nothing on disk: nothing built
        assert not native.kernels.cache_info().currsize
        assert not native_peaks.peaks.cache_info().currsize
        topp_passes.prefetch()
        topp_passes.kernels()  # the build is on disk now
        native.kernels.cache_clear()
        native_peaks.peaks.cache_clear()
        topp_passes.load_passes()
        assert native.kernels.cache_info().currsize and native.kernels() is not None
        assert not native_peaks.peaks.cache_info().currsize  # each loads its own
        topp_passes.load_peaks()
        assert native_peaks.peaks.cache_info().currsize and native_peaks.peaks() is not None
    finally:
        native.kernels.cache_clear()
        native_peaks.peaks.cache_clear()
