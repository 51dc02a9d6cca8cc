"""Validation of obstacle fields and the local frame of a yawed shape.

The lowest module of :mod:`mmplan.scene`: the smooth model
(:mod:`mmplan.scene.smooth_model`), the obstacle base class and every shape validate their
fields with these helpers, which raise :class:`~mmplan.errors.InputError` naming the field.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from mmplan.arrays import Array
from mmplan.errors import InputError

Vec3 = tuple[float, float, float]


def _fail(field: str, problem: str) -> InputError:
    return InputError(field, problem)


def as_float(value: Any, field: str) -> float:
    """A finite float, else :class:`InputError` naming ``field``."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise _fail(field, f"expected a number, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise _fail(field, f"expected a finite number, got {value!r}")
    return out


def positive(value: Any, field: str) -> float:
    """A finite float > 0, else :class:`InputError` naming ``field``."""
    out = as_float(value, field)
    if out <= 0.0:
        raise _fail(field, f"expected a positive length in metres, got {value!r}")
    return out


def vector(
    value: Any, field: str, size: int = 3, check: Callable[[Any, str], float] = as_float
) -> tuple[float, ...]:
    """A tuple of ``size`` floats each passing ``check`` (field ``name[i]`` on error)."""
    if isinstance(value, str | bytes) or not isinstance(value, Sequence | np.ndarray):
        raise _fail(field, f"expected a list of {size} numbers, got {value!r}")
    items = list(value)
    if len(items) != size:
        raise _fail(field, f"expected a list of {size} numbers, got {len(items)}: {value!r}")
    return tuple(check(v, f"{field}[{i}]") for i, v in enumerate(items))


def influence_value(value: Any) -> float | None:
    """Validate the optional ``influence`` field (None or a positive length)."""
    return None if value is None else positive(value, "influence")


def points_array(points: ArrayLike) -> Array:
    """Points as a float array (P, 3); a single point (3,) becomes (1, 3)."""
    arr = np.asarray(points, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InputError("points", f"expected an array of shape (P, 3), got {arr.shape}")
    return arr


def rot_z(yaw: float) -> Array:
    """Rotation matrix about z by ``yaw`` [rad] (3, 3)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def to_local(points: ArrayLike, center: Sequence[float], yaw: float) -> Array:
    """Coordinates p' = R_z(yaw)^T (p - c) of world points (P, 3)."""
    p = points_array(points) - np.asarray(center, dtype=float)
    # Row-vector form of R^T (p - c): (p - c) @ R.
    return np.asarray(p @ rot_z(yaw), dtype=float)
