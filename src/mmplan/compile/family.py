"""Families of compiled libraries that differ only in their obstacle slots (speed).

A planner whose compiled function holds obstacles in slots (a count per shape kind) lists
every library it compiles under a *family* key: the same robot model, settings and code, any
slots. A scene whose slots no library has exactly can then use one of the family instead of
compiling: :func:`wider` (at least its slots of every kind, the others parked) or
:func:`covering` (a slot of each of its kinds but fewer of some: the planner keeps the near
obstacles in the slots, e.g. :mod:`mmplan.planners.extended_jacobian.active`).

The list is a JSON file ``<prefix>_<family>.json`` in the cache folder
(:func:`mmplan.compile.codegen.cache_dir`): ``{library key: [[kind, count], ...]}``, a kind
being a string or a list of numbers (kept as a tuple of floats).
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Hashable, Sequence
from pathlib import Path
from typing import Any

from mmplan.compile import codegen as cg

Slots = tuple[tuple[Hashable, int], ...]


def _path(prefix: str, family: str) -> Path:
    return cg.cache_dir() / f"{prefix}_{family}.json"


def _kind(value: Any) -> Hashable:
    if isinstance(value, str):
        return value
    return tuple(float(v) for v in value)


def listed(prefix: str, family: str) -> list[tuple[str, Slots]]:
    """The family's libraries and their slots (entries that do not parse skipped)."""
    try:
        data = json.loads(_path(prefix, family).read_text())
    except (OSError, ValueError):
        return []
    out = []
    for key, entry in data.items() if isinstance(data, dict) else ():
        try:
            out.append((key, tuple((_kind(e), int(k)) for e, k in entry)))
        except (TypeError, ValueError, IndexError):
            continue
    return out


def _encode(slots: Sequence[tuple[Any, int]]) -> list[list[Any]]:
    return [[e if isinstance(e, str) else [float(v) for v in e], int(k)] for e, k in slots]


def remember(prefix: str, family: str, slots: Sequence[tuple[Any, int]], key: str) -> None:
    """List the library ``key`` (these slots) among its family's (atomic write; two processes
    writing at once may drop one entry: that library is then only found by its own key)."""
    entries = {k: _encode(s) for k, s in listed(prefix, family)}
    entries[key] = _encode(slots)
    path = _path(prefix, family)
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(fd, "w") as out:
            json.dump(entries, out)
        os.replace(tmp, path)
    except OSError:
        pass


def wider(prefix: str, family: str, slots: Sequence[tuple[Any, int]]) -> list[tuple[str, Slots]]:
    """Keys and slots of the family's libraries with at least ``slots``' slots of each kind
    (more slots or more kinds: unused slots are parked), the fewest slots first."""
    need = {_kind(e): k for e, k in slots}
    found = [
        (sum(k for _, k in have), key, have)
        for key, have in listed(prefix, family)
        if all(dict(have).get(e, 0) >= k for e, k in need.items())
    ]
    return [(key, have) for _, key, have in sorted(found, key=lambda f: (f[0], f[1]))]


def covering(
    prefix: str, family: str, slots: Sequence[tuple[Any, int]]
) -> list[tuple[str, Slots]]:
    """Keys and slots of the family's libraries with a slot of every kind of ``slots`` but
    fewer slots of some, the most slots of those kinds first."""
    need = {_kind(e): k for e, k in slots}
    found = []
    for key, have in listed(prefix, family):
        mine = dict(have)
        if all(mine.get(e, 0) >= 1 for e in need) and any(mine[e] < k for e, k in need.items()):
            found.append((-sum(min(mine[e], k) for e, k in need.items()), key, have))
    return [(key, have) for _, key, have in sorted(found, key=lambda f: (f[0], f[1]))]
