"""A time-scaling library built in the background (``passes.prefetch``, started by the planner
before it compiles the generator) is the one the passes then use, with the same results."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mmplan.compile import codegen
from mmplan.time_scaling import passes as topp_passes

from .test_topp import _assert_same, _random_problem


@pytest.mark.skipif(codegen.compiler() is None, reason="needs a C compiler")
def test_prefetched_library_is_used_and_matches_the_reference(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    topp_passes.passes.cache_clear()
    try:
        topp_passes.prefetch(5)
        assert 5 in topp_passes._PENDING  # nothing on disk: a build was started
        topp_passes.prefetch(5)  # a second call starts nothing more
        backward, _ = topp_passes._ready(5)
        assert 5 not in topp_passes._PENDING
        assert isinstance(backward, codegen.NativeFunction)
        assert len(list(tmp_path.glob("ej_topp_*.so"))) == 1  # built once, then loaded
        rng = np.random.default_rng(5)
        _assert_same(_random_problem(rng, 300, 5))
        topp_passes.prefetch(5)  # on disk now: no build
        assert 5 not in topp_passes._PENDING
    finally:
        topp_passes.passes.cache_clear()
