r"""More obstacles than a compiled library has slots: the near ones in the slots (speed).

A compiled generator has a fixed number of slots per obstacle shape type
(:mod:`~mmplan.planners.extended_jacobian.parameters`). A scene with more obstacles of a type
than a library on disk has slots is served by that library anyway, with no compile: the
slots hold the obstacles the robot is near, and the others are left out of p while the
robot stays far from them.

Why that is exact. The perturbation's term of an obstacle o and a collision sphere (centre
c, radius r) is kappa = ((delta_o - C)/C)^2 where C - r < delta_o, else exactly 0, and the
radial distance C is at least the distance of c to o's bounding box
(:mod:`~mmplan.planners.extended_jacobian.obstacles`). So while every sphere keeps

    gap_o = box distance(c) - r - delta_o > 0,

o adds exact zeros to K, dK/dq and the push: leaving it out of p changes no number of a step
(the obstacles in the slots keep the scene's order, so the sums add the same nonzero terms in
the same order: the samples are the same to the bit as with a library holding every obstacle,
tested, as long as the chunks fall in the same places: below). A step's Runge-Kutta stages
are evaluated between its two states, so an obstacle counts as safe at a state only with the
margin ``2 m + MARGIN``, where m is the largest displacement of a sphere over a step of the
stretch checked (a review recomputed the stages of real runs: the worst came 0.42 of the
margin beyond its states).

How it runs (the choice: :mod:`mmplan.planners.near_slots`; here the geometry and p): at the
start the slots take, per shape type, the obstacles nearest to the robot's spheres. After
each compiled chunk (:mod:`~mmplan.planners.extended_jacobian.chunks`) and each single step
(:mod:`~mmplan.planners.extended_jacobian.rollout`) the states it produced are checked
against the obstacles left out: a chunk that came within the margin of one runs again with
the slots chosen for all of its states (the chunks then fall where they fall with every
obstacle in a slot: the same samples to the bit), or, when those states come near more
obstacles of a type than slots, is cut before the first such state and the slots are chosen
again there (the loop's samples from there equal the chunk's to rounding); a single step is
taken again with the new choice. When more obstacles of a type are within the margin at once
than the library has slots, ``CrowdedError`` is raised and the planner uses a library with
more slots of that type (:meth:`~mmplan.planners.near_slots.CrowdedError.grown`; a compile
when there is none: the only case left where an obstacle count compiles).

Cost: the check evaluates the compiled collision points at every state of a chunk; measured
(``python bench/bench_active_slots.py``, warm, 9 alternated pairs) the paper scene with 3 and
17 more cylinders planned with 2 cylinder slots in 28.5 / 42.4 ms against 28.2 / 42.0 ms with
a library holding every obstacle (+1 %), the same samples; a new process planned them in 0.07
/ 0.08 s where compiling their own library took 2.3 / 3.1 s.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from typing import Any

import numpy as np

from mmplan.arrays import Array
from mmplan.planners.extended_jacobian.parameters import (
    ParameterLayout,
    Shape,
    park_slot,
    put_slot,
    shape_of,
)
from mmplan.planners.near_slots import CrowdedError, NearSlots
from mmplan.scene.box import BOX_EXPONENTS
from mmplan.scene.cylinder import CYLINDER_EXPONENTS

__all__ = ["ActiveSlots", "CrowdedError"]


def shape_name(exponents: Shape) -> str:
    """The shape with these superellipsoid exponents ("superellipsoid (e1, e2)" for others)."""
    names = {BOX_EXPONENTS: "box", CYLINDER_EXPONENTS: "cylinder", (1.0, 1.0): "sphere"}
    key = (float(exponents[0]), float(exponents[1]))
    return names.get(key, f"superellipsoid {key}")


class ActiveSlots(NearSlots):
    """Which of a scene's obstacles the slots of p hold, chosen along a rollout (module
    docstring).

    Args:
        robot: The robot (its collision spheres).
        layout: The generator's parameter layout (fewer slots than obstacles of a type).
        obstacles: The scene's obstacles as (superellipsoid model, delta) pairs.
    """

    def __init__(
        self, robot: Any, layout: ParameterLayout, obstacles: Sequence[tuple[Any, float]]
    ) -> None:
        self.starts = layout.starts()
        capacity: dict[Hashable, int] = {e: len(at) for e, at in self.starts.items()}
        super().__init__(robot, [shape_of(m) for m, _ in obstacles], capacity)
        self.obstacles = list(obstacles)
        self.center = np.array([m.center for m, _ in obstacles], dtype=float).reshape(-1, 3)
        self.semi = np.array([m.semi_axes for m, _ in obstacles], dtype=float).reshape(-1, 3)
        yaw = np.array([float(getattr(m, "yaw", 0.0)) for m, _ in obstacles])
        self.cos, self.sin = np.cos(yaw), np.sin(yaw)
        self.delta = np.array([float(d) for _, d in obstacles])

    def label(self, kind: Hashable) -> str:
        """The shape of these exponents (:func:`shape_name`)."""
        return shape_name(kind)  # type: ignore[arg-type]

    def gaps(self, C: Array, Q: Array, which: Sequence[int]) -> Array:
        """gap_o = box distance - radius - delta (module docstring) of the obstacles
        ``which``, the smallest over the spheres C (M, P, 3): (M, len(which))."""
        idx = np.asarray(which, dtype=int)
        d = C[:, :, None, :] - self.center[idx]  # (M, P, W, 3)
        c, s = self.cos[idx], self.sin[idx]
        local = np.stack(
            [c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1], d[..., 2]], axis=-1
        )
        excess = np.maximum(np.abs(local) - self.semi[idx], 0.0)
        dist = np.sqrt(np.sum(excess * excess, axis=-1)) - self.radii[None, :, None]
        return np.asarray(dist.min(axis=1) - self.delta[idx], dtype=float)

    def write(self, p: Array, chosen: dict[Hashable, list[int]]) -> Array:
        """p whose slots hold the chosen obstacles (parameters.py's numbers), the rest parked."""
        for e, starts in self.starts.items():
            mine = chosen.get(e, [])
            for j, at in enumerate(starts):
                if j < len(mine):
                    model, delta = self.obstacles[mine[j]]
                    put_slot(p, at, model, delta)
                else:
                    park_slot(p, at)
        return p
