"""Per-process caches of what planners build from one robot model (speed).

A compiled generator or model costs 10-100 ms to build and depends on a robot object (or its
shared symbolic model) plus a few settings; replanning with the same robot reuses it. The
entry is keyed by the anchor's identity and a hashable key, and holds the anchor only weakly:
a robot that is gone is never matched by a new object that reuses its ``id``. The least
recently used entry is dropped beyond ``size``.
"""

from __future__ import annotations

import weakref
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

T = TypeVar("T")


class ModelCache(Generic[T]):
    """LRU cache of values built from an anchor object (a Robot or its Symbols)."""

    def __init__(self, size: int) -> None:
        self.size = size
        self._items: OrderedDict[tuple[int, Hashable], tuple[weakref.ref[object], T]] = (
            OrderedDict()
        )

    def get(self, anchor: object, key: Hashable) -> T | None:
        """The value stored for (anchor, key), None when absent."""
        return self._lookup(anchor, key)[1]

    def _lookup(self, anchor: object, key: Hashable) -> tuple[bool, T | None]:
        """(whether (anchor, key) is stored, its value): a stored None is a value."""
        found = self._items.get((id(anchor), key))
        if found is None or found[0]() is not anchor:
            return False, None
        self._items.move_to_end((id(anchor), key))
        return True, found[1]

    def put(self, anchor: object, key: Hashable, value: T) -> None:
        """Store ``value`` for (anchor, key), dropping the least recently used beyond size."""
        self._items[(id(anchor), key)] = (weakref.ref(anchor), value)
        self._items.move_to_end((id(anchor), key))
        while len(self._items) > self.size:
            self._items.popitem(last=False)

    def get_or_build(self, anchor: object, key: Hashable, build: Callable[[], T]) -> T:
        """The stored value, or ``build()`` stored and returned. A value of None is stored
        too (found by profiling: the youBot's "no wrist" was looked up on disk twice a
        plan, its JSON file read each time)."""
        stored, found = self._lookup(anchor, key)
        if not stored:
            found = build()
            self.put(anchor, key, found)
        return found  # type: ignore[return-value]

    def clear(self) -> None:
        """Forget every entry."""
        self._items.clear()

    def __len__(self) -> int:
        return len(self._items)
