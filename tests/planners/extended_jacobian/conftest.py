"""Shared fixtures of the extended-Jacobian tests."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from typing import Any

import pytest

from mmplan.compile import codegen
from mmplan.planners.extended_jacobian import cache as ej_cache
from mmplan.planners.extended_jacobian import generator as ej_generator


@dataclasses.dataclass
class Counts:
    """C compiler runs and symbolic generator builds seen by a test."""

    compiles: int = 0
    builds: int = 0


@pytest.fixture
def counts(monkeypatch: pytest.MonkeyPatch) -> Iterator[Counts]:
    """Counters of C compiler runs (``codegen.subprocess.run``) and symbolic generator builds
    (``build_functions`` as the generator cache calls it)."""
    found = Counts()
    run, build = codegen.subprocess.run, ej_generator.build_functions

    def counted_run(*args: Any, **kwargs: Any) -> Any:
        found.compiles += 1
        return run(*args, **kwargs)

    def counted_build(*args: Any, **kwargs: Any) -> Any:
        found.builds += 1
        return build(*args, **kwargs)

    monkeypatch.setattr(codegen.subprocess, "run", counted_run)
    monkeypatch.setattr(ej_cache, "build_functions", counted_build)
    yield found
