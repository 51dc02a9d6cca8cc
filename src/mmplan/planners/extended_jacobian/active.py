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
tested). A step's Runge-Kutta stages are evaluated between its two states, so an obstacle
counts as safe at a state only with the margin ``2 m + MARGIN``, where m is the largest
displacement of a sphere over a step of the stretch checked.

How it runs (:mod:`~mmplan.planners.extended_jacobian.rollout`,
:mod:`~mmplan.planners.extended_jacobian.chunks`): at the start the slots take, per shape type,
the obstacles nearest to the robot's spheres. After each compiled chunk (and each single
step) the states it produced are checked against the obstacles left out: the chunk is cut
before the first state where one of them is within its margin, that obstacle is flagged, and
the slots are chosen again there (the flagged obstacles and every obstacle within the margin
first, then the nearest); a single step is taken again with the new choice. When more
obstacles of a type are within the margin at once than the library has slots,
:class:`CrowdedError` is raised and the planner uses a library with the scene's own slots (a
compile when there is none: the only case left where an obstacle count compiles).

Cost: the check evaluates the compiled collision points at every state of a chunk; measured
(``python bench/bench_active_slots.py``, warm, 9 alternated pairs) the paper scene with 3 and
17 more cylinders planned with 2 cylinder slots in 28.5 / 42.4 ms against 28.2 / 42.0 ms with
a library holding every obstacle (+1 %), the same samples; a new process planned them in 0.07
/ 0.08 s where compiling their own library took 2.3 / 3.1 s.
"""

from __future__ import annotations

from collections.abc import Sequence
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

#: Distance [m] an obstacle left out of the slots keeps beyond its neighbourhood, besides
#: twice the largest step of a sphere (module docstring).
MARGIN = 0.01


class CrowdedError(Exception):
    """More obstacles of a shape type near the robot at once than the library has slots."""

    def __init__(self, shape: Shape, near: int, slots: int) -> None:
        super().__init__(f"{near} obstacles with exponents {shape} near at once, {slots} slots")
        self.shape, self.near, self.slots = shape, near, slots


class ActiveSlots:
    """Which of a scene's obstacles the slots of p hold, chosen along a rollout (module
    docstring). One instance serves one rollout at a time (:meth:`start` resets it).

    Args:
        robot: The robot (its collision spheres).
        layout: The generator's parameter layout (fewer slots than obstacles of a type).
        obstacles: The scene's obstacles as (superellipsoid model, delta) pairs.
    """

    def __init__(
        self, robot: Any, layout: ParameterLayout, obstacles: Sequence[tuple[Any, float]]
    ) -> None:
        self.robot = robot
        self.obstacles = list(obstacles)
        self.slots = layout.starts()
        shapes = [shape_of(m) for m, _ in self.obstacles]
        missing = sorted({e for e in shapes if not self.slots.get(e)})
        if missing:
            raise ValueError(f"no slot for obstacles with exponents {missing}")
        self.kinds = {e: [i for i, k in enumerate(shapes) if k == e] for e in self.slots}
        self.center = np.array([m.center for m, _ in self.obstacles], dtype=float).reshape(-1, 3)
        self.semi = np.array([m.semi_axes for m, _ in self.obstacles], dtype=float).reshape(-1, 3)
        yaw = np.array([float(getattr(m, "yaw", 0.0)) for m, _ in self.obstacles])
        self.cos, self.sin = np.cos(yaw), np.sin(yaw)
        self.delta = np.array([float(d) for _, d in self.obstacles])
        self.radii = np.asarray(robot.collision_radii, dtype=float)
        self.chosen: frozenset[int] = frozenset()
        self.flagged: set[int] = set()
        self.margin = MARGIN
        self.choices = 0

    @property
    def needed(self) -> tuple[tuple[Shape, int], ...]:
        """The slots a library needs to hold every obstacle (the scene's own count)."""
        return tuple((e, len(idx)) for e, idx in sorted(self.kinds.items()) if idx)

    def points(self, Q: Array) -> Array:
        """Collision sphere centres at the states Q (M, n): (M, P, 3)."""
        Q = np.ascontiguousarray(np.atleast_2d(Q)[:, : self.robot.n], dtype=float)
        M, P = len(Q), len(self.radii)
        natives = self.robot.compiled()
        if natives is not None:
            return np.asarray(natives.many("collision_points", Q), dtype=float).reshape(M, P, 3)
        fn = self.robot.functions["collision_points"].map(M)
        return np.asarray(fn(Q.T), dtype=float).T.reshape(M, P, 3)

    def gaps(self, C: Array, which: Sequence[int]) -> Array:
        """gap_o (module docstring) of the obstacles ``which`` at each state of the sphere
        centres C (M, P, 3): the smallest over the spheres, (M, len(which))."""
        idx = np.asarray(which, dtype=int)
        d = C[:, :, None, :] - self.center[idx]  # (M, P, W, 3)
        c, s = self.cos[idx], self.sin[idx]
        local = np.stack(
            [c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1], d[..., 2]], axis=-1
        )
        excess = np.maximum(np.abs(local) - self.semi[idx], 0.0)
        dist = np.sqrt(np.sum(excess * excess, axis=-1)) - self.radii[None, :, None]
        return np.asarray(dist.min(axis=1) - self.delta[idx], dtype=float)

    def start(self, p: Array, q: Array) -> Array:
        """p with the slots' first choice at the start q (a copy); resets the choice."""
        self.chosen, self.flagged, self.margin, self.choices = frozenset(), set(), MARGIN, 0
        return self.choose(p, np.atleast_2d(q))

    def choose(self, p: Array, Q: Array) -> Array:
        """p (a copy) with the slots chosen for the states Q (M, n) (module docstring).

        Raises:
            CrowdedError: more obstacles of a type flagged or within the margin than slots.
        """
        p = np.array(p, dtype=float)
        g = self.gaps(self.points(Q), range(len(self.obstacles))).min(axis=0)
        chosen: list[int] = []
        for e, idx in self.kinds.items():
            starts = self.slots[e]
            must = [i for i in idx if i in self.flagged or g[i] <= self.margin]
            if len(must) > len(starts):
                raise CrowdedError(e, len(must), len(starts))
            rest = sorted((i for i in idx if i not in must), key=lambda i: (g[i], i))
            mine = sorted(must + rest[: len(starts) - len(must)])  # the scene's order
            chosen += mine
            for j, at in enumerate(starts):
                if j < len(mine):
                    model, delta = self.obstacles[mine[j]]
                    put_slot(p, at, model, delta)
                else:
                    park_slot(p, at)
        self.chosen, self.flagged = frozenset(chosen), set()
        self.choices += 1
        return p

    def stuck(self) -> tuple[Shape, int, int]:
        """:class:`CrowdedError`'s arguments for the type of a flagged obstacle: the choice keeps
        missing one (the caller gave up choosing again)."""
        i = min(self.flagged) if self.flagged else 0
        e = shape_of(self.obstacles[i][0])
        near = len(self.chosen & set(self.kinds[e])) + len(self.flagged & set(self.kinds[e]))
        return e, near, len(self.slots[e])

    def first_unsafe(self, Q: Array) -> int:
        """Index of the first state of Q (M, n), consecutive states of the rollout, at which
        an obstacle left out of the slots is within its margin (M when none); flags it."""
        out = [i for i in range(len(self.obstacles)) if i not in self.chosen]
        if not out:
            return len(Q)
        C = self.points(Q)
        step = np.sqrt(np.sum(np.diff(C, axis=0) ** 2, axis=-1)).max() if len(C) > 1 else 0.0
        self.margin = 2.0 * float(step) + MARGIN
        g = self.gaps(C, out)
        hit = np.flatnonzero((g <= self.margin).any(axis=1))
        if not hit.size:
            return len(Q)
        first = int(hit[0])
        self.flagged |= {out[j] for j in np.flatnonzero(g[first] <= self.margin)}
        return first
