"""Content keys of a robot model and of source code, for the compiled-library disk cache.

A compiled function is found again on a later run by a key computed without building it:
:func:`robot_fingerprint` hashes what a symbolic model is made of (the robot's kinematic,
dynamic and Pfaffian expressions, its joint limits, collision spheres and named parts; not
its torque and rate limits, which compiled functions take as numbers or options), and
:func:`source_fingerprint` the code that turns it into functions. Two robot objects with
the same model share a key (and so the very same compiled code: plans that differ only in
their rate limits stay equal to the last bit); a changed joint limit, mass or sphere is
another key.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from mmplan.compile.model_cache import ModelCache

_ROBOTS: ModelCache[str] = ModelCache(32)


def robot_fingerprint(robot: Any) -> str:
    """sha256 of the robot's symbolic model, joint limits, spheres and names (cached per
    object)."""

    def build() -> str:
        s = robot.symbols
        model = ca.Function(
            "model",
            [s.q, s.dq, s.ddq],
            [s.ee_position, s.ee_rotation, s.jacobian, s.pfaffian, s.null_basis, s.actuation,
             s.mass_matrix, s.bias, s.manipulability, s.collision_points],
        )  # fmt: skip
        parts = [
            model.serialize(),
            repr((robot.limits.joint_min, robot.limits.joint_max)),
            repr(list(robot.collision)),
            repr(robot.coordinates),
            repr(tuple(robot.arm_indices)),
            repr(robot.end_effector),
            repr(getattr(robot.platform, "wheel_radius", None)),
            repr([(j.coordinate, j.kind, j.parent, j.child) for j in robot.tree.joints]),
            repr(tuple(robot.actuators)),
        ]
        return hashlib.sha256("\n".join(parts).encode()).hexdigest()

    with np.printoptions(precision=17, threshold=10**9):  # every digit of every limit
        return _ROBOTS.get_or_build(robot, "fingerprint", build)


def source_fingerprint(files: Iterable[str | Path]) -> str:
    """sha256 of the contents of source files (the code version of a compiled library)."""
    digest = hashlib.sha256()
    for path in sorted(str(f) for f in files):
        digest.update(Path(path).read_bytes())
    digest.update(ca.CasadiMeta.version().encode())
    return digest.hexdigest()
