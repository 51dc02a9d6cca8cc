"""Collision models: points (spheres of radius 0) on platform boxes and along links.

[PajakPajak] and [Pajak] discretize the platform and the links into points at a given spacing
(0.14 m in [PajakPajak]'s example); distances are then taken from those points to obstacles.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from mmplan.robot.robot import CollisionSphere


def _samples(length: float, spacing: float) -> np.ndarray:
    count = max(2, int(np.ceil(length / spacing - 1e-9)) + 1)
    return np.linspace(0.0, 1.0, count)


def points_on_segment(
    body: str, start: ArrayLike, end: ArrayLike, spacing: float, radius: float = 0.0
) -> list[CollisionSphere]:
    """Points from ``start`` to ``end`` (body frame), ends included, at most ``spacing`` apart."""
    a, b = np.asarray(start, float), np.asarray(end, float)
    out = []
    for s in _samples(float(np.linalg.norm(b - a)), spacing):
        p = a + s * (b - a)
        out.append(CollisionSphere(body, (float(p[0]), float(p[1]), float(p[2])), radius))
    return out


def points_on_box(
    body: str, center: Sequence[float], size: Sequence[float], spacing: float
) -> list[CollisionSphere]:
    """Grid points on the surface of an axis-aligned box (body frame), at most ``spacing`` apart."""
    c, s = np.asarray(center, float), np.asarray(size, float)
    axes = [c[i] - s[i] / 2 + s[i] * _samples(float(s[i]), spacing) for i in range(3)]
    out = []
    for ix, x in enumerate(axes[0]):
        for iy, y in enumerate(axes[1]):
            for iz, z in enumerate(axes[2]):
                on_surface = (
                    ix in (0, len(axes[0]) - 1)
                    or iy in (0, len(axes[1]) - 1)
                    or iz in (0, len(axes[2]) - 1)
                )
                if on_surface:
                    out.append(CollisionSphere(body, (float(x), float(y), float(z))))
    return out
