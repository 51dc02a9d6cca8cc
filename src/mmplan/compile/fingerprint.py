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
import os
import sys
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
    """sha256 of the contents of source files (the code version of a compiled library)."""
    digest = hashlib.sha256()
    for path in sorted(str(f) for f in files):
        with open(path, "rb") as source:  # plain open: Path.read_bytes cost 5x more here
            digest.update(source.read())
    digest.update(ca.CasadiMeta.version().encode())
    return digest.hexdigest()


def python_files(folder: str | Path, recursive: bool = False) -> list[str]:
    """The ``*.py`` files in ``folder`` (and its subfolders when ``recursive``), by os.walk
    (pathlib's glob cost 5 ms a process for the generator's 38 files, measured under load)."""
    found = []
    for root, dirs, names in os.walk(folder):
        found += [os.path.join(root, n) for n in names if n.endswith(".py")]
        if not recursive:
            dirs.clear()
    return sorted(found)
