"""Self-collision pairs: which of a robot's collision spheres must stay apart.

A pair of bodies is checked when the bodies are not adjacent (parent and child in the tree)
and do not already overlap in the reference pose: real robot models overlap neighbouring
collision shapes by design (a wheel in its housing, a shoulder in the torso), and a pair that
collides at rest would only report what the model draws, not a motion that hits.
The signed distance of a sphere pair is ``|p_i - p_j| - r_i - r_j`` (negative: overlap).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass, field

import numpy as np

from mmplan.arrays import Array


@dataclass(frozen=True)
class SelfCollision:
    """Body pairs to keep apart and the collision-sphere index pairs that realise them.

    Attributes:
        body_pairs: (body_a, body_b) pairs checked.
        sphere_pairs: (K, 2) indices into the robot's collision spheres.
        skipped: Non-adjacent body pairs left out because they overlap in the reference pose.
    """

    body_pairs: tuple[tuple[str, str], ...] = ()
    sphere_pairs: Array = field(default_factory=lambda: np.zeros((0, 2), dtype=int))
    skipped: tuple[tuple[str, str], ...] = ()

    def distances(self, points: Array, radii: Array) -> Array:
        """Signed distances (K,) of the sphere pairs, from centres (P, 3) and radii (P,) [m]."""
        i, j = self.sphere_pairs[:, 0], self.sphere_pairs[:, 1]
        return np.asarray(
            np.linalg.norm(points[i] - points[j], axis=1) - radii[i] - radii[j], dtype=float
        )


def body_distances(
    bodies: Sequence[str], points: Array, radii: Array
) -> dict[tuple[str, str], float]:
    """Smallest signed sphere distance between every two bodies that have spheres [m]."""
    names = list(dict.fromkeys(bodies))
    index = {b: np.flatnonzero(np.asarray(bodies) == b) for b in names}
    out = {}
    for a_i, a in enumerate(names):
        for b in names[a_i + 1 :]:
            ia, ib = index[a], index[b]
            d = np.linalg.norm(points[ia, None, :] - points[None, ib, :], axis=2)
            out[(a, b)] = float((d - radii[ia, None] - radii[None, ib]).min())
    return out


def select_pairs(
    bodies: Sequence[str],
    points: Array,
    radii: Array,
    adjacent: Collection[frozenset[str]],
    rigid_groups: Sequence[Collection[str]] = (),
) -> SelfCollision:
    """Self-collision pairs of spheres on ``bodies`` (P,) at the reference pose ``points`` (P, 3).

    Args:
        bodies: Body of each collision sphere.
        points: Sphere centres in the reference pose (P, 3) [m].
        radii: Sphere radii (P,) [m].
        adjacent: Parent-child body pairs (never checked).
        rigid_groups: Groups of bodies whose distances cannot change (e.g. a platform and its
            wheels); pairs inside a group are not checked.
    """
    gaps = body_distances(bodies, points, radii)
    checked: list[tuple[str, str]] = []
    skipped: list[tuple[str, str]] = []
    for (a, b), gap in gaps.items():
        if frozenset((a, b)) in adjacent or any(a in g and b in g for g in rigid_groups):
            continue
        (checked if gap >= 0 else skipped).append((a, b))
    body_arr = np.asarray(bodies)
    rows = []
    for a, b in checked:
        ia, ib = np.flatnonzero(body_arr == a), np.flatnonzero(body_arr == b)
        rows.append(np.stack(np.meshgrid(ia, ib, indexing="ij"), axis=-1).reshape(-1, 2))
    sphere_pairs = np.concatenate(rows) if rows else np.zeros((0, 2), dtype=int)
    return SelfCollision(tuple(checked), sphere_pairs.astype(int), tuple(skipped))
