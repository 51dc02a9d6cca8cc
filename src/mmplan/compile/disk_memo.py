"""Small results about a robot model kept on disk next to the compiled libraries (speed).

Some checks and set-up steps read a number or two off the robot's symbolic model (the arm's
vertical reach, the wrist centre): 10-40 ms a process, for a result that depends only on the
model. :func:`remember` keeps such a JSON value per process (by robot object) and on disk,
keyed by the robot's fingerprint (:func:`mmplan.compile.fingerprint.robot_fingerprint`, which
covers the model and the code that builds it), the source of the module that computes the value
(a changed algorithm is another key), a name and an argument; the write is atomic and an
unreadable file is computed again.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Callable, Hashable
from functools import lru_cache
from typing import Any, TypeVar

from mmplan.compile.codegen import cache_dir
from mmplan.compile.fingerprint import robot_fingerprint, source_fingerprint
from mmplan.compile.model_cache import ModelCache

T = TypeVar("T")

_SEEN: ModelCache[Any] = ModelCache(64)


def remember(
    robot: Any,
    code: str,
    name: str,
    arg: Hashable,
    compute: Callable[[], T],
    encode: Callable[[T], Any],
    decode: Callable[[Any], T],
) -> T:
    """``compute()`` for this robot model, ``name`` and ``arg``: from this process's memory,
    else from the disk cache, else computed and stored (``code``: the computing module's
    file, ``__file__``; ``encode`` to JSON data, ``decode`` back; a value that fails to decode
    counts as absent)."""

    def stored() -> T:
        key = hashlib.sha256(f"{robot_fingerprint(robot)}|{_source(code)}".encode()).hexdigest()
        path = cache_dir() / f"{name}_{key[:24]}_{arg}.json"
        try:
            return decode(json.loads(path.read_text()))
        except (OSError, ValueError, TypeError, KeyError, IndexError):
            pass
        value = compute()
        try:  # floats round-trip exactly through JSON; atomic write
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
            with os.fdopen(fd, "w") as out:
                json.dump(encode(value), out)
            os.replace(tmp, path)
        except OSError:
            pass
        return value

    return _SEEN.get_or_build(robot, (code, name, arg), stored)


@lru_cache(maxsize=32)
def _source(code: str) -> str:
    return source_fingerprint([code])
