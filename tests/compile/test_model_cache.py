"""The per-process model cache (mmplan.compile.model_cache): identity keys held weakly, LRU."""

from __future__ import annotations

import gc

import pytest

from mmplan.compile import model_cache
from mmplan.compile.model_cache import ModelCache
from mmplan.robot.library import get_robot


class Anchor:
    """A weak-referenceable stand-in for a robot."""


def test_hit_only_for_the_same_live_anchor_and_key() -> None:
    cache: ModelCache[str] = ModelCache(4)
    a, b = Anchor(), Anchor()
    cache.put(a, "k", "built for a")
    assert cache.get(a, "k") == "built for a"
    assert cache.get(a, "other") is None and cache.get(b, "k") is None
    built = []
    assert cache.get_or_build(b, "k", lambda: built.append(1) or "built for b") == "built for b"
    assert cache.get_or_build(b, "k", lambda: built.append(1) or "again") == "built for b"
    assert built == [1]


def test_a_dead_anchor_is_never_matched_by_a_new_object(monkeypatch: pytest.MonkeyPatch) -> None:
    """A new object may get the id of a dead one: simulated by giving every object one id."""
    monkeypatch.setattr(model_cache, "id", lambda _obj: 7, raising=False)
    cache: ModelCache[str] = ModelCache(4)
    a = Anchor()
    cache.put(a, "k", "old")
    assert cache.get(a, "k") == "old"
    del a
    gc.collect()
    assert cache.get(Anchor(), "k") is None


def test_least_recently_used_is_dropped() -> None:
    cache: ModelCache[int] = ModelCache(2)
    a = Anchor()
    cache.put(a, 1, 1)
    cache.put(a, 2, 2)
    assert cache.get(a, 1) == 1  # 1 is now the most recently used
    cache.put(a, 3, 3)
    assert cache.get(a, 2) is None and cache.get(a, 1) == 1 and cache.get(a, 3) == 3
    assert len(cache) == 2


def test_robots_and_their_symbols_can_anchor() -> None:
    robot = get_robot("youbot-3r")
    cache: ModelCache[str] = ModelCache(4)
    cache.put(robot, 0, "robot")
    cache.put(robot.symbols, 0, "symbols")
    copy = robot.with_limits(robot.limits)  # shares the symbols, not the identity
    assert cache.get(copy, 0) is None and cache.get(copy.symbols, 0) == "symbols"


def test_a_value_of_none_is_built_once() -> None:
    """A build that returns None (a robot without a wrist) is stored like any value: it ran
    on every call before, and the wrist's disk memo was read twice a plan."""
    cache: ModelCache[str | None] = ModelCache(4)
    anchor = Anchor()
    builds: list[int] = []

    def build() -> None:
        builds.append(1)

    assert cache.get_or_build(anchor, "k", build) is None
    assert cache.get_or_build(anchor, "k", build) is None
    assert builds == [1] and cache.get(anchor, "k") is None
