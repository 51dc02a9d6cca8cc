r"""More obstacles than a compiled function's slots: which ones the slots hold along a run.

A compiled step holds a fixed number of obstacle slots per shape kind. A scene with more
obstacles of a kind runs it anyway when an obstacle far from the robot contributes exact
zeros (its term is 0 beyond a reach, as the barrier terms of both planner families are): the
slots hold the obstacles near the robot and the others are left out while the robot keeps
away from them. :class:`NearSlots` makes that choice; a planner subclasses it with its
geometry (:meth:`NearSlots.gaps`: how far each obstacle is from mattering, <= 0 where it may
matter) and the way its parameters are written (:meth:`NearSlots.write`):

* ``start(p, q)``: the slots take, per kind, the obstacles with the smallest gap at q;
* ``first_unsafe(Q)`` after a stretch of the run (consecutive states Q): the first state at
  which an obstacle left out is within the margin ``2 m + MARGIN`` (m the largest step of a
  collision sphere in the stretch: the integrator's stages lie between states) is flagged;
  the run keeps the states before it and calls ``choose(p, Q)`` there: the flagged obstacles
  and every obstacle within the margin first, then the nearest;
* :class:`CrowdedError` when more obstacles of a kind are within the margin at once than
  the kind has slots: the planner then uses a function with more slots of that kind
  (:meth:`CrowdedError.grown`), compiled when none is on disk; a first compile holds at most
  :data:`SLOT_CAP` slots of a kind (:func:`capped`).

Used by :mod:`mmplan.planners.extended_jacobian.active` and
:mod:`mmplan.planners.tracking.active`.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from typing import Any

import numpy as np

from mmplan.arrays import Array

#: Most slots of a kind a library is compiled with for a scene with more obstacles of it (the
#: near ones in the slots; :func:`capped`): a new user's scene of 200 obstacles compiled 62
#: cylinder slots in 9.2 s, a tracker's 16 slots in 24.6 s. Grown where the scene is crowded
#: (:meth:`CrowdedError.grown`).
SLOT_CAP = 8
#: Distance [m] an obstacle left out of the slots keeps beyond its reach, besides twice the
#: largest step of a sphere (module docstring).
MARGIN = 0.01


class CrowdedError(Exception):
    """More obstacles of a kind near the robot at once than the function has slots."""

    def __init__(self, kind: Hashable, near: int, slots: int, name: str | None = None) -> None:
        super().__init__(f"{near} {kind if name is None else name} obstacles near at once, "
                         f"{slots} slots")  # fmt: skip
        self.kind, self.near, self.slots = kind, near, slots

    def grown(self, cap: dict[Hashable, int]) -> dict[Hashable, int]:
        """``cap`` (slots per kind a library is compiled with) with this kind's grown to hold
        the obstacles near at once: at least twice its slots, a multiple of 2."""
        need = max(2 * self.slots, self.near + self.near % 2)
        return {**cap, self.kind: max(cap.get(self.kind, 0), need)}


def capped(
    slots: Sequence[tuple[Hashable, int]], cap: dict[Hashable, int] | None
) -> tuple[tuple[Hashable, int], ...]:
    """Slots per kind with at most ``cap``'s count of a kind (:data:`SLOT_CAP` for a kind it
    does not name; None: no cap): a library compiled for a scene of many obstacles holds the
    near ones (module docstring), and its compile stays bounded."""
    if cap is None:
        return tuple(slots)
    return tuple((k, min(n, cap.get(k, SLOT_CAP))) for k, n in slots)


class NearSlots:
    """Which obstacles the slots hold, chosen along a run (module docstring). One instance
    serves one run at a time (:meth:`start` resets it).

    Args:
        robot: The robot (its collision spheres).
        kinds: The kind of each obstacle of the scene.
        capacity: Slots per kind (every kind of ``kinds`` has at least one).
    """

    def __init__(
        self, robot: Any, kinds: Sequence[Hashable], capacity: dict[Hashable, int]
    ) -> None:
        missing = sorted({str(k) for k in kinds if not capacity.get(k)})
        if missing:
            raise ValueError(f"no slot for obstacles of kind {', '.join(missing)}")
        self.robot = robot
        self.count = len(kinds)
        self.capacity = capacity
        self.kinds = {k: [i for i, e in enumerate(kinds) if e == k] for k in capacity}
        self.radii = np.asarray(robot.collision_radii, dtype=float)
        self.chosen: frozenset[int] = frozenset()
        self.flagged: set[int] = set()
        self.margin = MARGIN
        self.choices = 0

    def gaps(self, C: Array, Q: Array, which: Sequence[int]) -> Array:
        """How far [m] each obstacle ``which`` is from mattering at each state: (M, W), from
        the sphere centres C (M, P, 3) and the states Q (M, n); <= 0 where it may matter."""
        raise NotImplementedError

    def write(self, p: Array, chosen: dict[Hashable, list[int]]) -> Array:
        """p (a copy) whose slots hold the obstacles ``chosen`` per kind (in scene order)."""
        raise NotImplementedError

    def label(self, kind: Hashable) -> str:
        """How messages name a kind."""
        return str(kind)

    def points(self, Q: Array) -> Array:
        """Collision sphere centres at the states Q (M, n): (M, P, 3)."""
        return np.asarray(self.robot.collision_points_at(np.atleast_2d(Q)[:, : self.robot.n]))

    def start(self, p: Array, q: Array) -> Array:
        """p with the slots' first choice at the start q (a copy); resets the choice."""
        self.chosen, self.flagged, self.margin, self.choices = frozenset(), set(), MARGIN, 0
        return self.choose(p, np.atleast_2d(q))

    def choose(self, p: Array, Q: Array) -> Array:
        """p (a copy) with the slots chosen for the states Q (M, n) (module docstring).

        Raises:
            CrowdedError: more obstacles of a kind flagged or within the margin than slots.
        """
        Q = np.atleast_2d(Q)
        g = self.gaps(self.points(Q), Q, range(self.count)).min(axis=0)
        chosen: dict[Hashable, list[int]] = {}
        for kind, idx in self.kinds.items():
            room = self.capacity[kind]
            must = [i for i in idx if i in self.flagged or g[i] <= self.margin]
            if len(must) > room:
                raise CrowdedError(kind, len(must), room, self.label(kind))
            rest = sorted((i for i in idx if i not in must), key=lambda i: (g[i], i))
            chosen[kind] = sorted(must + rest[: room - len(must)])  # the scene's order
        self.chosen = frozenset(i for mine in chosen.values() for i in mine)
        self.flagged = set()
        self.choices += 1
        return self.write(np.array(p, dtype=float), chosen)

    def stuck(self) -> CrowdedError:
        """The error for the kind of a flagged obstacle when choosing again keeps missing one
        (the caller gave up)."""
        i = min(self.flagged) if self.flagged else 0
        kind = next(k for k, idx in self.kinds.items() if i in idx)
        mine = set(self.kinds[kind])
        near = len((self.chosen | self.flagged) & mine)
        return CrowdedError(kind, near, self.capacity[kind], self.label(kind))

    def first_unsafe(self, Q: Array) -> int:
        """Index of the first state of Q (M, n), consecutive states of the run, at which an
        obstacle left out of the slots is within its margin (M when none); flags it."""
        Q = np.atleast_2d(Q)
        out = [i for i in range(self.count) if i not in self.chosen]
        if not out:
            return len(Q)
        C = self.points(Q)
        step = 0.0
        if len(C) > 1 and C.shape[1]:
            step = float(np.sqrt(np.sum(np.diff(C, axis=0) ** 2, axis=-1)).max())
        if len(Q) > 1:  # the platform's (x, y) too (a robot without spheres)
            step = max(step, float(np.abs(np.diff(Q[:, :2], axis=0)).max()) * np.sqrt(2.0))
        self.margin = 2.0 * step + MARGIN
        g = self.gaps(C, Q, out)
        hit = np.flatnonzero((g <= self.margin).any(axis=1))
        if not hit.size:
            return len(Q)
        first = int(hit[0])
        self.flagged |= {out[j] for j in np.flatnonzero(g[first] <= self.margin)}
        return first
