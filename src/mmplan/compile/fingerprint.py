"""Content keys of a robot model and of source code, for the compiled-library disk cache.

A compiled function is found again on a later run by a key computed without building it:
:func:`robot_fingerprint` hashes what a symbolic model is made of (the robot's description:
platform, bodies, joints, end effector, friction, its joint limits, collision spheres and
named parts, and the code that turns them into expressions; not its torque and rate limits,
which compiled functions take as numbers or options), and
:func:`source_fingerprint` the code that turns it into functions. Two robot objects with
the same model share a key (and so the very same compiled code: plans that differ only in
their rate limits stay equal to the last bit); a changed joint limit, mass or sphere is
another key.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import tempfile
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from mmplan.compile.model_cache import ModelCache

_ROBOTS: ModelCache[str] = ModelCache(32)


def robot_fingerprint(robot: Any) -> str:
    """sha256 of what the robot's symbolic model is made of, its joint limits, spheres and
    names (cached per object), computed without building the model.

    The symbolic model (:meth:`mmplan.robot.robot.Robot.symbols`) is a function of the
    robot's description alone: the platform (its type and parameters), the kinematic tree's
    bodies (inertials) and joints (kind, origin, axis, coordinate), the end effector, the
    collision spheres, the friction and the coordinates, all frozen dataclasses of plain
    numbers whose repr is exact, and of the code that builds it (the modules of the robot
    package, and the module of a user's own Robot or platform class). Hashing these costs
    about 1 ms; hashing the serialized model cost 10-25 ms a process plus the model's
    symbolic build (36 ms for youbot-3r), which a warm run otherwise never needs.
    """

    def build() -> str:
        parts = [
            _qualified(type(robot)),
            _qualified(type(robot.platform)),
            repr(robot.platform),
            repr(sorted(robot.tree.bodies.items())),
            repr(list(robot.tree.joints)),
            repr(robot.coordinates),
            repr(tuple(robot.arm_indices)),
            repr(tuple(robot.actuators)),
            repr(robot.end_effector),
            repr(list(robot.collision)),
            repr(sorted(robot.friction.items())),
            _exact(robot.limits.joint_min) + _exact(robot.limits.joint_max),
        ]
        code = _model_code(robot)
        if code is None:  # a model class without a source file (REPL, notebook, exec)
            parts.append(_serialized_model(robot))
        else:
            parts.append(source_fingerprint(code))
        return hashlib.sha256("\n".join(parts).encode()).hexdigest()

    with np.printoptions(precision=17, threshold=10**9):  # every digit of every limit
        return _ROBOTS.get_or_build(robot, "fingerprint", build)


def _qualified(kind: type) -> str:
    return f"{kind.__module__}.{kind.__qualname__}"


def _exact(values: Any) -> str:
    """Every bit of an array of numbers (repr rounds to the print precision)."""
    return np.ascontiguousarray(values, dtype=np.float64).tobytes().hex()


def _model_code(robot: Any) -> list[str] | None:
    """The source files that build a robot's symbolic model: mmplan's robot package
    (kinematics, dynamics, platforms) and the modules of every class in the robot's and its
    platform's class hierarchies (a user's own subclass too); None when one of those classes
    has no source file (defined in a REPL, a notebook or by exec: its code cannot be hashed)."""
    package = sys.modules.get("mmplan.robot.robot")
    files: set[str] = set()
    if package is not None and getattr(package, "__file__", None):
        files.update(python_files(os.path.dirname(os.path.abspath(str(package.__file__)))))
    for kind in (*type(robot).__mro__, *type(robot.platform).__mro__):
        if kind is object or kind.__module__ == "abc":
            continue
        source = getattr(sys.modules.get(kind.__module__), "__file__", None)
        if not source:
            return None
        files.add(os.path.abspath(source))
    return sorted(files)


def _serialized_model(robot: Any) -> str:
    """sha256 of the robot's serialized symbolic model (builds it: 10-40 ms)."""
    s = robot.symbols
    model = ca.Function(
        "model",
        [s.q, s.dq, s.ddq],
        [s.ee_position, s.ee_rotation, s.jacobian, s.pfaffian, s.null_basis, s.actuation,
         s.mass_matrix, s.bias, s.manipulability, s.collision_points],
    )  # fmt: skip
    return hashlib.sha256(model.serialize().encode()).hexdigest()


def source_fingerprint(files: Iterable[str | Path]) -> str:
    """sha256 of the contents of source files (the code version of a compiled library).

    Each file's own sha256 is kept in a small index next to the compiled libraries
    (:func:`_content_hash`), so that a process reads the index and stats the files instead
    of reading and hashing all of them (the generator's 45 files and the robot package:
    about 1.5 ms of every process's first plan, measured)."""
    digest = hashlib.sha256()
    for path in sorted(str(f) for f in files):
        digest.update(_content_hash(path).encode())
    digest.update(ca.CasadiMeta.version().encode())
    if _INDEX.dirty:
        _INDEX.save()
    return digest.hexdigest()


#: A file changed (contents or metadata) less than this long ago [ns] is always read again:
#: on a file system with coarse times a change within the same tick keeps size and times
#: (git's "racily clean" entries).
RECENT_NS = 3_000_000_000


class _Index:
    """path -> [size, mtime_ns, ctime_ns, inode, sha256 of the contents], read once per
    process from the cache folder and written back (atomically) when it gained entries, with
    the entries of files that are gone left out.

    One index per installed mmplan (its folder's hash in the file name): a single index for
    every checkout on a machine kept growing (341 entries here after a day of clones, 0.4 ms
    to parse in every process's first plan, against about 0.1 ms for one tree's)."""

    def __init__(self) -> None:
        self.entries: dict[str, list[Any]] | None = None
        self.dirty = False

    def _path(self) -> Path:
        from mmplan.compile.codegen import cache_dir  # codegen imports nothing of this module

        return cache_dir() / f"source_hashes_{_TREE}.json"

    def get(self) -> dict[str, list[Any]]:
        if self.entries is None:
            try:
                data = json.loads(self._path().read_text())
                self.entries = data if isinstance(data, dict) else {}
            except (OSError, ValueError):
                self.entries = {}
        return self.entries

    def save(self) -> None:
        self.dirty = False
        path = self._path()
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
            kept = {k: v for k, v in self.get().items() if os.path.exists(k)}
            with os.fdopen(fd, "w") as out:
                json.dump(kept, out)
            os.replace(tmp, path)
        except OSError:
            pass  # no index: hashed again next time


#: This mmplan's folder, hashed: the name of its index (:class:`_Index`).
_TREE = hashlib.sha256(os.path.dirname(os.path.dirname(os.path.abspath(__file__))).encode()
                       ).hexdigest()[:12]  # fmt: skip
_INDEX = _Index()


def _content_hash(path: str) -> str:
    """sha256 of a file's contents: from the index when its size, modification and change
    times and inode are those recorded (and it did not change in the last
    :data:`RECENT_NS`), else read. The change time cannot be set back: a same-size edit whose
    modification time a tool restores (cp -p, tar -x, touch -r) is read again."""
    st = os.stat(path)
    entries = _INDEX.get()
    entry = entries.get(path)
    key = [st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino]
    settled = time.time_ns() - max(st.st_mtime_ns, st.st_ctime_ns) > RECENT_NS
    if settled and isinstance(entry, list) and len(entry) == 5 and entry[:4] == key:
        return str(entry[4])
    with open(path, "rb") as source:  # plain open: Path.read_bytes cost 5x more here
        sha = hashlib.sha256(source.read()).hexdigest()
    if settled:
        entries[path] = [*key, sha]
        _INDEX.dirty = True
    return sha


def python_files(folder: str | Path, recursive: bool = False) -> list[str]:
    """The ``*.py`` files in ``folder`` (and its subfolders when ``recursive``), by os.walk
    (pathlib's glob cost 5 ms a process for the generator's 38 files, measured under load)."""
    found = []
    for root, dirs, names in os.walk(folder):
        found += [os.path.join(root, n) for n in names if n.endswith(".py")]
        if not recursive:
            dirs.clear()
    return sorted(found)
